"""Seconds for p(A) of the base scene to reach an L1 noise floor, in one run of this script:
the target-floor mode (``--floor``, with and without ``--dt auto``, burn-in "auto" and the
certificate) against the fixed settings of the first version (1024 paths, dt 0.01, burn-in
300, time 2000, or the time that the 1/sqrt(time) law says reaches the floor), and the cost of
the equilibration certificate (the same fixed run with and without it).

    python benchmarks/bench_montecarlo_floor.py   # writes benchmarks/results/montecarlo_floor.json

Warm timings (everything compiled first), best of ``REPEATS``, wall clock of
``montecarlo.simulate`` (pilots included).
"""

from __future__ import annotations

import json
import os
import platform
import sys
import time
from dataclasses import asdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import numba  # noqa: E402

from vifpk import montecarlo as mc  # noqa: E402
from vifpk.core.scene import MonteCarloSettings, load_scene  # noqa: E402

REPEATS = 2
OBS = ("A", "moments")


def timed(scene, **kw) -> dict:
    base = mc.Settings(**{**asdict(MonteCarloSettings()), "progress": False,
                          "observables": OBS, **kw})
    best = None
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        r = mc.simulate(scene.system, scene.noise, base)
        sec = time.perf_counter() - t0
        if best is None or sec < best["seconds"]:
            c = r.info["convergence"]
            best = {"seconds": sec, "floor": r.info["L1_floor"]["A"],
                    "dt": r.info["settings"]["dt"], "time": r.info["settings"]["time"],
                    "burn_in": r.info["settings"]["burn_in"],
                    "equilibrated": c.get("equilibrated"), "reached": c.get("reached"),
                    "kernel_seconds": r.info["steps"] / r.info["steps_per_second"]}
    return best


def main() -> None:
    scene = load_scene(ROOT / "scenes" / "paper-base.toml")
    old = {"dt": 0.01, "burn_in": 300.0, "certificate": False}
    # warm-up: compile every specialisation used below
    timed(scene, paths=64, time=50.0, burn_in=10.0)
    timed(scene, paths=64, time=50.0, burn_in=10.0, certificate=False)
    rows = {
        "fixed, first version (T = 2000)": timed(scene, **old),
        "fixed, first version (T = 8000, 1/sqrt law for 0.005)": timed(scene, time=8000.0,
                                                                        **old),
        "--floor 0.01": timed(scene, floor=0.01),
        "--floor 0.01 --dt auto": timed(scene, floor=0.01, dt="auto"),
        "--floor 0.005": timed(scene, floor=0.005),
        "--floor 0.005 --dt auto": timed(scene, floor=0.005, dt="auto"),
        "certificate off (burn-in 300, T 2000)": timed(scene, **old),
        "certificate on (burn-in 300, T 2000)": timed(scene, **dict(old, certificate=True)),
    }
    off = rows["certificate off (burn-in 300, T 2000)"]["seconds"]
    on = rows["certificate on (burn-in 300, T 2000)"]["seconds"]
    out = {
        "rows": rows,
        "certificate_extra": on / off - 1.0,
        "threads": numba.config.NUMBA_NUM_THREADS,
        "cpu_count": os.cpu_count(),
        "machine": platform.machine(), "python": platform.python_version(),
        "numba": numba.__version__,
        "note": "the load average is recorded: above the core count, other jobs shared the "
                "cores and the times are upper bounds",
        "load_average": os.getloadavg(),
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    path = ROOT / "benchmarks" / "results" / "montecarlo_floor.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    w = max(len(k) for k in rows)
    for k, r in rows.items():
        print(f"{k:<{w}}  {r['seconds']:6.2f} s  floor {r['floor']:.4f}  dt {r['dt']:.4g}  "
              f"T {r['time']:.0f}  burn-in {r['burn_in']:.0f}")
    print(f"certificate: {100 * out['certificate_extra']:+.1f}% wall time")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
