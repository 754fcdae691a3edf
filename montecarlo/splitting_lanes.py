"""The splitting's kernels of the original system in struct-of-arrays lanes (issue 44): the AMS
advance (``advance_orig``) and the direct simulation of the cycles (``cycles_orig``).

Levels, outcomes, the cycles and the bridge test are splitting_kernels.py's module docstring;
the per-path bookkeeping helpers are its own (``level_of``, ``_cycle_success``,
``_cycle_start``, ``_cycle_summary``). The step is lanes.lane_step: LANES paths advance
together, the smooth part of the step vectorised and every lane that meets an event stepped
again by kernels.strang_step, so each lane's state is strang_step's, bit for bit, and its
generator words advance by the same draws (montecarlo/lanes.py).

After each step, **the screen**: one loop over the lanes, which the compiler vectorises,
updates every lane's clock and flags the lanes whose tests may act: its energy outside the
lane's own bounds L[_LO] < q < L[_HI] (the advance: q_lo and its next level's energy, lowered
by 1e-9 relative, ``_next_level``; the cycles: those of its phase and arming, ``_arm``,
``_to_burn``), its clock at its bound, a possible bridge draw (passage_kernels.bridge_near,
bridge_hit's own test). Only the flagged lanes then read their path's tests (levels, the bridge
test with the lane's velocity at the kick) as the path alone did, in scalar code, with the
energies after and before the step taken again from the lane's x, v and F[L_X0], F[L_V0] (the
same arithmetic, so the same numbers; nothing stored a step beyond the clock and the flag); a
flag is conservative (a flagged lane whose tests find nothing goes on as it would have), so the
screen changes no number. (A burn-in's clock counts its steps, 1.0 a step: exact.) The
screen indexes the scratch in place and calls scalar helpers only, and it is
written in the kernel's body: a row view, or an array passed to an inlined helper, costs two
atomic reference counts a step (numba's NRT; measured 1 ns a path-step for the screen as a
helper, 5 ns for row views), and inside the loop it stops the vectorisation. A lane whose path
ends takes the next path of its thread (``lanes.drop`` fills the hole with the last lane).
Each path keeps its own four generator words (a fresh stream for every path and every clone,
ams.words), so the numbers do not depend on the lanes, the thread count or the executor
(benchmarks/mc_identity.py: bit-identical to the kernels that ran one path at a time;
tests/test_splitting_lanes.py).

Threads: ``_jit.over_blocks`` with one "block" per path: thread t of n runs paths t, t + n, ...
"""

from __future__ import annotations

import math

import numpy as np

from ._jit import jit, over_blocks
from .geometry import energy
from .lanes import L_REST, L_V, L_V0, L_VC, L_X, L_X0, L_XI, LANES, drop, lane_step, scratch
from .passage_kernels import bridge_hit, bridge_near
from .splitting_kernels import (
    MAX_RESTARTS,
    OUT_FAIL,
    OUT_SUCCESS,
    OUT_TIMEOUT,
    _cycle_start,
    _cycle_success,
    _cycle_summary,
    level_of,
)

ON = -2  # a lane's path goes on (not an outcome)
# the lanes' own rows: float (time, cycle start time, cycles' total time; the screen's bounds:
# the energies between which the lane's tests cannot act, lo < q < hi, the clock's increment
# and its bound), int (the path's index, its level or phase, restarts, armed, in a cycle,
# cycles completed, successes, whether the lane's tests may act after this step)
_T, _TC, _TOT, _LO, _HI, _DT, _TMAX = range(7)
N_L = 7
_J, _LEV, _RS, _ARM, _IN, _K, _SUCC, _ACT = range(8)
N_LI = 8
MARGIN = 1e-9  # relative: a level's energy in the screen's bound (_next_level)
BURN, RUN = 0, 1  # cycles_orig's phases (in _LEV)
NONE, SUCCESS, START = 0, 1, 2  # what a cycle's step met (_cycle_test)


def advance_orig(recs, rows, start, rng, maxlev, outcome, levels, h, B, P):
    """splitting_kernels.advance_sde for the original system (state row (x, v, xi, t, time at
    rest)) with the physics record P (plan.Record for this h), the bridge test's
    B = (P.bridge, P.pk, P.pc) and ``levels`` = (q_lo, q_hi, M, t_max): path j (row rows[j] of
    recs, generator words rng[j]) runs from recs[row, start[j]] until it is absorbed; fills
    recs[row, start[j] + 1 ..], maxlev[row] and outcome[row]. In lanes (module docstring)."""
    over_blocks(_advance_block, rows.size, recs, rows, start, rng, maxlev, outcome, levels, h,
                B, P)


@jit(inline="always")
def _next_level(lev, q_lo, q_hi, inv_dq):
    """An energy below which level_of(q) <= lev and q < q_hi surely hold: the screen's bound
    (level lev + 1 at (q - q_lo) inv_dq >= lev + 1, lowered by MARGIN relative, far above
    the rounding of that test: a lane in the margin is flagged, its tests find nothing)."""
    e = (lev + 1.0) / inv_dq
    return min(q_hi, q_lo + e - MARGIN * (abs(q_lo) + e))


@jit(inline="always")
def _record(recs, row, lev, F, L, i):
    recs[row, lev, 0] = F[L_X, i]
    recs[row, lev, 1] = F[L_V, i]
    recs[row, lev, 2] = F[L_XI, i]
    recs[row, lev, 3] = L[_T, i]
    recs[row, lev, 4] = F[L_REST, i]


@jit(nogil=True)
def _advance_block(first, every, recs, rows, start, rng, maxlev, outcome, levels, h, B, P):
    """advance_orig for paths first, first + every, ... (one thread's share)."""
    q_lo, q_hi, M, t_max = levels
    w0sq, alpha, khi = P.w0sq, P.alpha, P.khi
    half = 0.5 * h
    inv_dq = M / (q_hi - q_lo)
    F, S = scratch()
    L = np.zeros((N_L, LANES))
    Li = np.zeros((N_LI, LANES), dtype=np.int64)
    nxt = first
    m = 0
    while True:
        while m < LANES and nxt < rows.size:  # the thread's next paths into the free lanes
            j = nxt
            nxt += every
            row, st = rows[j], start[j]
            x, v = recs[row, st, 0], recs[row, st, 1]
            q = energy(x, v, w0sq, alpha, khi)
            lev = st
            e = level_of(q, q_lo, inv_dq, M)
            while lev < e:
                lev += 1
                for c in range(5):
                    recs[row, lev, c] = recs[row, st, c]
            if not recs[row, st, 3] < t_max:
                maxlev[row] = lev
                outcome[row] = OUT_TIMEOUT
                continue
            F[L_X, m], F[L_V, m], F[L_XI, m] = x, v, recs[row, st, 2]
            F[L_REST, m] = recs[row, st, 4]
            for w in range(4):
                S[w, m] = rng[j, w]
            L[_T, m], L[_LO, m], L[_HI, m] = recs[row, st, 3], q_lo, _next_level(lev, q_lo, q_hi,
                                                                                 inv_dq)
            Li[_J, m], Li[_LEV, m] = j, lev
            m += 1
        if m == 0:
            break
        lane_step(m, F, S, h, half, P, False, True)  # count: the time at rest (L_REST)
        # the screen (module docstring): every lane's clock, and whether its tests may act
        # (not flagged: its energy inside (q_lo, q_hi) and below its next level, L[_HI]; no
        # bridge draw; t < t_max: it goes on unchanged)
        flagged = 0
        for i in range(m):
            q = energy(F[L_X, i], F[L_V, i], w0sq, alpha, khi)
            t = L[_T, i] + h
            L[_T, i] = t
            x0, vc = F[L_X0, i], F[L_VC, i]
            q0 = energy(x0, F[L_V0, i], w0sq, alpha, khi)  # (the bridge's; none: not made)
            a = ((not ((q > q_lo) & (q < L[_HI, i]))) | (t >= t_max)  # (NaN: flagged)
                 | bridge_near(B, q_hi, q0, q, x0, vc, h, P)
                 | bridge_near(B, q_lo, q0, q, x0, vc, h, P))
            Li[_ACT, i] = a
            flagged += a
        if flagged == 0:
            continue
        i = 0
        while i < m:
            if Li[_ACT, i] == 0:  # goes on unchanged
                i += 1
                continue
            row = rows[Li[_J, i]]
            # the energies after and before the step (the screen's, the same arithmetic)
            q = energy(F[L_X, i], F[L_V, i], w0sq, alpha, khi)
            q0 = energy(F[L_X0, i], F[L_V0, i], w0sq, alpha, khi)
            t = L[_T, i]
            out = ON
            if q <= q_lo:
                out = OUT_FAIL
            elif q < q_hi:  # a crossing of q_hi, then of q_lo, inside the step (the bridge)
                hb, S[0, i], S[1, i], S[2, i], S[3, i] = bridge_hit(
                    B, q_hi, q0, q, F[L_X0, i], F[L_VC, i], h, P, S[0, i], S[1, i], S[2, i],
                    S[3, i])
                if hb >= 0.0:
                    q = q_hi
                else:
                    hb, S[0, i], S[1, i], S[2, i], S[3, i] = bridge_hit(
                        B, q_lo, q0, q, F[L_X0, i], F[L_VC, i], h, P, S[0, i], S[1, i],
                        S[2, i], S[3, i])
                    if hb >= 0.0:
                        out = OUT_FAIL
            lev = Li[_LEV, i]
            if out == ON:
                e = level_of(q, q_lo, inv_dq, M)
                while lev < e:
                    lev += 1
                    _record(recs, row, lev, F, L, i)
                Li[_LEV, i], L[_HI, i] = lev, _next_level(lev, q_lo, q_hi, inv_dq)
                if q >= q_hi:
                    out = OUT_SUCCESS
                elif not t < t_max:
                    out = OUT_TIMEOUT
            if out == ON:
                i += 1
                continue
            maxlev[row] = lev
            outcome[row] = out
            m = drop(F, S, L, Li, i, m)  # lane i: the last lane's path, not yet read


def cycles_orig(starts, rng, cyc, h, B, P, entries, summary):
    """splitting_kernels.cycles_sde for the original system with the physics record P (and
    the bridge test's B = (P.bridge, P.pk, P.pc), all None: none), ``cyc`` = (n_cycles, q0,
    q1, q_hi, t_max, n_burn): starts[p] = (x, v, xi, 0, 0), entries[p, k] the state row at
    the start of cycle k (its time and time at rest set to 0). A success's time is
    interpolated linearly in the energy inside its step.
    n_burn > 0: first n_burn steps of free simulation, begun again from starts[p] (the stream
    goes on) whenever the energy reaches q_hi, at most MAX_RESTARTS times (then summary[p, 5]
    = 2); the clock starts after it: the start law is then the law at q < q_hi after a long
    run that stayed below, i.e. the stationary law restricted below the threshold when n_burn
    is several relaxation times. summary[p, 6] counts the restarts. In lanes (module
    docstring)."""
    over_blocks(_cycles_block, starts.shape[0], starts, rng, cyc, h, B, P, entries, summary)


@jit(inline="always")
def _restart(F, i, starts, p):
    F[L_X, i], F[L_V, i], F[L_XI, i] = starts[p, 0], starts[p, 1], starts[p, 2]


@jit(inline="always")
def _arm(L, Li, i, armed, q0, q1, q_hi):
    """A cycle's lane armed or not, and the screen's bounds that go with it (unarmed: its
    tests act at q <= q0 or q >= q_hi; armed: at q >= min(q1, q_hi))."""
    Li[_ARM, i] = 1 if armed else 0
    L[_LO, i], L[_HI, i] = (-math.inf, min(q1, q_hi)) if armed else (q0, q_hi)


@jit(inline="always")
def _to_burn(L, Li, i, q_hi, n_burn):
    """A burn-in (again) from its first step: the clock counts its steps (1.0 a step, whole
    numbers: exact), its tests act at q >= q_hi or after n_burn steps."""
    Li[_LEV, i] = BURN
    L[_T, i], L[_DT, i], L[_TMAX, i] = 0.0, 1.0, float(n_burn)
    L[_LO, i], L[_HI, i] = -math.inf, q_hi


@jit(inline="always")
def _to_run(F, L, Li, i, p, cyc, h, w0sq, alpha, khi, summary):
    """The burn-in over: the clock starts (cycles_sde's warm-up)."""
    n_cycles, q0, q1, q_hi, t_max, n_burn = cyc
    summary[p, 6] = Li[_RS, i]
    Li[_LEV, i] = RUN
    q = energy(F[L_X, i], F[L_V, i], w0sq, alpha, khi)
    L[_T, i], L[_TC, i], L[_TOT, i], L[_DT, i], L[_TMAX, i] = 0.0, 0.0, 0.0, h, t_max
    _arm(L, Li, i, q <= q0, q0, q1, q_hi)
    Li[_IN, i], Li[_K, i], Li[_SUCC, i] = 0, 0, 0


@jit(nogil=True)
def _cycles_block(first, every, starts, rng, cyc, h, B, P, entries, summary):
    """cycles_orig for paths first, first + every, ... (one thread's share)."""
    n_cycles, q0, q1, q_hi, t_max, n_burn = cyc
    w0sq, alpha, khi = P.w0sq, P.alpha, P.khi
    half = 0.5 * h
    F, S = scratch()
    L = np.zeros((N_L, LANES))
    Li = np.zeros((N_LI, LANES), dtype=np.int64)
    nxt = first
    m = 0
    while True:
        while m < LANES and nxt < starts.shape[0]:  # the thread's next paths into free lanes
            p = nxt
            nxt += every
            _restart(F, m, starts, p)
            F[L_REST, m] = 0.0
            for w in range(4):
                S[w, m] = rng[p, w]
            Li[_J, m], Li[_RS, m] = p, 0
            _to_burn(L, Li, m, q_hi, n_burn)
            if n_burn <= 0:
                _to_run(F, L, Li, m, p, cyc, h, w0sq, alpha, khi, summary)
                if not L[_T, m] < t_max:
                    summary[p, 5] = 1.0
                    _cycle_summary(summary, p, 0, 0.0, 0)
                    continue
            m += 1
        if m == 0:
            break
        lane_step(m, F, S, h, half, P, False, True)
        # the screen (module docstring): every lane's clock (a burn-in's counts its steps), and
        # whether its tests may act (not flagged: its energy inside the bounds of its phase
        # and arming, L[_LO] < q < L[_HI] (_arm, _to_burn), its clock below its bound, and a
        # cycle's step without a bridge draw: it goes on unchanged)
        flagged = 0
        for i in range(m):
            q = energy(F[L_X, i], F[L_V, i], w0sq, alpha, khi)
            t = L[_T, i] + L[_DT, i]
            L[_T, i] = t
            x0, vc = F[L_X0, i], F[L_VC, i]
            qo = energy(x0, F[L_V0, i], w0sq, alpha, khi)  # (the bridge's; none: not made)
            unarmed = Li[_ARM, i] == 0
            bridge = (Li[_LEV, i] == RUN) & (
                bridge_near(B, q_hi, qo, q, x0, vc, h, P)
                | (unarmed & (qo > q0) & bridge_near(B, q0, qo, q, x0, vc, h, P)))
            a = ((not ((q > L[_LO, i]) & (q < L[_HI, i]))) | (t >= L[_TMAX, i])  # (NaN: flagged)
                 | bridge)
            Li[_ACT, i] = a
            flagged += a
        if flagged > 0:
            m = _cycles_read(m, F, S, L, Li, starts, cyc, h, B, P, entries, summary)


@jit(inline="always")
def _cycles_read(m, F, S, L, Li, starts, cyc, h, B, P, entries, summary):
    """Each flagged lane's tests after a step (the burn-in's, or its cycles': ``_cycle_test``;
    the screen in ``_cycles_block`` flags them); a lane whose path ended is dropped. Returns
    the busy lanes left."""
    n_cycles, q0, q1, q_hi, t_max, n_burn = cyc
    w0sq, alpha, khi = P.w0sq, P.alpha, P.khi
    i = 0
    while i < m:
        if Li[_ACT, i] == 0:  # goes on unchanged
            i += 1
            continue
        p = Li[_J, i]
        done = False
        if Li[_LEV, i] == BURN:  # (its step counted by the screen)
            if energy(F[L_X, i], F[L_V, i], w0sq, alpha, khi) >= q_hi:
                Li[_RS, i] += 1
                if Li[_RS, i] > MAX_RESTARTS:
                    summary[p, 5] = 2.0
                    done = True
                else:
                    _restart(F, i, starts, p)
                    _to_burn(L, Li, i, q_hi, n_burn)
            if not done and L[_T, i] >= n_burn:
                _to_run(F, L, Li, i, p, cyc, h, w0sq, alpha, khi, summary)
                if not L[_T, i] < t_max:
                    summary[p, 5] = 1.0
                    _cycle_summary(summary, p, 0, 0.0, 0)
                    done = True
        else:  # a step of its cycles (cycles_sde's loop body)
            x, v, xi = F[L_X, i], F[L_V, i], F[L_XI, i]
            # the energies after and before the step (the screen's, the same arithmetic)
            q, t = energy(x, v, w0sq, alpha, khi), L[_T, i]
            q_old = energy(F[L_X0, i], F[L_V0, i], w0sq, alpha, khi)
            ev, tc, armed, S[0, i], S[1, i], S[2, i], S[3, i] = _cycle_test(
                q, q_old, F[L_X0, i], F[L_VC, i], t, h, Li[_ARM, i] == 1, q0, q1, q_hi, B, P,
                S[0, i], S[1, i], S[2, i], S[3, i])
            k, total, succ = Li[_K, i], L[_TOT, i], Li[_SUCC, i]
            in_cycle, t_cycle = Li[_IN, i] == 1, L[_TC, i]
            if ev == SUCCESS:
                k, total, succ = _cycle_success(tc, in_cycle, t_cycle, k, total, succ,
                                                summary, p)
                done = True
            elif ev == START:
                k, total, done = _cycle_start(t, in_cycle, t_cycle, k, total, n_cycles,
                                              summary, p)
                if not done:
                    Li[_IN, i] = 1
                    if k < entries.shape[1]:
                        entries[p, k, 0], entries[p, k, 1], entries[p, k, 2] = x, v, xi
                        entries[p, k, 3], entries[p, k, 4] = 0.0, 0.0
                    L[_TC, i] = t
                    armed = False
            _arm(L, Li, i, armed, q0, q1, q_hi)
            if not done and not t < t_max:
                summary[p, 5] = 1.0
                done = True
            Li[_K, i], L[_TOT, i], Li[_SUCC, i] = k, total, succ
            if done:
                _cycle_summary(summary, p, k, total, succ)
        if done:
            m = drop(F, S, L, Li, i, m)  # lane i: the last lane's path, not yet read
        else:
            i += 1
    return m


@jit(inline="always")
def _cycle_test(q, q_old, x0, vc, t, h, armed, q0, q1, q_hi, B, P, s0, s1, s2, s3):
    """The tests of a cycle's step from energy q_old to q (x0 the x before it, vc the velocity
    at the kick): (NONE, SUCCESS at time tc, or START of a cycle; armed; generator).
    Scalars in and out: array arguments, bound per lane and per step, cost the kernel 4x
    (their reference counts; measured 150 against 40 ns a path-step)."""
    if q >= q_hi:
        return SUCCESS, (t - h * (q - q_hi) / (q - q_old) if q > q_old else t), armed, s0, \
            s1, s2, s3
    # a crossing of q_hi inside the step (the bridge test; none drawn when B is all None)
    hb, s0, s1, s2, s3 = bridge_hit(B, q_hi, q_old, q, x0, vc, h, P, s0, s1, s2, s3)
    if hb >= 0.0:
        return SUCCESS, t - h + hb * h, armed, s0, s1, s2, s3
    if q <= q0:
        armed = True
    elif not armed and q_old > q0:  # a dip below q0 inside the step arms it too
        hb, s0, s1, s2, s3 = bridge_hit(B, q0, q_old, q, x0, vc, h, P, s0, s1, s2, s3)
        armed = hb >= 0.0
    if armed and q >= q1:
        return START, t, armed, s0, s1, s2, s3
    return NONE, t, armed, s0, s1, s2, s3
