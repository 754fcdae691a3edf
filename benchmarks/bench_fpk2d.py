"""Accuracy against time and memory of the original system's FPK (vifpk.fpk2d, issue 46 item 5),
the Monte Carlo beside, on the Gibbs truth scene (scenes/systems/gibbs-quintic.toml: the
closed form is known, tests/test_fpk2d.py).

    python benchmarks/bench_fpk2d.py [--quick]

For n = 40 ... 320 (--quick: ... 160) cells a side: the L1 of p(A) on the Monte Carlo's 100
bins against the closed form, the CPU seconds of one solve (process_time), the LU's factor
size; then the Monte Carlo (`vifpk.solve(..., "montecarlo", floor=F)`) at floors 0.02 and
0.01 (--quick: 0.02): its L1 against the closed form, its floor, its CPU seconds (both
threads counted). Writes benchmarks/results/fpk2d.json.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import quad
from scipy.special import erf
from vifpk.fpk2d.observables import marginals
from vifpk.harness.workflows.compare import bin_average

import vifpk
from vifpk import fpk2d

ROOT = Path(__file__).resolve().parents[1]
SCENE = "systems/gibbs-quintic"
K, D0, D = (1.0, 0.3, 0.2), 0.1, 0.01
T = D / D0


def U(x: float) -> float:
    return K[0] * x * x / 2 + K[1] * x ** 4 / 4 + K[2] * x ** 6 / 6


def gibbs_cdf(a: np.ndarray) -> np.ndarray:
    total = quad(lambda x: math.exp(-U(x) / T), 0.0, np.inf)[0]
    return np.array([quad(lambda x, ua: math.exp(-U(x) / T) * erf(math.sqrt(max(ua - U(x), 0)
                                                                           / T)),
                          0.0, ai, args=(U(ai),), limit=200)[0] / total if ai > 0 else 0.0
                     for ai in a])


def main() -> None:
    quick = "--quick" in sys.argv
    sc = vifpk.scene(SCENE)
    c = fpk2d.coefficients(sc.system, sc.noise)
    E = fpk2d.choose_energy(c, 1e-9)[0]
    edges = np.linspace(0.0, float(c.amplitude(np.array([E]))[0]), 101)
    exact = np.diff(gibbs_cdf(edges))
    A = np.linspace(0.0, edges[-1], 801)
    rows = []
    for n in (40, 80, 160) if quick else (40, 80, 160, 320):
        t0 = time.process_time()
        sol = fpk2d.solve_grid(c, E, n)
        rec = marginals(c, sol.grid, sol.p, A)["data"]["A"]
        sec = time.process_time() - t0
        l1 = float(np.sum(np.abs(bin_average(rec, edges) * np.diff(edges) - exact)))
        rows.append({"cells": n, "L1_A": l1, "cpu_seconds": sec,
                     "solve_cpu_seconds": sol.seconds})
        print(f"fpk2d {n}^2: L1 {l1:.2e}, {sec:.2f} s CPU", flush=True)
    mc = []
    for floor in (0.02,) if quick else (0.02, 0.01):
        t0 = time.process_time()
        res = vifpk.solve(SCENE, "montecarlo", floor=floor, budget=1200)
        sec = time.process_time() - t0
        h = res.data["A"]
        e = np.asarray(h["edges"])
        ex = np.diff(gibbs_cdf(e))
        l1 = float(np.sum(np.abs(np.asarray(h["p"]) * np.diff(e) - ex)))
        mc.append({"floor_asked": floor, "L1_floor": res.info["L1_floor"]["A"], "L1_A": l1,
                   "cpu_seconds": sec})
        print(f"montecarlo floor {floor}: L1 {l1:.3g} (floor {res.info['L1_floor']['A']:.3g})"
              f", {sec:.1f} s CPU", flush=True)
    dest = ROOT / "benchmarks" / "results" / "fpk2d.json"
    dest.write_text(json.dumps({"scene": SCENE, "fpk2d": rows, "montecarlo": mc,
                                "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                                "note": "2 cores shared with other jobs: CPU seconds"},
                               indent=1))
    print("wrote", dest)


if __name__ == "__main__":
    main()
