"""The averaged SDE's histograms before and after its lanes (issue 44: per-path streams instead
of one stream per block): L1 of p(A), p(x1), p(x2) against each model's closed form, in units
of the run's noise floor, for a few seeds, in the old checkout and this one; and L1 between
the old and the new histograms of the same seed against their combined floor.

    python benchmarks/sde_lanes_law.py --before PYTHON   # -> results/sde_lanes_law.json

The runs are tests/test_averaged_sde_lanes.py's (paper-base, 1024 paths x 2000 time units,
dt and burn-in "auto", x1 and x2 on the folded orbit).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "results" / "sde_lanes_law.json"
MODELS = ("paper", "exact", "corrected")
SEEDS = (11, 12, 13)


def worker() -> dict:
    from vifpk.harness.door.solvers import averaged_sde_solution, closed_form
    from vifpk.harness.workflows.compare import compare

    from vifpk.core.scene import load_scene

    sc = load_scene(ROOT / "scenes" / "paper-base.toml")
    out: dict = {}
    for model in MODELS:
        cf = closed_form(sc, model=model, tail_mass=False)
        top = float(np.asarray(cf.data["A"]["x"])[-1])
        xv = np.asarray(cf.data["x2"]["x"])
        edges = {"edges_A": np.linspace(0.0, top, 49), "edges_x": np.linspace(0.0, top, 49),
                 "edges_v": np.linspace(xv[0], xv[-1], 49)}
        for seed in SEEDS:
            r = averaged_sde_solution(sc, model, edges=edges, seed=seed, phase=True,
                                      paths=1024, blocks=32, dt="auto", time=2000.0,
                                      burn_in="auto", sample_every=0.5)
            for o in ("A", "x1", "x2"):
                err = compare(cf.data[o], r.data[o])
                out[f"{model}/{seed}/{o}"] = {
                    "L1": err["L1"], "L1_floor": err["L1_floor"],
                    "p": np.asarray(r.data[o]["p"]).tolist(),
                    "err": np.asarray(r.data[o]["err"]).tolist(),
                    "dx": np.diff(np.asarray(r.data[o]["edges"])).tolist()}
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", help="python of the checkout before")
    ap.add_argument("--worker", action="store_true")
    a = ap.parse_args()
    if a.worker:
        print(json.dumps(worker()))
        return
    me = Path(__file__).resolve()
    runs = {}
    for side, py in (("before", a.before), ("after", sys.executable)):
        r = subprocess.run([py, str(me), "--worker"], capture_output=True, text=True,
                           check=True, cwd=ROOT, env=os.environ)
        runs[side] = json.loads(r.stdout.strip().splitlines()[-1])
    res: dict = {"L1_over_floor": {}, "old_vs_new": {}}
    for key in runs["after"]:
        b, n = runs["before"][key], runs["after"][key]
        res["L1_over_floor"][key] = {"before": b["L1"] / b["L1_floor"],
                                     "after": n["L1"] / n["L1_floor"]}
        dx = np.asarray(n["dx"])
        l1 = float(np.sum(np.abs(np.asarray(b["p"]) - np.asarray(n["p"])) * dx))
        floor = float(np.sqrt(2 / np.pi) * np.sum(np.hypot(b["err"], n["err"]) * dx))
        res["old_vs_new"][key] = {"L1": l1, "combined_floor": floor, "ratio": l1 / floor}
    for side in ("before", "after"):
        v = [x[side] for x in res["L1_over_floor"].values()]
        res[f"L1_over_floor_{side}"] = {"median": float(np.median(v)), "max": float(max(v))}
    v = [x["ratio"] for x in res["old_vs_new"].values()]
    res["old_vs_new_ratio"] = {"median": float(np.median(v)), "max": float(max(v))}
    res["settings"] = {"scene": "paper-base", "models": MODELS, "seeds": SEEDS, "paths": 1024,
                       "blocks": 32, "time": 2000.0, "dt": "auto", "before": a.before,
                       "combined_floor": "sqrt(2/pi) sum_i hypot(err_old_i, err_new_i) dx_i: "
                                         "the expected L1 between two independent runs"}
    OUT.write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({k: v for k, v in res.items() if k not in ("L1_over_floor",
                                                                   "old_vs_new")}, indent=1))


if __name__ == "__main__":
    main()
