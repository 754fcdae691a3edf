"""The main job, ``vifpk check scenes/paper-base.toml``, before and after, in one run (issue 44:
at most 6 s warm on 2 cores).

    python benchmarks/bench_check.py --before <python of the other checkout> [--rounds N]
        [--floor]                                            # -> results/check.json

Each command runs as a user runs it: a fresh process, ``python -m vifpk check
scenes/paper-base.toml --out DIR --quiet`` from the checkout's root, with the interpreter whose
editable install is that checkout (``--before``; this one: sys.executable), on every core,
PYTHONDONTWRITEBYTECODE unset (the sandbox sets it; it adds 0.3-0.5 s to every start). Warm:
numba's on-disk cache of each checkout is filled by a first run that is not timed. The rounds
alternate before / after, so that the machine's load hits both alike. Recorded per run: wall
seconds, CPU seconds of the process (user + system, getrusage of the children), the check's
own stage times and solver seconds (metrics.json ``timings``), the load average; per checkout
the medians, and the ratios before / after of the medians.

``--floor``: also ``solve paper-base --solver montecarlo --floor 0.005`` (issue 22's second
job), the same way.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SCENE = "scenes/paper-base.toml"


def _root_of(python: str) -> Path:
    """The checkout an interpreter's vifpk is installed from (editable)."""
    out = subprocess.run([python, "-c", "import vifpk.harness, pathlib; print(pathlib.Path("
                          "vifpk.harness.__file__).resolve().parents[1])"],
                         capture_output=True, text=True, check=True)
    return Path(out.stdout.strip())


def _timed(python: str, root: Path, args: list[str]) -> tuple[float, float]:
    """(wall, CPU) seconds of ``python -m vifpk ARGS`` run from ``root``."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([python, "-m", "vifpk", *args], cwd=root, env=env, check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def _check(python: str, root: Path, work: Path, tag: str) -> dict:
    out = work / f"check-{tag}"
    wall, cpu = _timed(python, root, ["check", SCENE, "--out", str(out), "--quiet"])
    m = json.loads((out / "metrics.json").read_text())
    t = m.get("timings", {})
    return {"wall_seconds": wall, "cpu_seconds": cpu, "in_check_seconds": t.get("wall_seconds"),
            "stages": t.get("stages", {}), "solutions": t.get("solutions", {}),
            "mc_dt": m["monte_carlo"]["settings"]["dt"],
            "classes": {k: v.get("verdict_class") for k, v in m["models"].items()},
            "load_average": os.getloadavg()[0]}


def _floor(python: str, root: Path, work: Path, tag: str) -> dict:
    js = work / f"floor-{tag}.json"
    wall, cpu = _timed(python, root, ["solve", "paper-base", "--solver", "montecarlo",
                                      "--floor", "0.005", "--json", str(js)])
    info = json.loads(js.read_text())["info"]
    js.unlink()
    return {"wall_seconds": wall, "cpu_seconds": cpu,
            "simulate_seconds": info["seconds"]["total"], "dt": info["settings"]["dt"],
            "floor": info["L1_floor"]["A"], "load_average": os.getloadavg()[0]}


def _medians(rows: list[dict]) -> dict:
    out = {k: statistics.median(r[k] for r in rows)
           for k in ("wall_seconds", "cpu_seconds") if rows}
    stages = {s for r in rows for s in r.get("stages", {})}
    out["stages"] = {s: statistics.median(r["stages"].get(s, 0.0) for r in rows)
                     for s in sorted(stages)}
    if rows and rows[0].get("in_check_seconds") is not None:
        out["outside_check_seconds"] = statistics.median(
            r["wall_seconds"] - r["in_check_seconds"] for r in rows)
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True, help="python of the checkout to compare with")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--floor", action="store_true", help="also time solve --floor 0.005")
    a = ap.parse_args()
    pythons = {"before": a.before, "after": sys.executable}
    roots = {k: _root_of(p) for k, p in pythons.items()}
    res: dict = {"command": f"vifpk check {SCENE}", "cpus": os.cpu_count(),
                 "load_average_start": os.getloadavg(),
                 "checkouts": {k: str(v) for k, v in roots.items()}}
    jobs = {"check": _check, **({"floor_0.005": _floor} if a.floor else {})}
    rows: dict = {tag: {j: [] for j in jobs} for tag in pythons}
    with tempfile.TemporaryDirectory(prefix="vifpk-bench-check-") as tmp:
        work = Path(tmp)
        for tag in pythons:  # warm numba's cache of each checkout
            for fn in jobs.values():
                fn(pythons[tag], roots[tag], work, f"warm-{tag}")
        for i in range(a.rounds):
            for tag in (("before", "after") if i % 2 == 0 else ("after", "before")):
                for j, fn in jobs.items():
                    r = fn(pythons[tag], roots[tag], work, f"{tag}-{i}")
                    rows[tag][j].append(r)
                    print(f"round {i} {tag} {j}: wall {r['wall_seconds']:.2f} s, CPU "
                          f"{r['cpu_seconds']:.2f} s, load {r['load_average']:.1f}",
                          file=sys.stderr, flush=True)
    res["runs"] = rows
    res["medians"] = {tag: {j: _medians(rows[tag][j]) for j in jobs} for tag in pythons}
    res["ratio_before_over_after"] = {
        j: {k: res["medians"]["before"][j][k] / res["medians"]["after"][j][k]
            for k in ("wall_seconds", "cpu_seconds")} for j in jobs}
    res["load_average_end"] = os.getloadavg()
    out = ROOT / "benchmarks" / "results" / "check.json"
    out.write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({k: res[k] for k in ("medians", "ratio_before_over_after")}, indent=1))


if __name__ == "__main__":
    main()
