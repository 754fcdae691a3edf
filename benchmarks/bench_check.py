"""Wall time of the main job and of the floor-0.005 Monte Carlo (issue 22), optionally against
another checkout in the same run (alternated, so that the machine's load hits both alike).

    python benchmarks/bench_check.py [--against PATH] [--repeats N]   # -> results/check.json

Each command runs as a user runs it, in a fresh process from the checkout's root
(``python -m vifpk ...``), warm: numba's on-disk cache is filled by a first run that is not
timed. Timed: wall seconds of the process, and for ``check`` the stage times it writes into
metrics.json (``timings.stages``).

1. ``check paper-base`` (issue 22 target: at most 10 s wall warm on 2 cores).
2. ``solve paper-base --solver montecarlo --floor 0.005 --dt auto`` (target: at most 3 s; the
   simulation's own seconds from its JSON, and the process's wall time).
3. ``solve ... --floor 0.005`` without ``--dt`` (the step now follows the floor).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _run(tree: Path, args: list[str]) -> float:
    env = {**os.environ, "PYTHONPATH": str(tree)}
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "harness", *args], cwd=tree, env=env, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def _check(tree: Path, work: Path, tag: str) -> dict:
    out = work / f"check-{tag}"
    wall = _run(tree, ["check", "paper-base", "--out", str(out), "--quiet"])
    metrics = json.loads((out / "metrics.json").read_text())
    return {"wall_seconds": wall, "stages": metrics.get("timings", {}).get("stages", {}),
            "load_average": os.getloadavg()}


def _floor(tree: Path, work: Path, tag: str, dt: bool) -> dict:
    js = work / f"floor-{tag}-{int(dt)}.json"
    args = ["solve", "paper-base", "--solver", "montecarlo", "--floor", "0.005",
            "--json", str(js)] + (["--dt", "auto"] if dt else [])
    wall = _run(tree, args)
    info = json.loads(js.read_text())["info"]
    js.unlink()
    return {"wall_seconds": wall, "simulate_seconds": info["seconds"]["total"],
            "dt": info["settings"]["dt"], "floor": info["L1_floor"]["A"],
            "load_average": os.getloadavg()}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--against", type=Path, help="another checkout to time in the same run")
    ap.add_argument("--repeats", type=int, default=1)
    a = ap.parse_args()
    trees = {"this": ROOT}
    if a.against:
        trees["against"] = a.against.resolve()
    res: dict = {"load_average_start": os.getloadavg(), "trees": {k: str(v) for k, v in
                                                                   trees.items()}}
    with tempfile.TemporaryDirectory(prefix="vifpk-bench-check-") as tmp:
        work = Path(tmp)
        for tag, tree in trees.items():  # warm numba's cache in each checkout
            _check(tree, work, f"warm-{tag}")
            _floor(tree, work, f"warm-{tag}", True)
        rows: dict = {tag: {"check": [], "floor_0.005_dt_auto": [], "floor_0.005": []}
                      for tag in trees}
        for i in range(a.repeats):
            for tag, tree in trees.items():
                rows[tag]["check"].append(_check(tree, work, f"{tag}-{i}"))
                rows[tag]["floor_0.005_dt_auto"].append(_floor(tree, work, tag, True))
                rows[tag]["floor_0.005"].append(_floor(tree, work, tag, False))
                print(tag, json.dumps(rows[tag], indent=None)[:400], file=sys.stderr,
                      flush=True)
    res["runs"] = rows
    res["load_average_end"] = os.getloadavg()
    out = ROOT / "benchmarks" / "results" / "check.json"
    out.write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
