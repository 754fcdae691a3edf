"""Seed-to-seed spread of a check's distances against their reported error bars (issue 29).

The same scene checked with N root seeds (everything else equal): per model and metric (L1,
KS, W1 of p(A)) the mean over seeds, the standard deviation over seeds, the mean of the
reported error bar (``*_err``) and the coverage: the fraction of seeds whose interval value
+/- err (and +/- 2 err) holds the mean over seeds (the expectation of the measured distance at
this sample size). Recorded in benchmarks/results/seed_spread.json (docs/report.md quotes it).

    python benchmarks/seed_spread.py [--seeds 24] [--paths 256] [--time 500]
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
from vifpk.harness.workflows.check import cross_check

from vifpk.core.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
METRICS = ("L1", "ks", "w1")


def summary(runs: list[dict]) -> dict:
    out = {}
    for m in runs[0]["models"]:
        out[m] = {}
        for k in METRICS:
            v = np.array([r["models"][m][k] for r in runs])
            err = np.array([r["models"][m][f"{k}_err"] for r in runs])
            floor = np.array([r["models"][m][f"{k}_floor"] for r in runs])
            mean = float(v.mean())
            out[m][k] = {"mean": mean, "std_over_seeds": float(v.std(ddof=1)),
                         "mean_err": float(err.mean()), "mean_floor": float(floor.mean()),
                         "coverage_1err": float(np.mean(np.abs(v - mean) <= err)),
                         "coverage_2err": float(np.mean(np.abs(v - mean) <= 2 * err))}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default=str(ROOT / "scenes" / "paper-base.toml"))
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--paths", type=int, default=256)
    ap.add_argument("--time", type=float, default=500.0)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "seed_spread.json"))
    a = ap.parse_args()
    base = load_scene(a.scene).with_values({"montecarlo.paths": a.paths,
                                            "montecarlo.time": a.time})
    runs = []
    t0 = time.perf_counter()
    for seed in range(1, a.seeds + 1):
        res = cross_check(base.with_values({"montecarlo.seed": seed}), quiet=True, fpk=False,
                          sde=False, tail_mass=False)
        runs.append({"seed": seed, "models": {
            m: {k: e["averaging_error"]["A"][k] for k in
                [x for k in METRICS for x in (k, f"{k}_err", f"{k}_floor")]}
            for m, e in res.metrics["models"].items()},
            "extensions": res.metrics["monte_carlo"]["convergence"].get("extensions", 0)})
        print(seed, {m: round(v["L1"], 4) for m, v in runs[-1]["models"].items()}, flush=True)
    doc = {"scene": a.scene, "command": "python benchmarks/seed_spread.py "
           f"--seeds {a.seeds} --paths {a.paths} --time {a.time}",
           "seconds": time.perf_counter() - t0, "runs": runs, "summary": summary(runs)}
    Path(a.out).write_text(json.dumps(doc, indent=1))
    print(json.dumps(doc["summary"], indent=1))
    assert all(math.isfinite(r["models"][m]["L1"]) for r in runs for m in r["models"])


if __name__ == "__main__":
    main()
