"""The averaged SDE's time-domain kernels with their paths in struct-of-arrays lanes (issue 44):
first passage (``run_sde_passage``) and the law at given times (``run_sde_snapshots``) of
sde_time.py, and the lane step the splitting's SDE kernels share (``sde_lane_step``).

**The step** (``sde_lane_step``) is averaged_sde.run_sde_blocks's: LANES paths advance
together, the step with the ziggurat's fast path (lanes.fast_normal) on every lane in one
loop (averaged_sde.sde_coefficients_at, sde_update: the arithmetic of ``sde_step``; the
amplitude sqrt(Z) the kernel's tests took after the step before, where they take it: one square
root a step less, the same number), and a lane whose normal took the slow path (NaN) stepped
again from its start by averaged_sde.sde_step. Each lane's new Z, the sigma its step used and
its generator words are therefore those of ``sde_step`` alone, bit for bit.

**The tests after the step** run in two loops: one over every lane that the compiler can
vectorise (the new amplitude, the step count, whether the lane needs a look: a crossing, a
bridge probability that may be above its floor, a non-finite amplitude, the last step; the
bridge's argument compared without its division, with a margin of 1e-9 relative that leaves
any doubtful lane to the look), then, lane by lane, only the lanes that need one, with
sde_time's own tests in its order (the bridge's uniform drawn from the lane's words as the
path alone drew it). A path that ends leaves its
lane to the thread's next path (lanes.drop fills the hole with the last lane, already
tested). Each path keeps its own four generator words (path p of block b: words 4p..4p+3 of
SeedSequence(root, spawn_key=(b,)), rng.block_seeds: the scheme sde_time already had), so a
path's numbers do not depend on its lane, the other paths, the thread count or the cut into
calls: they are those of the kernels that stepped one path at a time
(benchmarks/mc_identity.py's ``sde.fpt``, ``sde.snap``: 0 differ). The snapshots' histogram
counts are whole numbers, whose sums do not depend on the order.

Threads: ``_jit.over_blocks``; thread t of n runs the paths of blocks t, t + n, ... of the
call (done[b] .. done[b] + k - 1 of each), pooled into its lanes.
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import jit, over_blocks
from .averaged_sde import sde_coefficients_at, sde_step, sde_update
from .lanes import LANES, drop, fast_normal
from .passage_kernels import BRIDGE_FLOOR
from .rng import uniform

# float rows of the lane scratch: Z, Z at the step's start, sigma used by the step, the
# amplitude before the step, after it (first passage), the bridge's argument
R_Z, R_Z0, R_SIG, R_A, R_A1, R_ARG = range(6)
N_FLOAT = 6
# int rows: the global path index, its block, steps taken, needs a look (first passage)
I_G, I_B, I_N, I_LOOK = range(4)
N_INT = 4


@jit(inline="always")
def sde_scratch(n_float, n_int):
    """(float rows, int rows, generator words: 4 rows now, 4 at the step's start); the first
    N_FLOAT float rows and 4 int rows are this module's (R_*, I_*), a caller's own follow."""
    return (np.zeros((n_float, LANES)), np.zeros((n_int, LANES), dtype=np.int64),
            np.zeros((8, LANES), dtype=np.uint64))


@jit(inline="always")
def sde_lane_step(m, F, S, h, sq, a_tab, b_tab, inv_d, last, amp):
    """One step of lanes 0 .. m - 1 (module docstring): F[R_Z] the new Z, F[R_SIG] the sigma
    each step used, F[R_Z0] and S[4:8] the Z and the words at the step's start. ``amp``
    (a constant of the caller): F[R_A1] holds sqrt(F[R_Z]) of every lane at the step's start
    (the caller's tests took that square root after the step before, or at the load), which
    the step reads instead of taking it again: the same number (the square root is correctly
    rounded), one square root a path-step less (measured: benchmarks/bench_lanes_split_sde.py,
    docs/performance.md). (Rows are indexed in place: views of them made per step cost ~5 ns
    a path-step in reference counts.)"""
    for j in range(m):  # the step on every lane (NaN: a slow-path normal)
        s0, s1, s2, s3 = S[0, j], S[1, j], S[2, j], S[3, j]
        z0 = F[R_Z, j]
        F[R_Z0, j], S[4, j], S[5, j], S[6, j], S[7, j] = z0, s0, s1, s2, s3
        A = F[R_A1, j] if amp else math.sqrt(z0)
        a, bb = sde_coefficients_at(A, a_tab, b_tab, inv_d, last)
        z, s0, s1, s2, s3 = fast_normal(s0, s1, s2, s3)
        z2, s0, s1, s2, s3 = fast_normal(s0, s1, s2, s3)
        F[R_Z, j], _r = sde_update(A, a, bb, z, z2, h, sq)
        F[R_SIG, j] = bb
        S[0, j], S[1, j], S[2, j], S[3, j] = s0, s1, s2, s3
    for j in range(m):  # those lanes again, by sde_step
        if F[R_Z, j] == F[R_Z, j]:
            continue
        F[R_Z, j], F[R_SIG, j], _r, S[0, j], S[1, j], S[2, j], S[3, j] = sde_step(
            F[R_Z0, j], S[4, j], S[5, j], S[6, j], S[7, j], h, sq, a_tab, b_tab, inv_d, last)


@jit(inline="always")
def _next_path(b, i, every, done, k, count):
    """The thread's next (block, path in block) at or after (b, i); b >= count.size: none."""
    while b < count.size and i >= min(done[b] + k, count[b]):
        b += every
        if b < count.size:
            i = done[b]
    return b, i


@jit(inline="always")
def _load(F, Li, S, j, b, i, g, A, states):
    F[R_Z, j] = A * A
    F[R_A, j] = A
    F[R_A1, j] = math.sqrt(A * A)  # (sde_lane_step's amp: sqrt(Z), which may differ from A)
    Li[I_G, j], Li[I_B, j], Li[I_N, j] = g, b, 0
    for w in range(4):
        S[w, j] = states[b, i, w]


def run_sde_passage(states, starts, offset, count, done, k, n_max, horizon, h, Ac, a_tab,
                    b_tab, inv_d, fpt, censored, bad):
    """Paths done[b] .. done[b] + k - 1 of each block b (path i of block b is the global path
    offset[b] + i, from starts[...], with the words states[b, i]) stepped from A = starts[g]
    until A crosses Ac (sde_time's module docstring: at a step's end, or inside it by the
    Brownian bridge) or n_max steps: fpt and censored written per path, bad[path] = 1 when
    the path's amplitude became non-finite. In lanes (module docstring)."""
    over_blocks(_passage_block, count.size, states, starts, offset, count, done, k, n_max,
                horizon, h, Ac, (a_tab, b_tab, inv_d), fpt, censored, bad)


@jit(nogil=True)
def _passage_block(first, every, states, starts, offset, count, done, k, n_max, horizon, h,
                   Ac, tabs, fpt, censored, bad):
    """run_sde_passage for blocks first, first + every, ... (one thread's share)."""
    a_tab, b_tab, inv_d = tabs
    sq = math.sqrt(h)
    last = a_tab.size - 1
    floor_arg = -math.log(BRIDGE_FLOOR)
    cut = floor_arg * (1.0 + 1e-9)  # ``far``: the bridge's argument surely >= floor_arg
    F, Li, S = sde_scratch(N_FLOAT, N_INT)
    no_rows = np.zeros((0, LANES))  # lanes.drop's float rows of the caller: none here
    Z, A0, A1, ARG = F[R_Z], F[R_A], F[R_A1], F[R_ARG]
    SG, N, LOOK = F[R_SIG], Li[I_N], Li[I_LOOK]
    b, i = _next_path(first, done[first] if first < count.size else 0, every, done, k, count)
    m = 0
    while True:
        while m < LANES and b < count.size:  # the thread's next paths into the free lanes
            _load(F, Li, S, m, b, i, offset[b] + i, starts[offset[b] + i], states)
            m += 1
            b, i = _next_path(b, i + 1, every, done, k, count)
        if m == 0:
            break
        sde_lane_step(m, F, S, h, sq, a_tab, b_tab, inv_d, last, True)
        for j in range(m):  # every lane: its amplitude, its step count, whether to look
            a1 = math.sqrt(Z[j])
            A1[j] = a1
            N[j] += 1
            sg = SG[j]
            far = 2.0 * (Ac - A0[j]) * (Ac - a1) > cut * (sg * sg * h)  # no division
            go_on = (a1 < Ac) & far & (N[j] < n_max)
            LOOK[j] = 0 if go_on else 1
        for j in range(m - 1, -1, -1):  # the lanes to look at (last first: a drop moves
            n = N[j]                    # a lane already looked at into lane j)
            if LOOK[j] == 0:
                A0[j] = A1[j]
                continue
            A, a1 = A0[j], A1[j]
            g = Li[I_G, j]
            hit = -1.0
            end = True
            if a1 >= Ac:
                hit = (Ac - A) / (a1 - A)
            elif not math.isfinite(a1):
                bad[g] = 1
            else:
                end = False
                sg = SG[j]
                ARG[j] = 2.0 * (Ac - A) * (Ac - a1) / (sg * sg * h)
                if ARG[j] < floor_arg:
                    u, S[0, j], S[1, j], S[2, j], S[3, j] = uniform(S[0, j], S[1, j], S[2, j],
                                                                    S[3, j])
                    if u < math.exp(-ARG[j]):
                        hit = (Ac - A) / ((Ac - A) + (Ac - a1))
                        end = True
                A0[j] = a1
                end = end or n >= n_max
            if not end:
                continue
            if hit >= 0.0 and (n - 1 + hit) * h <= horizon:
                fpt[g] = (n - 1 + hit) * h
                censored[g] = False
            else:
                fpt[g] = horizon
                censored[g] = True
            m = drop(F, S, no_rows, Li, j, m)


def run_sde_snapshots(states, starts, offset, count, done, k, marks, h, a_tab, b_tab, inv_d,
                      a_lo, a_inv, hist, bad):
    """As run_sde_passage, but record A at the step indices ``marks`` (increasing) into
    hist[b, j, bin] (A outside the edges: not counted, so the density's mass falls short);
    a path whose amplitude is non-finite at a mark is bad[path] = 1 and recorded no more.
    In lanes (module docstring): a group of LANES paths advances together to each mark."""
    over_blocks(_snapshots_block, count.size, states, starts, offset, count, done, k, marks,
                h, (a_tab, b_tab, inv_d), (a_lo, a_inv), hist, bad)


@jit(nogil=True)
def _snapshots_block(first, every, states, starts, offset, count, done, k, marks, h, tabs,
                     bins, hist, bad):
    """run_sde_snapshots for blocks first, first + every, ... (one thread's share)."""
    a_tab, b_tab, inv_d = tabs
    a_lo, a_inv = bins
    sq = math.sqrt(h)
    last = a_tab.size - 1
    nb = hist.shape[2]
    F, Li, S = sde_scratch(N_FLOAT, N_INT)
    Z, ALIVE = F[R_Z], Li[I_LOOK]
    b, i = _next_path(first, done[first] if first < count.size else 0, every, done, k, count)
    while b < count.size:
        m = 0
        while m < LANES and b < count.size:  # a group of the thread's next paths
            _load(F, Li, S, m, b, i, offset[b] + i, starts[offset[b] + i], states)
            ALIVE[m] = 1
            m += 1
            b, i = _next_path(b, i + 1, every, done, k, count)
        n = 0
        for jm in range(marks.size):
            while n < marks[jm]:
                sde_lane_step(m, F, S, h, sq, a_tab, b_tab, inv_d, last, False)
                n += 1
            for j in range(m):
                if ALIVE[j] == 0:
                    continue
                A = math.sqrt(Z[j])
                if not math.isfinite(A):
                    bad[Li[I_G, j]] = 1
                    ALIVE[j] = 0
                    Z[j] = 0.0  # (a finite state the lane steps harmlessly; never read)
                    continue
                q = math.floor((A - a_lo) * a_inv)
                if 0 <= q < nb:
                    hist[Li[I_B, j], jm, q] += 1.0
