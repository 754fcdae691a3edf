"""What numba does in a vifpk command, per compiled function: cold (an empty cache: which
functions compile, for which types, how long) and warm (which cache entries load, how long).

    python benchmarks/bench_cold_start.py --rounds 2 OLD_DIR:OLD_PYTHON NEW_DIR:NEW_PYTHON
    python benchmarks/bench_cold_start.py --check ...   # `vifpk check scenes/paper-base.toml`
    python benchmarks/bench_cold_start.py --ahead ...   # the same check, the averaged SDE's
    # kernel compiled beside it by a second process sharing the cache (cold_start_ahead.json)
    # -> benchmarks/results/cold_start.json (--check: cold_start_check.json)

Each round runs every checkout in turn (alternating), each twice in fresh processes from that
checkout's directory with its own interpreter and a fresh NUMBA_CACHE_DIR: first cold (the
directory empty), then warm (on what the cold run wrote). ``--probe ARGS`` wraps numba's
``Dispatcher.compile`` (a cache load or a compile, for one signature) and records, per
(function, signature), the wall and CPU seconds (CPU of the calling thread:
time.thread_time, since the blocks' threads may compile concurrently) and whether the cache
served it; nested calls (a kernel's callees compile inside its compile) are recorded apart,
``self`` excludes them. Then it runs the vifpk command line with ARGS. Without
PYTHONDONTWRITEBYTECODE (bench_fixed_costs.py says why): the cold run writes the .pyc files a
newcomer's first run writes.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
SOLVE = ["solve", "scenes/paper-base.toml", "--solver", "montecarlo", "--floor", "0.005",
         "--dt", "auto", "--json", "{tmp}/solve.json"]
CHECK = ["check", "scenes/paper-base.toml", "--out", "{tmp}/report"]


def probe(argv: list[str], out: str) -> None:
    """Run ``vifpk ARGV`` with numba's compile/cache-load calls timed; write JSON to ``out``."""
    from numba.core import dispatcher

    events: list[dict] = []
    local = threading.local()
    t_start = time.perf_counter()
    orig = dispatcher.Dispatcher.compile

    def compile(self, sig):  # noqa: A001 - numba's name
        stack = getattr(local, "stack", None)
        if stack is None:
            stack = local.stack = []
        mod = getattr(self.py_func, "__module__", None) or "?"
        key = mod.rsplit(".", 1)[-1] + "." + self.py_func.__qualname__
        hits = sum(self._cache_hits.values())
        misses = sum(self._cache_misses.values())
        rec = {"fn": key, "sig": str(sig), "thread": threading.current_thread().name,
               "depth": len(stack), "start": time.perf_counter() - t_start, "child": 0.0,
               "child_cpu": 0.0}
        stack.append(rec)
        w, c = time.perf_counter(), time.thread_time()
        try:
            return orig(self, sig)
        finally:
            stack.pop()
            rec["wall"] = time.perf_counter() - w
            rec["cpu"] = time.thread_time() - c
            rec["self"] = rec["wall"] - rec["child"]
            rec["self_cpu"] = rec["cpu"] - rec["child_cpu"]
            rec["what"] = ("load" if sum(self._cache_hits.values()) > hits else
                           "compile" if sum(self._cache_misses.values()) > misses else "had")
            if stack:
                stack[-1]["child"] += rec["wall"]
                stack[-1]["child_cpu"] += rec["cpu"]
            if rec["what"] != "had":
                events.append(rec)

    dispatcher.Dispatcher.compile = compile
    from vifpk.harness.cli.entry import main

    sys.argv = ["vifpk", *argv]
    c0, w0 = time.process_time(), time.perf_counter()
    code = 0
    try:
        code = main()
    except SystemExit as e:
        code = e.code
    Path(out).write_text(json.dumps({
        "exit": code, "wall": time.perf_counter() - w0, "cpu": time.process_time() - c0,
        "events": events}, indent=1))


def ahead(scene: str) -> None:
    """Compile the averaged SDE's kernel as `vifpk check` calls it (phase points, the scene's
    paper model), on a tiny run: what a helper process started beside a cold check would do
    (``--ahead``: the experiment of compiling the check's two kernels concurrently)."""
    import numpy as np
    from vifpk.harness.door.solvers import averaged_sde_solution

    from vifpk.core.scene import load_scene

    sc = load_scene(scene)
    edges = {"edges_A": np.linspace(0.0, 1.0, 11), "edges_x": np.linspace(0.0, 1.0, 11),
             "edges_v": np.linspace(-1.0, 1.0, 11)}
    averaged_sde_solution(sc, "paper", edges=edges, seed=1, phase=True, paths=4, blocks=2,
                          dt=0.05, time=2.0, burn_in=1.0, sample_every=0.5)


def summary(rec: dict) -> dict:
    """Totals: compiles (count of function specialisations, nested ones included; self wall
    and CPU), top-level specialisations compiled (depth 0: the kernels a run calls from
    Python) and cache loads (count, wall, CPU)."""
    ev = rec["events"]
    comp = [e for e in ev if e["what"] == "compile"]
    load = [e for e in ev if e["what"] == "load"]
    return {"compiles": len(comp), "compile_self_wall": sum(e["self"] for e in comp),
            "compile_self_cpu": sum(e.get("self_cpu", 0.0) for e in comp),
            "top_level": sorted(f"{e['fn']} {e['what']}" for e in ev if e["depth"] == 0),
            "loads": len(load), "load_wall": sum(e["wall"] for e in load),
            "load_cpu": sum(e["cpu"] for e in load),
            "top": sorted(({"fn": e["fn"], "what": e["what"], "self": round(e["self"], 3),
                            "wall": round(e["wall"], 3), "depth": e["depth"]}
                           for e in ev), key=lambda e: -e["self"])[:12]}


def main() -> None:
    if sys.argv[1:2] == ["--probe"]:
        probe(sys.argv[3:], sys.argv[2])
        return
    if sys.argv[1:2] == ["--ahead-run"]:
        ahead(sys.argv[2])
        return
    args = sys.argv[1:]
    rounds, cmd, name, with_ahead = 1, SOLVE, "cold_start.json", False
    while args and args[0].startswith("--"):
        if args[0] == "--rounds":
            rounds, args = int(args[1]), args[2:]
        elif args[0] == "--check":
            cmd, name, args = CHECK, "cold_start_check.json", args[1:]
        elif args[0] == "--ahead":  # a cold check with the SDE's kernel compiled beside it
            cmd, name, args = CHECK, "cold_start_ahead.json", args[1:]
            with_ahead = True
        else:
            raise SystemExit(f"unknown option {args[0]}")
    res = {"command": "vifpk " + " ".join(cmd), "date": time.strftime(
        "%Y-%m-%d %H:%M UTC", time.gmtime()), "rounds": []}
    for _ in range(rounds):
        for spec in args:
            where, python = spec.split(":")
            with tempfile.TemporaryDirectory() as tmp:
                env = {**os.environ, "NUMBA_CACHE_DIR": f"{tmp}/numba"}
                env.pop("PYTHONDONTWRITEBYTECODE", None)
                row = {"checkout": where}
                for phase in ("cold", "warm"):
                    out = f"{tmp}/{phase}.json"
                    argv = [a.format(tmp=tmp) for a in cmd]
                    for opt in ("--out", "--json"):
                        if phase == "warm" and opt in argv:
                            argv[argv.index(opt) + 1] += "-warm"
                    w = time.perf_counter()
                    helper = (subprocess.Popen([python, __file__, "--ahead-run", argv[1]],
                                               cwd=where, env=env, stdout=subprocess.DEVNULL)
                              if with_ahead and phase == "cold" else None)
                    subprocess.run([python, __file__, "--probe", out, *argv], cwd=where,
                                   env=env, check=True, capture_output=True)
                    if helper is not None:
                        row["ahead_exit"] = helper.wait()
                    rec = json.loads(Path(out).read_text())
                    if rec["exit"] != 0:
                        raise SystemExit(f"{where} {phase}: exit {rec['exit']}")
                    if "--json" in argv:  # the run's own stage timing (the solve)
                        info = json.loads(Path(argv[argv.index("--json") + 1]).read_text())
                        rec["stages"] = info.get("info", {}).get("timing", {}).get("stages")
                    row[phase] = {"process_wall": time.perf_counter() - w,
                                  "load": os.getloadavg(), **rec, **summary(rec)}
                    print(where, phase, {k: row[phase][k] for k in (
                        "exit", "process_wall", "wall", "cpu", "compiles", "compile_self_cpu",
                        "top_level", "loads", "load_cpu", "load")}, flush=True)
                res["rounds"].append(row)
                (RESULTS / name).write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
