"""The numba kernels of the original system's first passage through an energy threshold (the
method, the crossing inside the step and the bridge test are passage.py's module docstring):
the energy's variance over a step, the Brownian-bridge crossing test (also the splitting's,
splitting_kernels.py), each path's state machine, and the starts on an orbit."""

from __future__ import annotations

import math

import numpy as np
from vifpk.montecarlo._jit import jit, over_blocks
from vifpk.montecarlo.geometry import energy, orbit_start
from vifpk.montecarlo.kernels import damping_k, spring_g
from vifpk.montecarlo.lanes import (
    L_V,
    L_VC,
    L_X,
    L_X0,
    L_XI,
    LANES,
    drop,
    lane_step,
    scratch,
)
from vifpk.montecarlo.rng import uniform

BRIDGE_FLOOR = 1e-14  # below this bridge-crossing probability no uniform is drawn
# a path's state machine
NEW, BURN, RUN, CROSSED, CENSORED, DIVERGED, REFUSED = range(7)


@jit
def energy_variance(bridge, pk, pc, x, vc, h, P):
    """sigma_H^2 h of the module docstring: the energy's variance over the step, frozen at the
    velocity at the kick vc and at x; 0 when no term is on (OU noise without parametric
    noise). The record's fields that may be None are arguments (numba prunes their terms)."""
    s = 0.0
    if bridge is not None:
        s = bridge * vc * vc * h
    if pk is not None:
        gk = pk * spring_g(x, P.w0sq, P.alpha, P.khi) * vc
        s += 2.0 * gk * gk
    if pc is not None:
        dc = pc * damping_k(x, P.c1, P.c2, P.dhi) * vc * vc
        s += 2.0 * dc * dc
    return s


@jit
def bridge_hit(B, level, E, E1, x, vc, h, P, s0, s1, s2, s3):
    """(fraction of the step at the crossing, or -1: none; generator) by the Brownian-bridge
    test of the module docstring with B = (bridge, pk, pc) (all None: no test); never a
    crossing (and no draw) when the variance is 0."""
    var = energy_variance(B[0], B[1], B[2], x, vc, h, P)
    if not var > 0.0:
        return -1.0, s0, s1, s2, s3
    arg = 2.0 * (level - E) * (level - E1) / var
    if arg < -math.log(BRIDGE_FLOOR):
        u, s0, s1, s2, s3 = uniform(s0, s1, s2, s3)
        if u < math.exp(-arg):
            return (level - E) / ((level - E) + (level - E1)), s0, s1, s2, s3
    return -1.0, s0, s1, s2, s3


@jit
def bridge_near(B, level, E, E1, x, vc, h, P):
    """Whether ``bridge_hit`` with these arguments draws a uniform (its tests, the same
    arithmetic; False when B is all None): the lane kernels' screen, in their vectorised loops,
    of the lanes whose tests must run."""
    var = energy_variance(B[0], B[1], B[2], x, vc, h, P)
    return (var > 0.0) & (2.0 * (level - E) * (level - E1) / var < -math.log(BRIDGE_FLOOR))


def run_passage(arrs, count, run, h, B, P):
    """Advance every unfinished path by at most ``budget`` steps (its state machine: NEW ->
    [BURN ->] RUN -> CROSSED | CENSORED, or DIVERGED / REFUSED) with the physics record P
    (plan.Record for this h) and the bridge test's B = (P.bridge, P.pk, P.pc) (all None or 0:
    no bridge test, discrete monitoring only); ``arrs`` = (rng, state, init, phase, steps, tries,
    fpt), per-path arrays [b, p] updated in place (``init``: the state at which the path's
    clock started); ``run`` = (budget, n_max, n_burn, horizon, Ec, a_start, a_burn, max_tries).
    One block per thread at a time (``_passage_block`` by ``_jit.over_blocks``)."""
    over_blocks(_passage_block, arrs[1].shape[0], arrs, count, run, h, B, P)


@jit(inline="always")
def _take(L, Li, F, S, j, arrs, b, p):
    """Path p of block b into lane j (its state, generator, phase, steps; a fresh chunk)."""
    rng, state, init, phase, steps, tries, fpt = arrs
    F[L_X, j], F[L_V, j], F[L_XI, j] = state[b, p, 0], state[b, p, 1], state[b, p, 2]
    for w in range(4):
        S[w, j] = rng[b, p, w]
    Li[_PATH, j], Li[_PH, j], Li[_N, j] = p, phase[b, p], steps[b, p]
    Li[_I, j], Li[_K, j] = 0, 0


@jit(inline="always")
def _give(L, Li, F, S, j, arrs, b):
    """The inverse of ``_take``: lane j's path back to the block's arrays."""
    rng, state, init, phase, steps, tries, fpt = arrs
    p = Li[_PATH, j]
    state[b, p, 0], state[b, p, 1], state[b, p, 2] = F[L_X, j], F[L_V, j], F[L_XI, j]
    for w in range(4):
        rng[b, p, w] = S[w, j]
    steps[b, p], phase[b, p] = Li[_N, j], Li[_PH, j]


# rows of the passage's own lane scratch: float (energy at the chunk's last step, level), int
# (path index, phase, steps, steps into the chunk, chunk length, budget left, whether the
# lane's tests may act after this step)
_E, _LEVEL = range(2)
_PATH, _PH, _N, _I, _K, _LEFT, _ACT = range(7)


@jit(nogil=True)
def _passage_block(first, every, arrs, count, run, h, B, P):
    """run_passage for the ``count[b]`` paths of each block b = first, first + every, ...
    (``_jit.over_blocks`` runs one such call per thread), LANES unfinished paths of a block at
    a time in lanes (montecarlo/lanes.py): each lane runs its own path's state machine, and a
    lane whose path ends (crossed, censored, refused, diverged, or out of budget for this call)
    takes the block's next unfinished path. Each path's arithmetic, draws and state machine are
    those of the path advanced alone (chunks of k = min(budget left, steps to the phase's end)
    steps, the finiteness test at each chunk's end), so results do not depend on the lanes."""
    rng, state, init, phase, steps, tries, fpt = arrs
    budget, n_max, n_burn, horizon, Ec, a_start, a_burn, max_tries = run
    w0sq, alpha, khi = P.w0sq, P.alpha, P.khi
    half = 0.5 * h
    F, S = scratch()
    L = np.zeros((2, LANES))
    Li = np.zeros((7, LANES), dtype=np.int64)
    for b in range(first, state.shape[0], every):  # this thread's blocks
        n_paths = count[b]
        nxt = 0
        m = 0
        fresh = False  # a lane filled or a chunk ended since the chunk starts' loop ran
        while True:
            # fill the free lanes with the block's next unfinished paths
            while m < LANES and nxt < n_paths:
                if phase[b, nxt] < CROSSED:
                    _take(L, Li, F, S, m, arrs, b, nxt)
                    Li[_LEFT, m] = budget
                    m += 1
                    fresh = True
                nxt += 1
            if m == 0:
                break
            # each lane to the start of a chunk of steps (or its path out: budget spent); only
            # after a lane was filled or a chunk ended (no lane needs it otherwise)
            j = m if not fresh else 0
            fresh = False
            while j < m:
                p = Li[_PATH, j]
                done = False
                while Li[_I, j] == 0 and Li[_K, j] == 0:  # no chunk under way
                    if Li[_LEFT, j] <= 0:
                        done = True
                        break
                    ph = Li[_PH, j]
                    if ph == NEW:
                        amp = a_burn if n_burn > 0 else a_start
                        x, v, xi, S[0, j], S[1, j], S[2, j], S[3, j] = orbit_start(
                            amp, w0sq, alpha, khi, P.fold, P.x_lo, P.x_hi, P, S[0, j],
                            S[1, j], S[2, j], S[3, j])
                        F[L_X, j], F[L_V, j], F[L_XI, j] = x, v, xi
                        Li[_N, j] = 0
                        Li[_PH, j] = BURN if n_burn > 0 else RUN
                        if Li[_PH, j] == RUN:
                            init[b, p, 0], init[b, p, 1], init[b, p, 2] = x, v, xi
                        continue
                    burning = ph == BURN
                    L[_LEVEL, j] = math.inf if burning else Ec
                    L[_E, j] = energy(F[L_X, j], F[L_V, j], w0sq, alpha, khi)
                    Li[_K, j] = min(Li[_LEFT, j], (n_burn if burning else n_max) - Li[_N, j])
                if done:
                    _give(L, Li, F, S, j, arrs, b)
                    m = drop(F, S, L, Li, j, m)
                    continue  # lane j now holds another path (or none)
                j += 1
            if m == 0:
                continue
            lane_step(m, F, S, h, half, P, False, False)
            # the screen, in one loop the compiler vectorises (the scratch indexed in place,
            # scalar helpers only: splitting_lanes.py's module docstring): every lane's energy
            # and whether its tests may act; a lane not flagged (below its level, no bridge
            # draw, its chunk not at its end) only keeps the energy and counts the step, here
            flagged = 0
            for j in range(m):
                E, level = L[_E, j], L[_LEVEL, j]
                E1 = energy(F[L_X, j], F[L_V, j], w0sq, alpha, khi)
                i = Li[_I, j] + 1
                a = ((E1 >= level) | (i >= Li[_K, j])
                     | bridge_near(B, level, E, E1, F[L_X0, j], F[L_VC, j], h, P))
                L[_E, j] = E if a else E1
                Li[_I, j] = Li[_I, j] if a else i
                Li[_ACT, j] = a
                flagged += a
            if flagged == 0:
                continue
            j = 0
            while j < m:
                if Li[_ACT, j] == 0:  # its chunk goes on (energy and step kept by _screen)
                    j += 1
                    continue
                p = Li[_PATH, j]
                x, v = F[L_X, j], F[L_V, j]
                E, level = L[_E, j], L[_LEVEL, j]
                E1 = energy(x, v, w0sq, alpha, khi)
                i = Li[_I, j] + 1
                k = Li[_K, j]
                hit = -1.0
                if E1 >= level:
                    hit = (level - E) / (E1 - E)
                else:
                    hb, S[0, j], S[1, j], S[2, j], S[3, j] = bridge_hit(
                        B, level, E, E1, F[L_X0, j], F[L_VC, j], h, P, S[0, j], S[1, j],
                        S[2, j], S[3, j])
                    if hb >= 0.0:
                        hit = hb
                    else:
                        L[_E, j] = E1
                if hit < 0.0 and i < k:  # the chunk goes on
                    Li[_I, j] = i
                    j += 1
                    continue
                # the chunk's end: the path alone's bookkeeping after its inner loop
                Li[_I, j], Li[_K, j] = 0, 0
                fresh = True
                n = Li[_N, j]
                finished = True
                if not (math.isfinite(x) and math.isfinite(v)):
                    Li[_PH, j] = DIVERGED
                    Li[_N, j] = n + i
                elif Li[_PH, j] == BURN:
                    n += k
                    Li[_LEFT, j] -= k
                    finished = False
                    if n == n_burn:
                        if L[_E, j] < Ec:  # E after the chunk (a hit keeps the one before)
                            Li[_PH, j] = RUN
                            n = 0
                            init[b, p, 0], init[b, p, 1], init[b, p, 2] = x, v, F[L_XI, j]
                        else:
                            tries[b, p] += 1
                            if tries[b, p] > max_tries:
                                Li[_PH, j] = REFUSED
                                finished = True
                            else:
                                Li[_PH, j] = NEW
                    Li[_N, j] = n
                elif hit >= 0.0:
                    t = (n + i - 1 + hit) * h
                    Li[_N, j] = n + i
                    if t <= horizon:
                        Li[_PH, j] = CROSSED
                        fpt[b, p] = t
                    else:
                        Li[_PH, j] = CENSORED
                        fpt[b, p] = horizon
                else:
                    n += k
                    Li[_LEFT, j] -= k
                    Li[_N, j] = n
                    finished = n >= n_max
                    if finished:
                        Li[_PH, j] = CENSORED
                        fpt[b, p] = horizon
                if finished:
                    _give(L, Li, F, S, j, arrs, b)
                    m = drop(F, S, L, Li, j, m)  # lane j: the last lane's path, not yet read
                    continue
                j += 1


@jit
def starts_loop(rng, out, A, w0sq, alpha, khi, walls, P):
    """out[i] = orbit_start(A, ...) with path i's generator words; walls = (fold, lo, up); P
    the kernels' record (its class: the noise kind's state start, pieces.py)."""
    fold_, lo, up = walls
    for i in range(out.shape[0]):
        x, v, xi, s0, s1, s2, s3 = orbit_start(A, w0sq, alpha, khi, fold_, lo, up, P,
                                               rng[i, 0], rng[i, 1], rng[i, 2], rng[i, 3])
        out[i, 0], out[i, 1], out[i, 2] = x, v, xi
        rng[i, 0], rng[i, 1], rng[i, 2], rng[i, 3] = s0, s1, s2, s3

