"""Work-precision of the MFPT of the original system: direct Monte Carlo against splitting.

At thresholds both reach (paper-base, Ac = 0.8 and 0.9) each method is run at a few sizes; we
record its wall seconds, its MFPT, its relative standard error (the precision it claims) and
its deviation from the pooled reference (the inverse-variance mean of every estimate at that
threshold; the deviation is the error it made, within a few of its standard errors). At the
thresholds only splitting reaches (--split-only, run with a target relative half-width of
10%), direct simulation's cost is extrapolated from its measured rate: a first-passage time is
close to exponential (sd ~ mean), so a relative standard error e takes ~1/e^2 paths of
mean length T each.

    NUMBA_NUM_THREADS=2 python benchmarks/bench_splitting.py
        [--out benchmarks/results/splitting_work_precision.json]

Direct Monte Carlo is the project's own first passage (harness.door.timedomain.passage_montecarlo,
montecarlo/passage.py), with a horizon far beyond the MFPT (no path censored).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time

import numpy as np
from vifpk.harness.door.timedomain import passage_montecarlo, passage_splitting

from vifpk.core.scene import load_scene

START = 0.4


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="paper-base")
    ap.add_argument("--thresholds", default="0.8,0.9")
    ap.add_argument("--split-only", default="1.1")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "results",
                                                  "splitting_work_precision.json"))
    a = ap.parse_args()
    sc = load_scene(a.scene)
    dt = 0.01
    rows, rate = [], []
    for Ac in (float(v) for v in a.thresholds.split(",")):
        here = []
        for paths in (96, 384):  # whole multiples of the 32 blocks
            t = time.perf_counter()
            d = passage_montecarlo(sc, threshold=Ac, start=START, horizon=1e6, paths=paths,
                                   dt=dt, seed=paths, progress=False)
            sec = time.perf_counter() - t
            ft = d.data["fpt"]["time"]
            assert not d.data["fpt"]["censored"].any()
            rate.append(ft.sum() / sec)  # simulated time units (all paths) a second
            here.append({"method": "direct", "threshold": Ac, "paths": paths, "seconds": sec,
                         "value": float(ft.mean()),
                         "stderr": float(ft.std(ddof=1) / math.sqrt(paths))})
        for groups, particles in ((10, 50), (10, 100), (20, 200)):
            t = time.perf_counter()
            r = passage_splitting(sc, threshold=Ac, start=START, groups=groups,
                                  particles=particles, dt=dt, seed=groups * particles)
            sec = time.perf_counter() - t
            m = r.info["mfpt"]
            here.append({"method": "splitting", "threshold": Ac, "groups": groups,
                         "particles": particles, "seconds": sec, "value": m["value"],
                         "stderr": m["stderr"], "p": m["p"]["value"]})
        w = np.array([1 / r["stderr"] ** 2 for r in here])
        ref = float(np.sum(w * [r["value"] for r in here]) / w.sum())
        for r in here:
            r["reference"] = ref
            r["relative_stderr"] = r["stderr"] / r["value"]
            r["relative_error"] = r["value"] / ref - 1
            print(json.dumps(r), flush=True)
        rows += here
    direct_rate = float(np.median(rate))
    for Ac in (float(v) for v in a.split_only.split(",") if v):
        t = time.perf_counter()
        r = passage_splitting(sc, threshold=Ac, start=START, groups=10, dt=dt, rel_ci=0.1,
                              budget=900)
        sec = time.perf_counter() - t
        m = r.info["mfpt"]
        e = m["stderr"] / m["value"]
        row = {"method": "splitting", "threshold": Ac, "groups": r.info["groups"],
               "particles": 200, "seconds": sec, "value": m["value"], "stderr": m["stderr"],
               "relative_stderr": e, "p": m["p"]["value"], "target": r.info["target"],
               "direct_seconds_for_same_stderr": m["value"] / e**2 / direct_rate}
        print(json.dumps(row), flush=True)
        rows.append(row)
    out = {"scene": a.scene, "start": START, "dt": dt, "rows": rows,
           "direct_rate_time_units_per_second": direct_rate,
           "threads": os.environ.get("NUMBA_NUM_THREADS", "default"),
           "machine": platform.node(), "load": os.getloadavg(),
           "note": "direct cost extrapolated as T / e^2 / rate (exponential FPT: sd ~ mean)"}
    with open(a.out + ".tmp", "w") as fh:
        json.dump(out, fh, indent=1)
    os.replace(a.out + ".tmp", a.out)
    print(f"direct rate {direct_rate:.3g} time units / s")


if __name__ == "__main__":
    main()
