"""Throughput of the paper-base kernel before/after the physics record (issue 37), alternating.

    NUMBA_NUM_THREADS=1 python benchmarks/bench_record.py OLD_PYTHON NEW_PYTHON [ROUNDS]
    NUMBA_NUM_THREADS=1 python benchmarks/bench_record.py OLD NEW ROUNDS --cpu --time 500

(``--cpu``: path-steps per CPU second of the whole run instead of the kernel's wall-clock rate:
the measure to use on a loaded machine; ``--time T``: the sampled time of the measured run.)

Each round runs ``--one`` under the old interpreter (a venv with the old checkout installed)
and then under the new one; ``--one`` runs the stationary Monte Carlo of scenes/paper-base.toml
(256 paths, dt 0.01, 2000 time units, energy balance on: the kernel's full path) once to
compile or load the cache, then again, and prints the kernel's path-steps per second (info
"steps_per_second": steps over the seconds spent inside run_paths). Prints each round and the
median ratio new / old.
"""

from __future__ import annotations

import statistics
import subprocess
import sys


def one(cpu: bool = False, time_: float = 2000.0) -> None:
    """``cpu``: path-steps of the run per CPU second of the process over the whole second
    simulate call (time.process_time; with NUMBA_NUM_THREADS=1, robust on a loaded machine,
    where the wall-clock rate inside run_paths measures the scheduler), else the kernel's
    wall-clock rate (info "steps_per_second")."""
    import time

    from vifpk.montecarlo.simulate import Settings, simulate

    from vifpk.core.scene import load_scene

    sc = load_scene("scenes/paper-base.toml")
    for t in (20.0, time_):
        st = Settings(paths=256, blocks=16, dt=0.01, time=t, burn_in=10.0, seed=1,
                      bins=40, threads=1, floor=0.0, budget=0.0, sample_every=0.5,
                      progress=False, certificate=False,
                      observables=("A", "x1", "x2", "moments", "energy"))
        c0 = time.process_time()
        r = simulate(sc.system, sc.noise, st)
        c1 = time.process_time()
    print(256 * (10.0 + time_) / 0.01 / (c1 - c0) if cpu else r.info["steps_per_second"])


def main(old: str, new: str, rounds: int, extra: tuple[str, ...] = ()) -> None:
    out: dict[str, list[float]] = {"old": [], "new": []}
    for i in range(rounds):
        for name, py in (("old", old), ("new", new)):
            got = subprocess.run([py, __file__, "--one", *extra], capture_output=True, text=True,
                                 check=True).stdout.split()[-1]
            out[name].append(float(got))
        print(f"round {i}: old {out['old'][-1]:.4g}  new {out['new'][-1]:.4g} steps/s",
              flush=True)
    ratio = statistics.median(n / o for n, o in zip(out["new"], out["old"], strict=True))
    print(f"median old {statistics.median(out['old']):.4g}, new "
          f"{statistics.median(out['new']):.4g} steps/s; median ratio new/old {ratio:.3f}")


if __name__ == "__main__":
    if sys.argv[1] == "--one":
        one(cpu="--cpu" in sys.argv,
            time_=float(sys.argv[sys.argv.index("--time") + 1]) if "--time" in sys.argv
            else 2000.0)
    else:
        flags = tuple(sys.argv[4:])  # e.g. --cpu --time 500: passed to each --one
        main(sys.argv[1], sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 5, flags)
