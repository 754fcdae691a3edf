"""Monte Carlo speed: steps per second per core of the full-physics kernel and of each
reduced kernel, and the ratio against the same scheme vectorised in plain NumPy, measured in
the same run.

    python benchmarks/bench_montecarlo.py      # writes benchmarks/results/montecarlo.json

Target (issue 4): at least 30 million steps per second per core, full physics, default dt.
Timing: a warm-up call first (compile or cache load reported apart), then the minimum of
repeats; one core = threads=1.
"""

from __future__ import annotations

import json
import platform
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from vifpk.montecarlo.plan import physics as _params  # noqa: E402
from vifpk.montecarlo.reference import simulate_numpy  # noqa: E402

from vifpk import montecarlo as mc  # noqa: E402
from vifpk.core.scene import MonteCarloSettings, load_scene  # noqa: E402

DEFAULTS = mc.Settings(**asdict(MonteCarloSettings()), certificate=False)

EDGES = {"edges_A": np.linspace(0, 2, 101), "edges_x": np.linspace(-2, 2, 101),
         "edges_v": np.linspace(-2, 2, 101)}


def kernel_rate(system, noise, threads: int, repeats: int = 3) -> dict[str, float]:
    kw = dict(paths=64, blocks=16, dt=0.01, time=1000.0, burn_in=10.0, progress=False,
              threads=threads, edges=EDGES, observables=("A", "x1", "x2", "moments", "events"))
    t0 = time.perf_counter()
    mc.simulate(system, noise, DEFAULTS, **dict(kw, paths=16, time=1.0))
    warm = time.perf_counter() - t0
    rates = [mc.simulate(system, noise, DEFAULTS, **kw).info["steps_per_second"]
             for _ in range(repeats)]
    return {"steps_per_second": max(rates), "first_call_seconds": warm}


def numpy_rate(system, noise, paths: int = 4096, steps: int = 400) -> float:
    phys = _params(system, noise)
    simulate_numpy(phys, paths=paths, steps=5, burn=0, stride=1, h=0.01,
                   edges_A=EDGES["edges_A"])
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        simulate_numpy(phys, paths=paths, steps=steps, burn=0, stride=50, h=0.01,
                       edges_A=EDGES["edges_A"])
        best = min(best, time.perf_counter() - t0)
    return paths * steps / best


def main() -> None:
    scene = load_scene(ROOT / "scenes" / "paper-base.toml")
    s, n = scene.system, scene.noise
    variants = {
        "full (OU, barrier, friction)": (s, n),
        "no friction": (replace(s, mu=0.0), n),
        "no barrier": (replace(s, barrier=False), n),
        "smooth (no barrier, no friction)": (replace(s, mu=0.0, barrier=False), n),
        "white noise, full": (s, replace(n, kind="white")),
    }
    rows = {}
    for name, (sy, no) in variants.items():
        one = kernel_rate(sy, no, 1)
        two = kernel_rate(sy, no, numba.config.NUMBA_NUM_THREADS)
        rows[name] = {"per_core": one["steps_per_second"], "all_cores": two["steps_per_second"],
                      "first_call_seconds": one["first_call_seconds"]}
        print(f"{name:34s} {one['steps_per_second'] / 1e6:7.1f} M steps/s/core   "
              f"{two['steps_per_second'] / 1e6:7.1f} M steps/s on "
              f"{numba.config.NUMBA_NUM_THREADS} cores")
    np_full = numpy_rate(s, n)
    ratio = rows["full (OU, barrier, friction)"]["per_core"] / np_full
    print(f"NumPy vectorised, full physics:    {np_full / 1e6:7.2f} M steps/s "
          f"-> numba/NumPy per core = {ratio:.0f}x")
    out = {"command": "python benchmarks/bench_montecarlo.py", "dt": 0.01, "kernels": rows,
           "numpy_full_steps_per_second": np_full, "numba_over_numpy_per_core": ratio,
           "target_per_core": 30e6,
           "machine": {"cores": numba.config.NUMBA_NUM_THREADS, "python": platform.python_version(),
                       "numba": numba.__version__, "numpy": np.__version__}}
    (ROOT / "benchmarks" / "results" / "montecarlo.json").write_text(json.dumps(out, indent=1)
                                                                      + "\n")


if __name__ == "__main__":
    main()
