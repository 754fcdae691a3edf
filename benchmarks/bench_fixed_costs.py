"""Where a warm `vifpk solve` spends its CPU, stage by stage, for any checkout (issue 44).

    python benchmarks/bench_fixed_costs.py --rounds 3 OLD_DIR:OLD_PYTHON NEW_DIR:NEW_PYTHON
    # -> benchmarks/results/fixed_costs.json

Each round runs every checkout once, in turn (alternating, so a change of the machine's load
hits both alike), in a fresh process from that checkout's directory with its own interpreter:
``python bench_fixed_costs.py --stage-run ARGS`` wraps the stationary driver's stage functions
(they have the same names before and after issue 44, so one wrapper serves both) with CPU
timers (time.process_time: every thread) and runs ``vifpk solve`` (default: paper-base,
--floor 0.005 --dt auto). "startup" is the CPU after importing what that command imports (the
parser with every workflow, the door, montecarlo.simulate), before it runs; "dt_check" the
run-time step check's coarse run; "rest" is what no stage holds (validation, pricing, the
result and the JSON).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "results" / "fixed_costs.json"
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


def main() -> None:
    if sys.argv[1:2] == ["--stage-run"]:
        print(json.dumps(stage_run(sys.argv[2:] or ARGS)))
        return
    rounds = 3
    args = sys.argv[1:]
    if args[:1] == ["--rounds"]:
        rounds, args = int(args[1]), args[2:]
    res = {"command": "vifpk " + " ".join(ARGS), "rounds": [],
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    for _ in range(rounds):
        for spec in args:
            where, python = spec.split(":")
            out = subprocess.run([python, __file__, "--stage-run", *ARGS, "--json",
                                  os.devnull], cwd=where, capture_output=True, text=True,
                                 check=True).stdout.strip().splitlines()[-1]
            res["rounds"].append({"checkout": where, "load": os.getloadavg()[0],
                                  "cpu": json.loads(out)})
            print(where, res["rounds"][-1]["cpu"], flush=True)
            OUT.write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
