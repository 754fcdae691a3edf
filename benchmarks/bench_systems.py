"""Issue 21: does the general system cost the paper's scenes anything? Monte Carlo speed of the
base scene with this tree's kernel against a baseline commit's kernel, IN ONE RUN, and the
speed of the scenes that switch the new terms on.

    python benchmarks/bench_systems.py [--baseline REF] [--candidate REF] [--rounds 3]
    # writes benchmarks/results/systems.json

The baseline (default: main just before the general laws landed, cb059f2) and the candidate
(default: this working tree; f7e5f2c is the landing itself, whose montecarlo/ differs from
cb059f2 by the general laws alone) are exported with ``git archive`` into a temporary
folder; each measurement runs in a fresh interpreter whose
``sys.path`` starts with one tree (so each tree's numba cache is its own), one thread, after a
warm-up call; the trees alternate round by round so that a change of machine load hits both
alike, and the best of the rounds is kept (the least disturbed). The load average before and
after is recorded beside the numbers: on a shared machine only the ratio is meaningful.
Results are bit-identical between the trees for the paper's scenes (tests/test_systems.py
checks the numbers; this measures the time).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "results" / "systems.json"
BASELINE = "cb059f2"

WORKER = r"""
import json, sys, time
from dataclasses import asdict
import numpy as np
from vifpk import montecarlo as mc
try:
    from vifpk.core.scene import MonteCarloSettings, load_scene, scene_from_dict
except ImportError:
    from vifpk.harness.scene import MonteCarloSettings, load_scene, scene_from_dict
EDGES = {"edges_A": np.linspace(0, 2, 101), "edges_x": np.linspace(-2, 2, 101),
         "edges_v": np.linspace(-2, 2, 101)}
name, spec = sys.argv[1], json.loads(sys.argv[2])
scene = load_scene(spec) if isinstance(spec, str) else scene_from_dict(spec)
s = mc.Settings(**asdict(MonteCarloSettings()), certificate=False)
kw = dict(paths=64, blocks=16, dt=0.01, time=1000.0, burn_in=10.0, progress=False, threads=1,
          edges=EDGES, observables=("A", "x1", "x2", "moments", "events"))
t0 = time.perf_counter()
mc.simulate(scene.system, scene.noise, s, **dict(kw, paths=16, time=1.0))
warm = time.perf_counter() - t0
r = mc.simulate(scene.system, scene.noise, s, **kw)
h = float(np.sum(r.data["A"]["p"] * np.arange(r.data["A"]["p"].size)))
print(json.dumps({"steps_per_second": r.info["steps_per_second"], "first_call": warm,
                  "checksum": h, "module": mc.__file__}))
"""

SCENES = {
    "paper-base": "paper-base",
    "quintic (k5 term)": {"system": {"restoring": [1.0, 0.6, 0.2], "c1": 0.025, "c2": 0.05}},
    "damping x^4 term": {"system": {"omega0": 1.0, "alpha": 0.6,
                                    "damping": [-0.025, 0.05, 0.01]}},
    "Rayleigh velocity damping": {"system": {"omega0": 1.0, "alpha": 0.6, "c1": 0.025,
                                             "c2": 0.05, "velocity_damping": [0.05]}},
}


def export(ref: str, dest: Path) -> Path:
    """The baseline tree (montecarlo, harness or vifpk: whatever the commit has) in dest."""
    dest.mkdir(parents=True)
    archive = dest / "tree.tar"
    subprocess.run(["git", "-C", str(ROOT), "archive", "-o", str(archive), ref], check=True)
    with tarfile.open(archive) as t:
        t.extractall(dest / "tree", filter="data")
    return dest / "tree"


def measure(tree: Path, name: str, spec: object) -> dict[str, float]:
    env = {**os.environ, "NUMBA_NUM_THREADS": "1", "PYTHONPATH": str(tree)}
    out = subprocess.run([sys.executable, "-c", WORKER, name, json.dumps(spec)], cwd=tree,
                         env=env, check=True, capture_output=True, text=True).stdout
    res = json.loads(out.strip().splitlines()[-1])
    if not res["module"].startswith(str(tree)):  # the tree asked for, not an installed copy
        raise RuntimeError(f"measured {res['module']}, not the tree {tree}")
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--baseline", default=BASELINE)
    ap.add_argument("--candidate", default=None, help="a commit (default: this working tree)")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    load0 = os.getloadavg()
    t_start = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        base_tree = export(args.baseline, Path(tmp) / "baseline")
        cand = ROOT if args.candidate is None else export(args.candidate, Path(tmp) / "cand")
        rows: dict[str, dict[str, list[float]]] = {}
        for _ in range(args.rounds):
            for label, tree in (("baseline", base_tree), ("candidate", cand)):
                r = measure(tree, "paper-base", "paper-base")
                row = rows.setdefault(f"paper-base, {label}", {"rates": [], "checksum": []})
                row["rates"].append(r["steps_per_second"])
                row["checksum"].append(r["checksum"])
            for name, spec in SCENES.items():
                if name == "paper-base":
                    continue
                r = measure(cand, name, spec)
                rows.setdefault(f"{name}, candidate", {"rates": [], "checksum": []})[
                    "rates"].append(r["steps_per_second"])
    load1 = os.getloadavg()
    best = {k: max(v["rates"]) for k, v in rows.items()}
    ref = best["paper-base, baseline"]
    result = {
        "command": "python benchmarks/bench_systems.py" + (
            f" --baseline {args.baseline}" if args.baseline != BASELINE else "") + (
            f" --candidate {args.candidate}" if args.candidate else "") + (
            f" --rounds {args.rounds}" if args.rounds != 3 else ""),
        "baseline": args.baseline, "candidate": args.candidate or "working tree",
        "rounds": args.rounds,
        "machine": {"python": platform.python_version(), "cpu_count": os.cpu_count()},
        "load_average_before": load0, "load_average_after": load1,
        "wall_seconds": time.time() - t_start,
        "per_core_steps_per_second": {k: {"best": best[k], "all": v["rates"],
                                          "ratio_to_baseline": best[k] / ref}
                                      for k, v in rows.items()},
        "paper_base_same_histogram": len({c for k, v in rows.items() if "paper-base" in k
                                           for c in v["checksum"]}) == 1,
    }
    for k, v in result["per_core_steps_per_second"].items():
        print(f"{k:40s} {v['best'] / 1e6:7.1f} M steps/s/core  x{v['ratio_to_baseline']:.3f}")
    print(f"load average before {load0}, after {load1}")
    OUT.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
