"""The splitting's kernels of the averaged SDE in struct-of-arrays lanes (issue 44): the AMS
advance (``advance_sde``) and the direct simulation of the cycles (``cycles_sde``).

Levels, outcomes, the cycles and the Brownian-bridge test at A_lo = sqrt(q_lo) and
A_hi = sqrt(q_hi) are splitting_kernels.py's module docstring; its bookkeeping helpers
(``level_of``, ``_cycle_success``, ``_cycle_start``, ``_cycle_summary``) are used as they are.
The step is sde_lanes.sde_lane_step (each lane's Z, sigma and words those of
averaged_sde.sde_step, bit for bit). After it, one loop over every lane the compiler can
vectorise updates the clocks and the amplitudes (the one before the step kept from the step
before: the same sqrt of the same Z) and finds the lanes that need a look (a boundary crossed at the
step's end, a bridge probability above e^-BRIDGE_CUT, a level gained, a cycle start, the
time up); only those then run the tests of the path alone (``_sde_hit``), lane by lane, the
bridge's uniforms drawn from the lane's own words in the same order. A lane whose path ends
takes the thread's next path (lanes.drop). Each path has its own four generator words
(ams.words: a fresh stream for every path and clone), so the numbers are those of the kernels
that ran one path at a time, for any lane, thread count or executor (benchmarks/mc_identity.py
``sde.escape``, ``sde.split``: 0 differ).

Threads: ``_jit.over_blocks`` with one "block" per path: thread t of n runs paths t, t + n, ...
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import jit, over_blocks
from .lanes import LANES, drop
from .rng import uniform
from .sde_lanes import N_FLOAT, R_A, R_A1, R_SIG, R_Z, sde_lane_step, sde_scratch
from .splitting_kernels import (
    BRIDGE_CUT,
    OUT_FAIL,
    OUT_SUCCESS,
    OUT_TIMEOUT,
    _cycle_start,
    _cycle_success,
    _cycle_summary,
    level_of,
)

# the lanes' own rows after sde_lanes's: float (time, cycle start time, cycles' total time;
# advance_sde: u = (q - q_lo) M / (q_hi - q_lo) of the next level, a float: AVX2 has no packed
# int64 -> double), int (the path's index, its level / armed, in a cycle, cycles completed,
# successes, look)
_T, _TC, _TOT = N_FLOAT, N_FLOAT + 1, N_FLOAT + 2
_UP = _TC
_J, _LEV, _IN, _K, _SUCC, _LOOK = range(6)
_ARM = _LEV


@jit(inline="always")
def _bridge(A0, A1, b, sig, h, s0, s1, s2, s3):
    """Whether the path crossed b inside a step from A0 to A1 (both on the same side of b)."""
    d = 2.0 * (A0 - b) * (A1 - b) / (sig * sig * h)
    if d > BRIDGE_CUT:
        return False, s0, s1, s2, s3
    u, s0, s1, s2, s3 = uniform(s0, s1, s2, s3)
    return u < math.exp(-d), s0, s1, s2, s3


@jit(inline="always")
def _sde_hit(A0, A1, sig, h, A_lo, A_hi, low_on, s0, s1, s2, s3):
    """The tests of a step from A0 to A1 with sigma sig: hit = 1 for a crossing of A_hi, -1 for
    one of A_lo (tested only with low_on), else 0 (the bridge's uniforms from s0..s3)."""
    if A1 >= A_hi:
        return 1, s0, s1, s2, s3
    if low_on and A1 <= A_lo:
        return -1, s0, s1, s2, s3
    if sig > 0.0:
        up, s0, s1, s2, s3 = _bridge(A0, A1, A_hi, sig, h, s0, s1, s2, s3)
        if up:
            return 1, s0, s1, s2, s3
        if low_on:
            down, s0, s1, s2, s3 = _bridge(A0, A1, A_lo, sig, h, s0, s1, s2, s3)
            if down:
                return -1, s0, s1, s2, s3
    return 0, s0, s1, s2, s3


CUT_SURE = BRIDGE_CUT * (1.0 + 1e-9)  # _quiet: d surely > BRIDGE_CUT without the division


@jit(inline="always")
def _quiet(a0, a1, sig, h, A_lo, A_hi, low_on):
    """Whether ``_sde_hit`` surely returns 0 without a draw: d > BRIDGE_CUT tested as
    2 (a0 - b)(a1 - b) > CUT_SURE sig^2 h, no division, with a margin of 1e-9 relative
    (a doubtful lane, or NaN anywhere, is not quiet: the look decides it exactly)."""
    s2h = CUT_SURE * (sig * sig * h)
    far_up = 2.0 * (a0 - A_hi) * (a1 - A_hi) > s2h
    far_lo = 2.0 * (a0 - A_lo) * (a1 - A_lo) > s2h
    no_low = (not low_on) | ((a1 > A_lo) & far_lo)
    return (a1 < A_hi) & no_low & ((sig <= 0.0) | far_up)


def advance_sde(recs, rows, start, rng, maxlev, outcome, q_lo, q_hi, M, t_max,
                h, a_tab, b_tab, inv_d):
    """Run path j (row rows[j] of recs, state row (Z = A^2, t), generator words rng[j]) from
    recs[row, start[j]] until it is absorbed (splitting_kernels' module docstring); fills
    recs[row, start[j] + 1 ..], maxlev[row] and outcome[row]. In lanes (module docstring)."""
    over_blocks(_advance_block, rows.size, recs, rows, start, rng, maxlev, outcome,
                (q_lo, q_hi, M, t_max), h, (a_tab, b_tab, inv_d))


@jit(nogil=True)
def _advance_block(first, every, recs, rows, start, rng, maxlev, outcome, levels, h, tabs):
    """advance_sde for paths first, first + every, ... (one thread's share)."""
    q_lo, q_hi, M, t_max = levels
    a_tab, b_tab, inv_d = tabs
    sq = math.sqrt(h)
    last = a_tab.size - 1
    inv_dq = M / (q_hi - q_lo)
    A_lo = math.sqrt(q_lo)
    A_hi = math.sqrt(q_hi)
    F, Li, S = sde_scratch(N_FLOAT + 2, 6)
    no_rows = np.zeros((0, LANES))
    Z, SG, A0, A1, T, UP = F[R_Z], F[R_SIG], F[R_A], F[R_A1], F[_T], F[_UP]
    LEV, LOOK = Li[_LEV], Li[_LOOK]
    nxt = first
    m = 0
    while True:
        while m < LANES and nxt < rows.size:  # the thread's next paths into the free lanes
            j = nxt
            nxt += every
            row = rows[j]
            z, t = recs[row, start[j], 0], recs[row, start[j], 1]
            lev = start[j]
            xi0 = level_of(z, q_lo, inv_dq, M)
            while lev < xi0:
                lev += 1
                recs[row, lev, 0] = z
                recs[row, lev, 1] = t
            if not t < t_max:
                maxlev[row] = lev
                outcome[row] = OUT_TIMEOUT
                continue
            Z[m], A1[m], T[m], Li[_J, m], LEV[m] = z, math.sqrt(z), t, j, lev
            UP[m] = lev + 1.0 if lev < M else math.inf
            for w in range(4):
                S[w, m] = rng[j, w]
            m += 1
        if m == 0:
            break
        sde_lane_step(m, F, S, h, sq, a_tab, b_tab, inv_d, last, True)
        for i in range(m):  # every lane: its clock, whether to look
            a0, a1 = A1[i], math.sqrt(Z[i])  # A1: sqrt of the Z before the step
            A0[i], A1[i] = a0, a1
            T[i] += h
            u = (Z[i] - q_lo) * inv_dq
            same = (Z[i] <= q_lo) | (u < UP[i])  # no level gained (level_of(Z) <= LEV)
            go_on = _quiet(a0, a1, SG[i], h, A_lo, A_hi, True) & same & (T[i] < t_max)
            LOOK[i] = 0 if go_on else 1
        for i in range(m - 1, -1, -1):  # the lanes to look at, last first (lanes.drop)
            if LOOK[i] == 0:
                continue
            row = rows[Li[_J, i]]
            hit, S[0, i], S[1, i], S[2, i], S[3, i] = _sde_hit(
                A0[i], A1[i], SG[i], h, A_lo, A_hi, True, S[0, i], S[1, i], S[2, i], S[3, i])
            lev = LEV[i]
            out = OUT_FAIL
            if hit != -1:
                xi = M if hit == 1 else level_of(Z[i], q_lo, inv_dq, M)
                while lev < xi:
                    lev += 1
                    recs[row, lev, 0] = Z[i]
                    recs[row, lev, 1] = T[i]
                LEV[i] = lev
                UP[i] = lev + 1.0 if lev < M else math.inf
                if hit == 1:
                    out = OUT_SUCCESS
                elif T[i] < t_max:
                    continue  # the path goes on
                else:
                    out = OUT_TIMEOUT
            maxlev[row] = lev
            outcome[row] = out
            m = drop(F, S, no_rows, Li, i, m)


def cycles_sde(starts, rng, n_cycles, q0, q1, q_hi, t_max, h, a_tab, b_tab, inv_d,
               entries, summary):
    """Direct simulation of the cycle decomposition, path p from starts[p] (a Z) with its own
    generator words rng[p]. Warm-up until the first cycle start, the first step at q >= q1 after
    a visit to q <= q0 (or a success first); then cycles, each from one cycle start to the next
    (or to the success, which ends the path), until n_cycles are complete or t_max.
    entries[p, k] = (Z, 0): the state at the start of cycle k. summary[p] = (warm-up time,
    1 if the warm-up ended at q_hi, cycles completed, their total time, successes,
    1 if t_max ended the path). In lanes (module docstring)."""
    over_blocks(_cycles_block, starts.size, starts, rng, (n_cycles, q0, q1, q_hi, t_max), h,
                (a_tab, b_tab, inv_d), entries, summary)


@jit(nogil=True)
def _cycles_block(first, every, starts, rng, cyc, h, tabs, entries, summary):
    """cycles_sde for paths first, first + every, ... (one thread's share)."""
    n_cycles, q0, q1, q_hi, t_max = cyc
    a_tab, b_tab, inv_d = tabs
    sq = math.sqrt(h)
    last = a_tab.size - 1
    A_lo = math.sqrt(q0)
    A_hi = math.sqrt(q_hi)
    F, Li, S = sde_scratch(N_FLOAT + 3, 6)
    no_rows = np.zeros((0, LANES))
    Z, SG, A0, A1, T = F[R_Z], F[R_SIG], F[R_A], F[R_A1], F[_T]
    ARM, LOOK = Li[_ARM], Li[_LOOK]
    nxt = first
    m = 0
    while True:
        while m < LANES and nxt < starts.size:  # the thread's next paths into the free lanes
            p = nxt
            nxt += every
            if 0.0 >= t_max:
                summary[p, 5] = 1.0
                _cycle_summary(summary, p, 0, 0.0, 0)
                continue
            Z[m], A1[m], T[m] = starts[p], math.sqrt(starts[p]), 0.0
            F[_TC, m], F[_TOT, m] = 0.0, 0.0
            Li[_J, m], Li[_IN, m], Li[_K, m], Li[_SUCC, m] = p, 0, 0, 0
            ARM[m] = 1 if starts[p] <= q0 else 0
            for w in range(4):
                S[w, m] = rng[p, w]
            m += 1
        if m == 0:
            break
        sde_lane_step(m, F, S, h, sq, a_tab, b_tab, inv_d, last, True)
        for i in range(m):  # every lane: its clock, whether to look
            a0, a1 = A1[i], math.sqrt(Z[i])  # A1: sqrt of the Z before the step
            A0[i], A1[i] = a0, a1
            T[i] += h
            armed = ARM[i] == 1
            quiet = _quiet(a0, a1, SG[i], h, A_lo, A_hi, not armed)
            start = armed & (Z[i] >= q1)
            go_on = quiet & (not start) & (T[i] < t_max)
            LOOK[i] = 0 if go_on else 1
        for i in range(m - 1, -1, -1):  # the lanes to look at, last first (lanes.drop)
            if LOOK[i] == 0:
                continue
            p = Li[_J, i]
            armed = ARM[i] == 1
            t = T[i]
            hit, S[0, i], S[1, i], S[2, i], S[3, i] = _sde_hit(
                A0[i], A1[i], SG[i], h, A_lo, A_hi, not armed, S[0, i], S[1, i], S[2, i],
                S[3, i])
            k, total, succ = Li[_K, i], F[_TOT, i], Li[_SUCC, i]
            in_cycle, t_cycle = Li[_IN, i] == 1, F[_TC, i]
            done = False
            if hit == 1:
                k, total, succ = _cycle_success(t, in_cycle, t_cycle, k, total, succ, summary, p)
                done = True
            else:
                if hit == -1:
                    armed = True
                if armed and Z[i] >= q1:
                    k, total, done = _cycle_start(t, in_cycle, t_cycle, k, total, n_cycles,
                                                  summary, p)
                    if not done:
                        Li[_IN, i] = 1
                        if k < entries.shape[1]:
                            entries[p, k, 0] = Z[i]
                            entries[p, k, 1] = 0.0
                        F[_TC, i] = t
                        armed = False
                if not done and t >= t_max:
                    summary[p, 5] = 1.0
                    done = True
            ARM[i] = 1 if armed else 0
            Li[_K, i], F[_TOT, i], Li[_SUCC, i] = k, total, succ
            if done:
                _cycle_summary(summary, p, k, total, succ)
                m = drop(F, S, no_rows, Li, i, m)
