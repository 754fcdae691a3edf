"""numba kernels of the splitting estimator (splitting.py): a path run from a given state until
it is absorbed, with the states it had when it first reached each level of the reaction
coordinate (AMS), and the direct simulation of the cycles (the cycle decomposition). The
original system's pair (``advance_orig``, ``cycles_orig``) runs its paths in vector lanes and
is in splitting_lanes.py, with this module's conventions and bookkeeping helpers.

Two dynamics, each with its own pair of kernels and the same conventions:
- the averaged amplitude SDE, state row (Z = A^2, t); the step is averaged_sde.sde_step (not a
  copy), and the reaction coordinate is q = Z;
- the original system, state row (x, v, xi, t, time at rest); the step is kernels.strang_step (not a
  copy), and the reaction coordinate is the energy q = E = v^2/2 + U(x) (geometry.energy).
  The state at rest needs no flag of its own: the kernel's rest is v == 0 exactly (and x == 0
  at the wall), which the copied row carries.

Levels: q_lo < q_hi and ``levels`` = M; the level of a state is
xi(q) = min(M, floor((q - q_lo) M / (q_hi - q_lo))) (0 below q_lo). A path is absorbed at q <= q_lo
(a return: outcome 0) or q >= q_hi (a success, level M: outcome 1); outcome -1 when it reached
``t_max`` first. ``recs[row, j]`` is the state at the first step where the level was >= j.

Random numbers: each path is given its own four generator words by the caller (a fresh stream
for every path and every clone), so the results do not depend on the thread count.

Crossings inside a step: for the SDE, a step that ends short of a boundary (A_lo = sqrt(q_lo)
or A_hi = sqrt(q_hi)) is counted as a crossing with the Brownian-bridge probability
exp(-2 (A_n - b)(A_{n+1} - b) / (sigma^2 h)) (sigma frozen over the step), which removes the
O(sqrt h) bias of a discretely monitored boundary (Broadie, Glasserman & Kou 1997; Gobet 2000);
for the original system the energy's own test (passage_kernels.bridge_hit, sigma_H^2 of
passage.py's docstring: white external noise and the Stratonovich parametric noises) at the two
boundaries q_lo (a return; in cycles_orig the arming below q0) and q_hi (a success), with the
physics record's B = (bridge, pk, pc); under OU noise alone the energy is C^1 in time, B is all
None, so a missed crossing costs O(h^2) per step and none is drawn. The burn-in of cycles_orig
tests q_hi at the step ends only. A success's time is interpolated linearly inside the step.
"""

from __future__ import annotations

import math

from numba import prange

from ._jit import jit
from .averaged_sde import sde_step
from .geometry import orbit_start
from .rng import uniform

OUT_FAIL, OUT_SUCCESS, OUT_TIMEOUT = 0, 1, -1
BRIDGE_CUT = 40.0  # no uniform is drawn when the bridge probability is below e^-40
MAX_RESTARTS = 100  # burn-ins a path may begin again (cycles_orig)


@jit(inline="always")
def level_of(q, q_lo, inv_dq, M):
    """The level xi(q) of the module docstring."""
    if q <= q_lo:
        return 0
    u = (q - q_lo) * inv_dq
    if u >= M:
        return M
    return int(u)


@jit(inline="always")
def _bridge(A0, A1, b, sig, h, s0, s1, s2, s3):
    """Whether the path crossed b inside a step from A0 to A1 (both on the same side of b)."""
    d = 2.0 * (A0 - b) * (A1 - b) / (sig * sig * h)
    if d > BRIDGE_CUT:
        return False, s0, s1, s2, s3
    u, s0, s1, s2, s3 = uniform(s0, s1, s2, s3)
    return u < math.exp(-d), s0, s1, s2, s3


@jit(inline="always")
def _sde_move(Z, s0, s1, s2, s3, h, sq, a_tab, b_tab, inv_d, last, A_lo, A_hi, low_on):
    """One SDE step with the bridge test at the two boundaries: (Z, hit) with hit = 1 for a
    crossing of A_hi, -1 for one of A_lo (tested only with low_on), else 0."""
    A0 = math.sqrt(Z)
    Z, sig, _r, s0, s1, s2, s3 = sde_step(Z, s0, s1, s2, s3, h, sq, a_tab, b_tab, inv_d, last)
    A1 = math.sqrt(Z)
    if A1 >= A_hi:
        return Z, 1, s0, s1, s2, s3
    if low_on and A1 <= A_lo:
        return Z, -1, s0, s1, s2, s3
    if sig > 0.0:
        up, s0, s1, s2, s3 = _bridge(A0, A1, A_hi, sig, h, s0, s1, s2, s3)
        if up:
            return Z, 1, s0, s1, s2, s3
        if low_on:
            down, s0, s1, s2, s3 = _bridge(A0, A1, A_lo, sig, h, s0, s1, s2, s3)
            if down:
                return Z, -1, s0, s1, s2, s3
    return Z, 0, s0, s1, s2, s3


@jit(inline="always")
def _cycle_success(tc, in_cycle, t_cycle, k, total, succ, summary, p):
    """The threshold reached at time tc: the cycle in progress ends with a success, or the
    warm-up ends at the threshold (summary[p, 0:2]). Returns (k, total, succ)."""
    if in_cycle:
        return k + 1, total + (tc - t_cycle), succ + 1
    summary[p, 0] = tc
    summary[p, 1] = 1.0
    return k, total, succ


@jit(inline="always")
def _cycle_start(t, in_cycle, t_cycle, k, total, n_cycles, summary, p):
    """A cycle start at time t (the first step at q >= q1 after a visit to q <= q0): ends the
    cycle in progress, or the warm-up (summary[p, 0]). Returns (k, total, done: n_cycles
    complete)."""
    if in_cycle:
        k += 1
        total += t - t_cycle
        if k >= n_cycles:
            return k, total, True
    else:
        summary[p, 0] = t
    return k, total, False


@jit(inline="always")
def _cycle_summary(summary, p, k, total, succ):
    summary[p, 2] = k
    summary[p, 3] = total
    summary[p, 4] = succ


@jit(parallel=True)
def advance_sde(recs, rows, start, rng, maxlev, outcome, q_lo, q_hi, M, t_max,
                h, a_tab, b_tab, inv_d):
    """Run path j (row rows[j] of recs) from recs[row, start[j]] until it is absorbed (see the
    module docstring); fills recs[row, start[j] + 1 ..], maxlev[row] and outcome[row]."""
    sq = math.sqrt(h)
    last = a_tab.size - 1
    inv_dq = M / (q_hi - q_lo)
    A_lo = math.sqrt(q_lo)
    A_hi = math.sqrt(q_hi)
    for j in prange(rows.size):
        row = rows[j]
        s0, s1, s2, s3 = rng[j, 0], rng[j, 1], rng[j, 2], rng[j, 3]
        Z = recs[row, start[j], 0]
        t = recs[row, start[j], 1]
        lev = start[j]
        xi0 = level_of(Z, q_lo, inv_dq, M)
        while lev < xi0:
            lev += 1
            recs[row, lev, 0] = Z
            recs[row, lev, 1] = t
        out = OUT_TIMEOUT
        while t < t_max:
            Z, hit, s0, s1, s2, s3 = _sde_move(Z, s0, s1, s2, s3, h, sq, a_tab, b_tab, inv_d,
                                               last, A_lo, A_hi, True)
            t += h
            if hit == -1:
                out = OUT_FAIL
                break
            xi = M if hit == 1 else level_of(Z, q_lo, inv_dq, M)
            while lev < xi:
                lev += 1
                recs[row, lev, 0] = Z
                recs[row, lev, 1] = t
            if hit == 1:
                out = OUT_SUCCESS
                break
        maxlev[row] = lev
        outcome[row] = out


@jit(parallel=True)
def cycles_sde(starts, rng, n_cycles, q0, q1, q_hi, t_max, h, a_tab, b_tab, inv_d,
               entries, summary):
    """Direct simulation of the cycle decomposition, path p from starts[p] (a Z) with its own
    generator words rng[p]. Warm-up until the first cycle start, the first step at q >= q1 after
    a visit to q <= q0 (or a success first); then cycles, each from one cycle start to the next
    (or to the success, which ends the path), until n_cycles are complete or t_max.
    entries[p, k] = (Z, 0): the state at the start of cycle k. summary[p] = (warm-up time,
    1 if the warm-up ended at q_hi, cycles completed, their total time, successes,
    1 if t_max ended the path)."""
    sq = math.sqrt(h)
    last = a_tab.size - 1
    A_lo = math.sqrt(q0)
    A_hi = math.sqrt(q_hi)
    for p in prange(starts.size):
        s0, s1, s2, s3 = rng[p, 0], rng[p, 1], rng[p, 2], rng[p, 3]
        Z = starts[p]
        t = 0.0
        armed = Z <= q0
        in_cycle = False
        t_cycle = 0.0
        k = 0
        total = 0.0
        succ = 0
        while True:
            if t >= t_max:
                summary[p, 5] = 1.0
                break
            Z, hit, s0, s1, s2, s3 = _sde_move(Z, s0, s1, s2, s3, h, sq, a_tab, b_tab, inv_d,
                                               last, A_lo, A_hi, not armed)
            t += h
            if hit == 1:
                k, total, succ = _cycle_success(t, in_cycle, t_cycle, k, total, succ, summary, p)
                break
            if hit == -1:
                armed = True
            if armed and Z >= q1:
                k, total, done = _cycle_start(t, in_cycle, t_cycle, k, total, n_cycles, summary,
                                              p)
                if done:
                    break
                in_cycle = True
                if k < entries.shape[1]:
                    entries[p, k, 0] = Z
                    entries[p, k, 1] = 0.0
                t_cycle = t
                armed = False
        _cycle_summary(summary, p, k, total, succ)


@jit
def orbit_starts(A, out, rng, w0sq, alpha, khi, walls, P):
    """out[p] = (x, v, xi, 0, 0) from geometry.orbit_start (phase uniform in time on the
    conservative orbit of amplitude A, on the walls' elastic orbit, xi from its stationary
    law: the kind of the kernels' record P), with the generator words rng[p]; walls = (fold,
    lo, up)."""
    fold, lo, up = walls
    for p in range(out.shape[0]):
        x, v, xi, _s0, _s1, _s2, _s3 = orbit_start(A, w0sq, alpha, khi, fold, lo, up, P,
                                                   rng[p, 0], rng[p, 1], rng[p, 2], rng[p, 3])
        out[p, 0] = x
        out[p, 1] = v
        out[p, 2] = xi
        out[p, 3] = 0.0
        out[p, 4] = 0.0
