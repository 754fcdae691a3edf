"""Which side is biased where vifpk's p(A) and the RK4 reference's differ (issue 44: on
paper-base bench_rk4_floor.py measured L1 0.0158 between them against 0.0070 of the two
floors). Independent evidence, all on the same histogram edges and the same sampled time:

- vifpk at its auto step and at 1/4 of it (the bias ladder: its own step's bias);
- the RK4 reference (bench_rk4_floor.rk4_block) at dt = 0.01 and 0.005 (an O(dt) bias of the
  reference, e.g. from the wall or the friction switch, halves);
- the RK4 reference with twice the burn-in, and its first half of sampled time against its
  second half (a start that has not relaxed);
- two seeds of each side (the spread of L1 between independent runs of the same model: with
  a slow amplitude a block's paths move the whole histogram together, so L1 of noise alone
  is far from its mean sum sqrt(2/pi) se_i w_i in a single pair).

Beside each L1: the pair's floor sum sqrt(2/pi) sqrt(se_i^2 + se'_i^2) w_i (its expected
value under noise alone) and the mean amplitude E[A] (from the histogram, per block) with its
standard error: a bias of the energy balance moves E[A], a scalar whose noise is Gaussian
(z-scores below are the difference over the combined standard error).

    NUMBA_NUM_THREADS=1 python benchmarks/bench_rk4_discrepancy.py [--time 4000]
        # -> benchmarks/results/rk4_discrepancy.json
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_rk4_floor import _coefficients, _load, _rk4_kernels  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "rk4_discrepancy.json"
FLOOR = 0.005  # the target floor whose auto step is vifpk's "auto"


def _summary(blocks: np.ndarray, edges: np.ndarray) -> dict:
    """p, se per bin and E[A] +- se from per-block densities (bin centres)."""
    w = np.diff(edges)
    c = 0.5 * (edges[1:] + edges[:-1])
    nb = blocks.shape[0]
    mean_a = blocks @ (c * w)
    return {"p": blocks.mean(axis=0), "se": blocks.std(axis=0, ddof=1) / math.sqrt(nb),
            "mean_A": float(mean_a.mean()),
            "mean_A_se": float(mean_a.std(ddof=1) / math.sqrt(nb)), "blocks": blocks}


def _all_edges(scene, ea: np.ndarray) -> dict:
    """The kernel's three histograms' edges from p(A)'s (as bench_dt_bias.py)."""
    from vifpk.montecarlo.plan import physics
    from vifpk.montecarlo.tuning import _spring
    phys = physics(scene.system, scene.noise)
    a_hi = float(ea[-1])
    vmax = math.sqrt(2 * sum(c * a_hi ** (2 * i + 2) / (2 * i + 2)
                              for i, c in enumerate(_spring(phys))))
    return {"edges_A": ea, "edges_x": np.linspace(0.0 if phys["lower"] is not None else -a_hi,
                                                   a_hi, ea.size),
            "edges_v": np.linspace(-vmax, vmax, ea.size)}


def run_vifpk(name: str, dt: float | str, seed: int, T: float, edges, burn_in) -> dict:
    import numba

    from vifpk import montecarlo
    numba.set_num_threads(1)
    scene = _load(name)
    st = montecarlo.Settings(**{**dataclasses.asdict(scene.montecarlo), "dt": dt,
                                "floor": 0.0, "time": T, "threads": 1, "seed": seed,
                                "burn_in": burn_in, "dt_check": False,
                                "edges": {} if edges is None else _all_edges(scene, edges)},
                             observables=("A",), progress=False)
    c0 = time.process_time()
    r = montecarlo.simulate(scene.system, scene.noise, st)
    a = r.data["A"]
    e = np.asarray(a["edges"], float)
    out = _summary(np.asarray(a["p_blocks"], float), e)
    out.update(edges=e, cpu=time.process_time() - c0, dt=r.info["settings"]["dt"],
               amplitude=(r.info.get("dt_rule") or {}).get("amplitude"),
               burn_in=r.info["settings"]["burn_in"])
    return out


def run_rk4(name: str, dt: float, seed: int, T: float, edges: np.ndarray, burn_in: float
            ) -> dict:
    """The reference of bench_rk4_floor.py at step dt (its OU record made for dt), 32 x 32
    paths from rest at x = 0.3, burn_in, then T sampled in two halves (kept apart)."""
    import bench_rk4_floor as b
    b.DT_RK4 = dt  # _coefficients reads it (the OU's exact update over dt)
    block = _rk4_kernels()
    scene = _load(name)
    c, ou, walls = _coefficients(scene)
    nb, per = 32, 32
    stride = round(0.5 / dt)
    halves = np.zeros((2, nb, edges.size - 1))
    samples = np.zeros((2, nb))
    gens = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(nb)]
    state = np.zeros((nb, per, 2))
    state[..., 0] = 0.3
    xi = np.zeros((nb, per))
    w = np.diff(edges)
    c0 = time.process_time()
    burn = round(burn_in / dt)
    chunk = round(250.0 / dt)
    n_chunks = max(round(T / 250.0), 2)
    for k in range(n_chunks):
        half = 0 if k < n_chunks // 2 else 1
        n = chunk + (burn if k == 0 else 0)
        for j in range(nb):
            normals = gens[j].standard_normal((per, n))
            samples[half, j] += block(state[j], xi[j], normals, n, burn if k == 0 else 0,
                                      stride, dt, c, ou, walls, edges[0], 1.0 / w[0],
                                      halves[half, j])
    cpu = time.process_time() - c0
    both = halves.sum(axis=0) / (samples.sum(axis=0)[:, None] * w)
    out = _summary(both, edges)
    out.update(cpu=cpu, dt=dt, burn_in=burn_in,
               first_half=_summary(halves[0] / (samples[0][:, None] * w), edges),
               second_half=_summary(halves[1] / (samples[1][:, None] * w), edges))
    return out


def compare(a: dict, b: dict, w: np.ndarray) -> dict:
    l1 = float(np.sum(np.abs(a["p"] - b["p"]) * w))
    floor = float(np.sum(math.sqrt(2 / math.pi) * np.hypot(a["se"], b["se"]) * w))
    d = a["mean_A"] - b["mean_A"]
    se = math.hypot(a["mean_A_se"], b["mean_A_se"])
    return {"L1": l1, "floor": floor, "L1_over_floor": l1 / floor,
            "bias_est": math.sqrt(max(l1 * l1 - floor * floor, 0.0)),
            "dmean_A": d, "dmean_A_se": se, "z": d / se}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="paper-base")
    ap.add_argument("--time", type=float, default=4000.0)
    ap.add_argument("--runs", nargs="+", default=[
        "vifpk:auto:1", "vifpk:auto:2", "vifpk:fine:1", "rk4:0.01:1", "rk4:0.01:2",
        "rk4:0.005:1", "rk4long:0.01:3"],
        help="side:dt:seed; dt 'fine' = vifpk's auto step / 4; rk4long: twice the burn-in")
    a = ap.parse_args()
    load0 = os.getloadavg()
    # the auto step at floor 0.005 (what bench_rk4_floor.py's vifpk runs use), from a short
    # pilot run's amplitude; its edges and burn-in are every run's
    from vifpk.montecarlo.plan import physics
    from vifpk.montecarlo.tuning import auto_dt
    pilot = run_vifpk(a.scene, "auto", 1, 20.0, None, "auto")
    edges, burn = pilot["edges"], pilot["burn_in"]
    sc = _load(a.scene)
    h_auto = auto_dt(FLOOR, physics(sc.system, sc.noise), pilot["amplitude"])
    runs: dict = {}
    for key in a.runs:
        if key in runs:
            continue
        side, dt, seed = key.split(":")
        if side == "vifpk":
            h = h_auto / 4 if dt == "fine" else (h_auto if dt == "auto" else float(dt))
            runs[key] = run_vifpk(a.scene, h, int(seed), a.time, edges, burn)
        else:
            runs[key] = run_rk4(a.scene, float(dt), int(seed), a.time, edges,
                                burn * (2 if side == "rk4long" else 1))
        r = runs[key]
        print(key, f"dt {r['dt']:.5g} cpu {r['cpu']:.1f} E[A] {r['mean_A']:.5f} "
              f"+- {r['mean_A_se']:.5f}", flush=True)
    w = np.diff(edges)
    pairs = {f"{x} vs {y}": compare(runs[x], runs[y], w)
             for x, y in itertools.combinations(runs, 2)}
    halves = {k: compare(r["first_half"], r["second_half"], w)
              for k, r in runs.items() if "first_half" in r}
    for k, v in {**pairs, **{f"{k} halves": v for k, v in halves.items()}}.items():
        print(f"{k:34s} L1 {v['L1']:.4f} floor {v['floor']:.4f} ({v['L1_over_floor']:.2f}x) "
              f"dE[A] {v['dmean_A']:+.5f} +- {v['dmean_A_se']:.5f} (z {v['z']:+.1f})")
    res = {"scene": a.scene, "time": a.time, "burn_in": burn, "dt_auto": h_auto,
           "edges": edges.tolist(),
           "runs": {k: {"dt": r["dt"], "cpu": r["cpu"], "burn_in": r["burn_in"],
                        "mean_A": r["mean_A"], "mean_A_se": r["mean_A_se"],
                        "p": r["p"].tolist(), "se": r["se"].tolist()}
                    for k, r in runs.items()},
           "pairs": pairs, "halves": halves,
           "machine": {"load_average_start": load0, "load_average_end": os.getloadavg(),
                       "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}}
    old = json.loads(OUT.read_text()) if OUT.exists() else {}
    old[a.scene] = res
    OUT.write_text(json.dumps(old, indent=1) + "\n")


if __name__ == "__main__":
    main()
