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
5. The lane kernels against the TARGET (issue 44): a minimal kernel of the same scheme and
   physics (paper-base: OU, the wall at 0 with r, friction, the chatter guard), written for
   this benchmark alone, with its paths in struct-of-arrays lanes (LANES of them: the smooth
   step on every lane in one loop the compiler vectorises, then the lanes that met an event,
   an impact, a velocity zero or the ziggurat's slow path, stepped again one by one), and the
   same minimal kernel with 4 paths in turn (the layout of the kernel before issue 44). Both
   end bit-identical to the production kernel (checked here, from the same states and
   generator words). ns per path-step, median of alternating rounds in one run; the ratio
   kernel / minimal SoA is what the issue's target (<= 1.2) is about.
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

from vifpk.montecarlo import lanes  # noqa: E402
from vifpk.montecarlo.kernels import N_EVENTS, exp_phi, velocity_flow  # noqa: E402
from vifpk.montecarlo.pieces import record  # noqa: E402
from vifpk.montecarlo.plan import physics  # noqa: E402
from vifpk.montecarlo.rng import KN, U64, WN, block_seeds, normal  # noqa: E402

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


_C6, _C24, _C120 = 1.0 / 6.0, 1.0 / 24.0, 1.0 / 120.0
LANES = lanes.LANES


@numba.njit(error_model="numpy")
def _wall(x, v, tau, r, press, h):
    """Drift tau with the wall at 0 (Newton's r) and the chatter guard, as pieces.reflect."""
    xn = x + v * tau
    if xn >= 0.0:
        return xn, v
    t_hit = (0.0 - x) / v
    w = -r * v
    if press > 0.0 and abs(w) < press * h:
        return 0.0, 0.0
    return 0.0 + w * (tau - t_hit), w


@numba.njit(error_model="numpy")
def _full(x, v, xi, s0, s1, s2, s3, h, c):
    """One whole step of one path (the events included)."""
    c1, c2, w0sq, alpha, mu, r, f, a, sd = c
    half = 0.5 * h
    p = mu - f * xi
    x, v = _wall(x, v, half, r, p, h)
    k = c2 * x * x - c1
    g = (w0sq + alpha * x * x) * x
    v, _ = velocity_flow(v, h, -g + f * xi, k, mu, 1 if x == 0.0 else 0)
    x, v = _wall(x, v, half, r, p, h)
    z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
    return x, v, a * xi + sd * z, s0, s1, s2, s3


@numba.njit(error_model="numpy")
def _minimal_soa(st, S, n, h, c):
    """The target: st = (x, v, xi) rows, S = generator words (4 rows), LANES paths in lanes.
    The lanes live in arrays made here (Y, W: strides the compiler knows, so it proves their
    rows apart and vectorises the smooth loop, as in the production kernels' scratch), indexed
    in place (a row view made per step costs atomic reference counts)."""
    c1, c2, w0sq, alpha, mu, r, f, a, sd = c
    half = 0.5 * h
    Y = np.empty((6, LANES))  # x, v, xi, and their values at the step's start
    W = np.empty((8, LANES), dtype=np.uint64)  # the words, and at the step's start
    for j in range(LANES):
        Y[0, j], Y[1, j], Y[2, j] = st[0, j], st[1, j], st[2, j]
        W[0, j], W[1, j], W[2, j], W[3, j] = S[0, j], S[1, j], S[2, j], S[3, j]
    for _ in range(n):
        for j in range(LANES):  # the smooth step on every lane (NaN: an event)
            x, v, xi = Y[0, j], Y[1, j], Y[2, j]
            s0, s1, s2, s3 = W[0, j], W[1, j], W[2, j], W[3, j]
            Y[3, j], Y[4, j], Y[5, j] = x, v, xi
            W[4, j], W[5, j], W[6, j], W[7, j] = s0, s1, s2, s3
            x = x + v * half
            x = x if x >= 0.0 else np.nan
            k = c2 * x * x - c1
            g = (w0sq + alpha * x * x) * x
            z = k * h
            z2 = z * z
            phi = (1.0 - 0.5 * z) + z2 * ((_C6 - _C24 * z) + _C120 * z2)
            e = 1.0 - z * phi
            sg = 1.0 if v > 0.0 else -1.0
            vt = v * e + ((-g + f * xi) - mu * sg) * h * phi
            v = vt if abs(z) < 0.02 and v != 0.0 and vt * sg > 0.0 else np.nan
            x = x + v * half
            x = x if x >= 0.0 else np.nan
            u = s0 + s3
            t = s1 << U64(17)
            s2 ^= s0
            s3 ^= s1
            s1 ^= s2
            s0 ^= s3
            s2 ^= t
            s3 = (s3 << U64(45)) | (s3 >> U64(19))
            iz = np.int64(u & U64(127))
            hz = np.int64(np.int32(np.uint32(u >> U64(32))))
            zn = hz * WN[iz]  # (loaded whether or not it is accepted: no branch in the loop)
            zn = zn if abs(hz) < KN[iz] else np.nan
            Y[0, j], Y[1, j], Y[2, j] = x, v, a * xi + sd * zn
            W[0, j], W[1, j], W[2, j], W[3, j] = s0, s1, s2, s3
        for j in range(LANES):  # the lanes that met an event, in full
            if Y[0, j] == Y[0, j] and Y[1, j] == Y[1, j] and Y[2, j] == Y[2, j]:
                continue
            Y[0, j], Y[1, j], Y[2, j], W[0, j], W[1, j], W[2, j], W[3, j] = _full(
                Y[3, j], Y[4, j], Y[5, j], W[4, j], W[5, j], W[6, j], W[7, j], h, c)
    for j in range(LANES):
        st[0, j], st[1, j], st[2, j] = Y[0, j], Y[1, j], Y[2, j]
        S[0, j], S[1, j], S[2, j], S[3, j] = W[0, j], W[1, j], W[2, j], W[3, j]


@numba.njit(error_model="numpy")
def _minimal_turn4(st, S, n, h, c):
    """The same minimal scheme, 4 paths at a time in turn (the layout before issue 44)."""
    for j0 in range(0, LANES, 4):
        for _ in range(n):
            for j in range(j0, j0 + 4):
                st[0, j], st[1, j], st[2, j], S[0, j], S[1, j], S[2, j], S[3, j] = _full(
                    st[0, j], st[1, j], st[2, j], S[0, j], S[1, j], S[2, j], S[3, j], h, c)


def _lanes_case(scene, h: float, blocks: int = 2):
    """(call, path-steps of a call, final states) of lanes._block on ``blocks`` blocks of LANES
    paths: the A histogram sampled every 0.5 time units (what a floor run fills)."""
    phys = physics(scene.system, scene.noise)
    P = record(phys, h)
    stride = max(1, round(0.5 / h))

    def start():
        st = np.random.default_rng(3).uniform(0.05, 0.5, (blocks, LANES, 3))
        st[..., 2] *= 0.1
        return block_seeds(3, blocks, LANES), st

    def call(n):
        rng, st = start()
        out = (np.zeros((blocks, 100)), *(np.zeros((blocks, 0)),) * 2, np.zeros((blocks, 0, 0)),
               np.zeros((blocks, LANES, 0)), np.zeros((blocks, N_EVENTS)),
               np.zeros((blocks, LANES)), np.zeros((blocks, LANES, 0)),
               np.zeros((blocks, LANES, 0)))
        lanes._block(np.int64(0), np.int64(1), rng, st, n, 0, 0, stride, h, P,
                     (0.0, 50.0, 0.0, 1.0, 0.0, 1.0), out, 1)
        return rng, st
    return call, blocks * LANES, start


def _passage_case(scene, h: float, per: int = 64):
    """(call, path-steps of a call) of passage_kernels.run_passage on one block of ``per``
    paths started on the orbit of amplitude 0.4, a threshold (A = 3) no path reaches: the
    kernel's stepping with its per-step energy test."""
    from vifpk.montecarlo.passage_kernels import run_passage
    phys = physics(scene.system, scene.noise)
    P = record(phys, h)
    B = (P.bridge, P.pk, P.pc)
    Ec = 0.5 * 9.0 + 0.25 * phys["alpha"] * 81.0

    def call(n):
        ints = [np.zeros((1, per), np.int64) for _ in range(3)]
        arrs = (block_seeds(4, 1, per), np.zeros((1, per, 3)), np.zeros((1, per, 3)), *ints,
                np.zeros((1, per)))
        run_passage(arrs, np.array([per]), (n, 10 ** 9, 0, 1e9, Ec, 0.4, 0.0, 0), h, B, P)
        return arrs
    return call, per


def _ratios(n: int = 20_000, rounds: int = 7) -> dict:
    """ns per path-step: the production kernel against the minimal kernels, alternating."""
    base = load_scene("paper-base")
    h = 0.5 / 23  # the --dt auto step of the floor-0.005 run before issue 44
    P = record(physics(base.system, base.noise), h)
    c = (P.c1, P.c2, P.w0sq, P.alpha, P.mu, P.lo_law_r, P.f, P.ou_a, P.ou_s)
    call, per_call, start = _lanes_case(base, h, blocks=1)
    rng0, st0 = start()

    def minimal(fn):
        def run(k):
            st = np.ascontiguousarray(st0[0].T)
            S = np.ascontiguousarray(rng0[0].T)
            fn(st, S, k, h, c)
            return st, S
        return run
    runs = {"minimal SoA (target)": minimal(_minimal_soa),
            "minimal, 4 paths in turn": minimal(_minimal_turn4),
            "kernel (lanes._block), paper-base": call}
    passage, per_passage = _passage_case(base, h)
    # the same scheme: every kernel ends in the same bits from the same start
    ends = {k: fn(500) for k, fn in runs.items()}
    st_k = ends["kernel (lanes._block), paper-base"][1][0]
    for key in ("minimal SoA (target)", "minimal, 4 paths in turn"):
        assert np.array_equal(ends[key][0], st_k.T), key
    runs["first passage (passage_kernels.run_passage), paper-base"] = passage
    passage(10)
    per = {k: per_passage if k.startswith("first passage") else per_call for k in runs}
    times: dict[str, list[float]] = {k: [] for k in runs}
    for _ in range(rounds):
        for k, fn in runs.items():
            c0 = time.process_time()
            fn(n)
            times[k].append((time.process_time() - c0) / (n * per[k]) * 1e9)
    med = {k: float(np.median(v)) for k, v in times.items()}
    target = med["minimal SoA (target)"]
    return {"ns_per_path_step_median": med, "rounds": times,
            "ratio_to_minimal_soa": {k: v / target for k, v in med.items()},
            "settings": {"scene": "paper-base", "dt": h, "lanes": LANES, "steps": n,
                         "rounds": rounds}}


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
    res = {"lanes_against_minimal": _ratios(),
           "ns_per_step": {k: v * 1e9 for k, v in ns.items()},
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
