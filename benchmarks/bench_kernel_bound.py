"""What bounds the Monte Carlo kernel's steps per second (issue 22): the kernel against
measured lower bounds on this machine, in one run, one thread, CPU time (process_time, so
that other jobs on a shared machine change the numbers less than wall time would).

    NUMBA_NUM_THREADS=1 python benchmarks/bench_kernel_bound.py   # -> results/kernel_bound.json

1. Random numbers: one ziggurat normal per step (what the OU scheme draws), alone in a loop.
2. Memory: the loop with one histogram increment per sample (every 50 steps), alone.
3. The critical path: x -> k = c2 x^2 - c1 -> (e^{-kh}, phi(kh)) -> v -> x, the chain of
   dependent operations one path's step cannot overlap, with exp_phi as the kernel has it
   (Estrin, multiplications) and as it had it (Horner, a division by 120).
4. The kernel (montecarlo.simulate, 512 paths x 400 time units, dt 0.01, burn-in 100, pilots
   included) on paper-base and with effects switched off: no friction; no barrier and no
   friction (smooth); smooth with white noise (two velocity sub-flows and a kick).
"""

from __future__ import annotations

import dataclasses
import json
import os
import sys
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from vifpk.montecarlo.kernels import exp_phi  # noqa: E402
from vifpk.montecarlo.rng import normal  # noqa: E402

from vifpk import montecarlo  # noqa: E402
from vifpk.core.scene import load_scene  # noqa: E402


@numba.njit
def _normals(state, n):
    s0, s1, s2, s3 = state[0], state[1], state[2], state[3]
    acc = 0.0
    for _ in range(n):
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        acc += z
    state[0], state[1], state[2], state[3] = s0, s1, s2, s3
    return acc


@numba.njit
def _histogram(hist, n, stride):
    acc = 0.0
    j = 0
    for i in range(n):
        acc += 1e-9 * i
        if i % stride == 0:
            j = (j * 1103515245 + 12345) & 127
            hist[j % hist.shape[0]] += 1.0
    return acc


@numba.njit(error_model="numpy")
def _horner(z):
    phi = 1.0 - z * (0.5 - z * (1.0 / 6.0 - z * (1.0 / 24.0 - z / 120.0)))
    return 1.0 - z * phi, phi


@numba.njit(error_model="numpy")
def _chain_estrin(n, h):
    x, v = 0.3, 0.1
    for _ in range(n):
        x += 0.5 * h * v
        k = 0.05 * x * x - 0.025
        e, phi = exp_phi(k * h)
        v = v * e + (-(x + 0.6 * x * x * x)) * h * phi
        x += 0.5 * h * v
    return x + v


@numba.njit(error_model="numpy")
def _chain_horner(n, h):
    x, v = 0.3, 0.1
    for _ in range(n):
        x += 0.5 * h * v
        k = 0.05 * x * x - 0.025
        e, phi = _horner(k * h)
        v = v * e + (-(x + 0.6 * x * x * x)) * h * phi
        x += 0.5 * h * v
    return x + v


def _cpu(fn, *args, repeats: int = 3) -> float:
    fn(*args)
    best = np.inf
    for _ in range(repeats):
        c0 = time.process_time()
        fn(*args)
        best = min(best, time.process_time() - c0)
    return best


def _kernel(scene) -> float:
    """Steps per CPU second of montecarlo.simulate (best of 2, warm)."""
    st = montecarlo.Settings(**{**dataclasses.asdict(scene.montecarlo), "dt": 0.01,
                                "time": 400.0, "burn_in": 100.0, "paths": 512, "blocks": 32,
                                "threads": 1, "floor": 0.0, "budget": 0.0},
                             observables=scene.observables.names(), progress=False)
    montecarlo.simulate(scene.system, scene.noise, st)
    best = 0.0
    for _ in range(2):
        c0 = time.process_time()
        r = montecarlo.simulate(scene.system, scene.noise, st)
        best = max(best, r.info["steps"] / (time.process_time() - c0))
    return best


def main() -> None:
    numba.set_num_threads(1)
    load0 = os.getloadavg()
    n = 20_000_000
    ns = {}
    ns["normal (ziggurat)"] = _cpu(_normals, np.array([1, 2, 3, 4], dtype=np.uint64), n) / n
    ns["loop + histogram every 50 steps"] = _cpu(_histogram, np.zeros(100), n, 50) / n
    ns["critical path, exp_phi Estrin"] = _cpu(_chain_estrin, n, 0.01) / n
    ns["critical path, exp_phi Horner with a division"] = _cpu(_chain_horner, n, 0.01) / n
    base = load_scene("paper-base")
    kernels = {
        "paper-base (OU, barrier, friction)": base,
        "no friction": base.with_values({"system.mu": 0.0}),
        "smooth (no barrier, no friction), OU": base.with_values(
            {"system.barrier": False, "system.mu": 0.0}),
        "smooth, white noise": base.with_values(
            {"system.barrier": False, "system.mu": 0.0, "noise.kind": "white"}),
    }
    for label, scene in kernels.items():
        ns[f"kernel step: {label}"] = 1.0 / _kernel(scene)
    res = {"ns_per_step": {k: v * 1e9 for k, v in ns.items()},
           "M_steps_per_second_per_core": {k: 1e-6 / v for k, v in ns.items()
                                           if k.startswith("kernel")},
           "machine": {"cpus": os.cpu_count(), "load_average_start": load0,
                       "load_average_end": os.getloadavg(),
                       "note": "CPU time of one thread (process_time): other jobs on the cores "
                               "change it less than wall time, not at all only on a quiet "
                               "machine"}}
    out = ROOT / "benchmarks" / "results" / "kernel_bound.json"
    out.write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
