"""The averaged models' first-passage routes: seconds per call on paper-base.

    python benchmarks/bench_passage_averaged.py   # writes benchmarks/results/passage_averaged.json

For each model (paper, exact, corrected) and threshold, from the model's stationary start:
the MFPT quadrature (fpk.mfpt, two grids, refined to rtol 1e-9) and the time-stepped R(t)
(fpk.reliability, 400 cells, BDF), through the door (harness.door.timedomain.passage_averaged) and
apart. Timing: benchmarks/timing.py (a first call, then the minimum of ``REPEATS`` warm calls); the
1-minute load average is recorded beside (the machine is shared).
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from timing import timed  # noqa: E402
from vifpk.harness.door.solvers import averaged_model
from vifpk.harness.door.timedomain import passage_averaged  # noqa: E402

import vifpk  # noqa: E402
from vifpk import fpk  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
THRESHOLDS = (0.5, 0.8, 1.0)
REPEATS = 2


def main() -> None:
    scene = vifpk.scene("paper-base")
    rows = []
    for name in ("paper", "exact", "corrected"):
        m = averaged_model(scene, name)
        for ac in THRESHOLDS:
            res = passage_averaged(scene, name, threshold=ac, start="stationary")
            q = timed(lambda m=m, ac=ac: fpk.mfpt(m.drift, m.diffusion, threshold=ac,
                                                  start="stationary"), repeats=REPEATS)
            r = timed(lambda m=m, ac=ac: fpk.reliability(m.drift, m.diffusion, threshold=ac,
                                                         start="stationary"),
                      repeats=REPEATS)
            rows.append({"model": name, "threshold": ac, "mfpt": res.info["mfpt"],
                         "mfpt_integral": res.info["mfpt_integral"],
                         "routes_gap_relative": res.info["diagnostics"]["routes_gap"]
                         / res.info["mfpt"],
                         "quadrature_s": q, "reliability_s": r,
                         "door_total_s": res.info["seconds"]["total"]
                         + res.info["quadrature"]["seconds"]})
            print(f"{name:9s} Ac={ac:4.2f} T={res.info['mfpt']:10.4g} "
                  f"quad {q['min']:6.3f} s  R(t) {r['min']:6.2f} s  "
                  f"gap {rows[-1]['routes_gap_relative']:.1e}")
    out = {"command": "python benchmarks/bench_passage_averaged.py", "scene": "paper-base",
           "start": "stationary", "cells": 400, "rows": rows,
           "load_average_1min": os.getloadavg()[0],
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
           "machine": {"python": platform.python_version(), "processor": platform.machine()}}
    path = ROOT / "benchmarks" / "results" / "passage_averaged.json"
    path.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
