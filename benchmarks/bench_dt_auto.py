"""dt = "auto" on the base scene and on the scenes unlike it of bench_dt_bias.py (issue 29):
the step the rule picks (tuning.auto_dt: Omega, the fastest free orbit the scale pilot's
paths reach), the bias the dt ladder of benchmarks/results/dt_bias.json puts there
(interpolated in log-log between its steps), and the run-time check's verdict, estimate and
cost, at a target floor of 0.005 and 0.01 (1024 paths, one thread, default seed).

    NUMBA_NUM_THREADS=1 python benchmarks/bench_dt_auto.py   # -> results/dt_auto.json
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import asdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import numpy as np  # noqa: E402
from bench_dt_bias import SCENES, scene  # noqa: E402

from vifpk import montecarlo as mc  # noqa: E402
from vifpk.core.scene import MonteCarloSettings  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "dt_auto.json"
LADDER = json.loads((ROOT / "benchmarks" / "results" / "dt_bias.json").read_text())["scenes"]


def ladder_bias(name: str, dt: float) -> float | None:
    rows = sorted(LADDER[name]["rows"], key=lambda r: r["dt"])
    h = np.array([r["dt"] for r in rows])
    b = np.array([max(r["bias"], 1e-5) for r in rows])
    if dt < h[0]:
        return None  # below the ladder
    return float(np.exp(np.interp(math.log(dt), np.log(h), np.log(b))))


def main() -> None:
    out = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "scenes": {}}
    for name in SCENES:
        sc = scene(name)
        for floor in (0.005, 0.01):
            st = mc.Settings(**{**asdict(MonteCarloSettings()), "progress": False,
                                "threads": 1, "observables": ("A", "moments"),
                                "dt": "auto", "floor": floor, "budget": 0})
            t0 = time.perf_counter()
            r = mc.simulate(sc.system, sc.noise, st)
            sec = time.perf_counter() - t0
            chk, rule = r.info["dt_check"], r.info["dt_rule"]
            h = r.info["settings"]["dt"]
            row = {"floor": floor, "dt": h, "omega": rule["omega"],
                   "amplitude": rule["amplitude"], "old_dt": rule["pilot_dt"],
                   "ladder_bias_at_dt": ladder_bias(name, h),
                   "ladder_bias_at_old_dt": ladder_bias(name, rule["pilot_dt"]),
                   "check": {k: chk.get(k) for k in ("verdict", "bias", "bias_interval",
                                                     "check_dt", "L1", "L1_floor", "L1_err")},
                   "seconds": sec, "check_seconds": r.info["seconds"].get("dt_check"),
                   "warnings": r.info["warnings"]}
            out["scenes"].setdefault(name, []).append(row)
            print(name, json.dumps(row), flush=True)
            OUT.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
