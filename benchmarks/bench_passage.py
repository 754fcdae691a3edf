"""First-passage Monte Carlo speed: path-steps per second of montecarlo.first_passage against
the stationary kernel (montecarlo.simulate, no observables) on the same scene, paths and
time, one thread, the two alternated in one run (so machine load hits both alike); and the
averaged SDE's first passage (sde_time.sde_first_passage, Rayleigh amplitude).

    python benchmarks/bench_passage.py      # writes benchmarks/results/passage.json

Timing: a warm-up call first (compile or cache load apart), then the best of 3.
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from vifpk import montecarlo as mc  # noqa: E402
from vifpk.core.scene import MonteCarloSettings, load_scene  # noqa: E402

PATHS, TIME = 256, 500.0


def main() -> None:
    scene = load_scene(ROOT / "scenes" / "paper-base.toml")
    s, n = scene.system, scene.noise
    fp = mc.PassageSettings(paths=PATHS, blocks=16, dt=0.01, horizon=TIME, seed=1,
                            progress=False, threads=1)
    st = mc.Settings(**{**asdict(MonteCarloSettings()), "paths": PATHS, "blocks": 16,
                        "time": TIME, "burn_in": 0.0, "observables": (), "certificate": False,
                        "progress": False, "threads": 1})
    # threshold 5: never reached from A0 = 1 within the horizon, so every path runs TIME
    mc.first_passage(s, n, fp, threshold=5.0, start=1.0)
    mc.simulate(s, n, st)
    fp_rates, sim_rates = [], []
    for _ in range(3):
        fp_rates.append(mc.first_passage(s, n, fp, threshold=5.0, start=1.0)
                        .info["steps_per_second"])
        sim_rates.append(mc.simulate(s, n, st).info["steps_per_second"])

    def drift(A):
        return -A / 2 + 1 / (2 * A)

    def diffusion(A):
        return 1.0 + 0 * A

    numba.set_num_threads(1)
    kw = dict(threshold=2.0, start=0.5, paths=4000, blocks=16, dt=0.01, horizon=1e4, seed=1)
    mc.sde_first_passage(drift, diffusion, **kw)
    sde = []
    for _ in range(3):
        t0 = time.perf_counter()
        res = mc.sde_first_passage(drift, diffusion, **kw)
        spent = time.perf_counter() - t0
        sde.append(float(np.sum(np.ceil(res.data["fpt"]["time"] / 0.01))) / spent)
    out = {
        "what": "path-steps per second, one thread, paper-base, dt = 0.01, 256 paths x 500 "
                "time units (first_passage: threshold out of reach, every path runs the "
                "horizon); simulate: no observables, no burn-in; SDE: Rayleigh amplitude, "
                "4000 paths to Ac = 2 (MFPT ~ 3.6)",
        "first_passage": max(fp_rates), "simulate": max(sim_rates),
        "ratio_first_passage_to_simulate": max(fp_rates) / max(sim_rates),
        "sde_first_passage": max(sde),
        "load_average_1min": os.getloadavg()[0],
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "versions": {"numba": numba.__version__, "python": platform.python_version()},
    }
    path = ROOT / "benchmarks" / "results" / "passage.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
