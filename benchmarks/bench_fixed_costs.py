"""Where a warm `vifpk solve` spends its CPU, stage by stage, for any checkout (issue 44).

    python benchmarks/bench_fixed_costs.py --rounds 3 OLD_DIR:OLD_PYTHON NEW_DIR:NEW_PYTHON
    # -> benchmarks/results/fixed_costs.json
    python benchmarks/bench_fixed_costs.py --rounds 3 --scene benchmarks/two-wall.toml \
        --out fixed_costs_two_wall.json OLD_DIR:OLD_PYTHON NEW_DIR:NEW_PYTHON

Each round runs every checkout once, in turn (alternating, so a change of the machine's load
hits both alike), in a fresh process from that checkout's directory with its own interpreter:
``python bench_fixed_costs.py --stage-run ARGS`` wraps the stationary driver's stage functions
(they have the same names before and after issue 44, so one wrapper serves both) with CPU
timers (time.process_time: every thread) and runs ``vifpk solve`` (default: paper-base,
--floor 0.005 --dt auto). "startup" is the CPU after importing what that command imports (the
parser with every workflow, the door, montecarlo.simulate), before it runs; "dt_check" the
run-time step check's coarse run; "rest" is what no stage holds (validation, pricing, the
result and the JSON).

Each round also measures the FLOOR, what any numba program of this stack pays, in a fresh
process of the first checkout's interpreter (``--floor-run``): the interpreter, ``import
numpy``, ``import numba`` (cumulative CPU seconds), then the first call of a one-line
``njit(cache=True)`` function loaded from numba's own cache ("numba's cached call": numba's
registry refresh, which imports scipy.linalg through numba/np/arraymath.py's BLAS check;
vifpk's kernels skip it, montecarlo/_jit.py, so a vifpk run's cache load is its "kernel"
stage instead).

Every process's whole CPU (user + system, its exit included: what the in-process clocks
cannot see) is read by this script from ``resource.getrusage(RUSAGE_CHILDREN)``: "process"
in each row; for the floor, "process" of a second process that stops after ``import numba``
("imports_process": interpreter + numpy + numba + exit).

``--scene PATH`` runs that scene instead of paper-base (e.g. benchmarks/two-wall.toml).

Every process runs without PYTHONDONTWRITEBYTECODE (set in some sandboxes, this machine's
among them): with it, no .pyc is ever written for an editable install and every run compiles
vifpk's ~100 modules from source (0.3-0.5 s CPU at load 8, measured 2026-12-05), which a
newcomer's second run (or any wheel install) does not pay.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "results" / "fixed_costs.json"
#: the environment of every measured process (module docstring: no PYTHONDONTWRITEBYTECODE)
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
ARGS = ["solve", "scenes/paper-base.toml", "--solver", "montecarlo", "--floor", "0.005",
        "--dt", "auto"]


def stage_run(argv: list[str]) -> dict[str, float]:
    from vifpk.harness.cli import app

    app.build_parser()
    import vifpk.harness.door.solvers  # noqa: F401

    from vifpk import montecarlo  # noqa: F401

    S = sys.modules["vifpk.montecarlo.simulate"]
    AS = sys.modules["vifpk.montecarlo.assemble"]
    B = sys.modules["vifpk.montecarlo.burnin"]
    rec: dict[str, float] = {"startup": time.process_time()}
    depth = [0]

    def wrap(mod, name, label, nest=False):
        f = getattr(mod, name)

        def g(*a, **k):
            top = depth[0] == 0
            if nest:
                depth[0] += 1
            t = time.process_time()
            try:
                return f(*a, **k)
            finally:
                if nest:
                    depth[0] -= 1
                if top:
                    rec[label] = rec.get(label, 0.0) + time.process_time() - t
        setattr(mod, name, g)

    for name, label in (("resolve", "plan"), ("compile_kernel", "kernel"),
                        ("begin", "pilots_and_burn_in"), ("sample", "sampling"),
                        ("assemble", "result_and_dt_check")):
        wrap(S, name, label)
    wrap(B, "pilot_scale", "scale_pilot")
    wrap(B, "relaxation", "relaxation_pilot")
    wrap(AS, "certificate", "certificate")
    wrap(AS, "run_step_check", "dt_check", nest=True)
    from vifpk.harness.cli.entry import main

    sys.argv = ["vifpk", *argv]
    try:
        main()
    except SystemExit:
        pass
    rec["total"] = time.process_time()
    rec["burn_in"] = rec["pilots_and_burn_in"] - rec["scale_pilot"] - rec.get(
        "relaxation_pilot", 0.0)
    rec["rest"] = rec["total"] - rec["startup"] - sum(
        rec[k] for k in ("plan", "kernel", "pilots_and_burn_in", "sampling",
                         "result_and_dt_check"))
    return rec


FLOOR_MODULE = """import numba


@numba.njit(cache=True)
def one(x):
    return x + 1.0
"""


def floor_run(where: str, stop: str = "") -> dict[str, float]:
    """CPU seconds (cumulative, process_time) of the floor's steps (module docstring);
    ``where`` holds the one-line cached module (its cache filled by a first run); with
    ``stop`` "numba" the process ends after importing numba."""
    t = {"interpreter": time.process_time()}
    import numpy  # noqa: F401

    t["numpy"] = time.process_time()
    import numba  # noqa: F401

    t["numba"] = time.process_time()
    if stop == "numba":
        return t
    sys.path.insert(0, where)
    from floor_one import one

    one(1.0)
    t["numba's cached call"] = time.process_time()
    return t


def child_cpu() -> float:
    """user + system CPU seconds of this process's waited-for children so far."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def measured(cmd: list[str], **kw) -> tuple[subprocess.CompletedProcess, float]:
    """(the finished process, its whole CPU seconds: user + system, its exit included)."""
    c0 = child_cpu()
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, **kw)
    return out, child_cpu() - c0


def floor(python: str, tmp: str) -> dict[str, float]:
    """The floor measured in fresh processes of ``python`` (the cache filled beforehand)."""
    Path(tmp, "floor_one.py").write_text(FLOOR_MODULE)
    cmd = [python, __file__, "--floor-run", tmp]
    env = {**ENV, "NUMBA_CACHE_DIR": str(Path(tmp, "cache"))}
    subprocess.run(cmd, env=env, check=True, capture_output=True)
    out, cpu = measured(cmd, env=env)
    row = json.loads(out.stdout.strip().splitlines()[-1])
    row["process"] = cpu
    _, row["imports_process"] = measured([*cmd, "numba"], env=env)
    return row


def main() -> None:
    if sys.argv[1:2] == ["--stage-run"]:
        print(json.dumps(stage_run(sys.argv[2:] or ARGS)))
        return
    if sys.argv[1:2] == ["--floor-run"]:
        print(json.dumps(floor_run(*sys.argv[2:4])))
        return
    rounds, out_path, argv = 3, OUT, list(ARGS)
    args = sys.argv[1:]
    while args[:1] in (["--rounds"], ["--scene"], ["--out"]):
        if args[0] == "--rounds":
            rounds = int(args[1])
        elif args[0] == "--scene":
            argv[1] = str(Path(args[1]).resolve())
        else:
            out_path = OUT.with_name(args[1])
        args = args[2:]
    res = {"command": "vifpk " + " ".join(argv), "rounds": [],
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    if out_path.exists():  # the record before this one, kept beside it
        before = json.loads(out_path.read_text())
        res["earlier"] = [*before.pop("earlier", []), before]
    for _ in range(rounds):
        with tempfile.TemporaryDirectory() as tmp:
            row = floor(args[0].split(":")[1], tmp)
        res["rounds"].append({"checkout": "floor", "load": os.getloadavg()[0], "cpu": row})
        print("floor", row, flush=True)
        for spec in args:
            where, python = spec.split(":")
            with tempfile.TemporaryDirectory() as tmp:
                record = Path(tmp, "solve.json")
                run, cpu = measured([python, __file__, "--stage-run", *argv, "--json",
                                     str(record)], cwd=where, env=ENV)
                out = run.stdout.strip().splitlines()[-1]
                timing = json.loads(record.read_text())["info"]["timing"]
            res["rounds"].append({"checkout": where, "load": os.getloadavg()[0],
                                  "cpu": {**json.loads(out), "process": cpu},
                                  "timing": timing})
            print(where, res["rounds"][-1]["cpu"], flush=True)
            out_path.write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
