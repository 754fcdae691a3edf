"""Throughput of the paper-base kernel before/after the physics record (issue 37), alternating.

    NUMBA_NUM_THREADS=1 python benchmarks/bench_record.py OLD_PYTHON NEW_PYTHON [ROUNDS]

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


def one() -> None:
    from vifpk.montecarlo.simulate import Settings, simulate

    from vifpk.core.scene import load_scene

    sc = load_scene("scenes/paper-base.toml")
    for time_ in (20.0, 2000.0):
        st = Settings(paths=256, blocks=16, dt=0.01, time=time_, burn_in=10.0, seed=1,
                      bins=40, threads=1, floor=0.0, budget=0.0, sample_every=0.5,
                      progress=False, certificate=False,
                      observables=("A", "x1", "x2", "moments", "energy"))
        r = simulate(sc.system, sc.noise, st)
    print(r.info["steps_per_second"])


def main(old: str, new: str, rounds: int) -> None:
    out: dict[str, list[float]] = {"old": [], "new": []}
    for i in range(rounds):
        for name, py in (("old", old), ("new", new)):
            got = subprocess.run([py, __file__, "--one"], capture_output=True, text=True,
                                 check=True).stdout.split()[-1]
            out[name].append(float(got))
        print(f"round {i}: old {out['old'][-1]:.4g}  new {out['new'][-1]:.4g} steps/s",
              flush=True)
    ratio = statistics.median(n / o for n, o in zip(out["new"], out["old"], strict=True))
    print(f"median old {statistics.median(out['old']):.4g}, new "
          f"{statistics.median(out['new']):.4g} steps/s; median ratio new/old {ratio:.3f}")


if __name__ == "__main__":
    if sys.argv[1] == "--one":
        one()
    else:
        main(sys.argv[1], sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 5)
