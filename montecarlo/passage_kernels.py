"""The numba kernels of the original system's first passage through an energy threshold (the
method, the crossing inside the step and the bridge test are passage.py's module docstring):
the energy's variance over a step, the Brownian-bridge crossing test (also the splitting's,
splitting_kernels.py), each path's state machine, and the starts on an orbit."""

from __future__ import annotations

import math

from vifpk.montecarlo._jit import jit, over_blocks
from vifpk.montecarlo.geometry import energy, orbit_start
from vifpk.montecarlo.kernels import damping_k, spring_g, strang_step
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


def run_passage(arrs, count, run, h, B, P):
    """Advance every unfinished path by at most ``budget`` steps (its state machine: NEW ->
    [BURN ->] RUN -> CROSSED | CENSORED, or DIVERGED / REFUSED) with the physics record P
    (plan.Record for this h) and the bridge test's B = (P.bridge, P.pk, P.pc) (all None or 0:
    no bridge test, discrete monitoring only); ``arrs`` = (rng, state, init, phase, steps, tries,
    fpt), per-path arrays [b, p] updated in place (``init``: the state at which the path's
    clock started); ``run`` = (budget, n_max, n_burn, horizon, Ec, a_start, a_burn, max_tries).
    One block per thread at a time (``_passage_block`` by ``_jit.over_blocks``)."""
    over_blocks(_passage_block, arrs[1].shape[0], arrs, count, run, h, B, P)


@jit(nogil=True)
def _passage_block(first, every, arrs, count, run, h, B, P):
    """run_passage for the ``count[b]`` paths of each block b = first, first + every, ..., one
    path after the other (``_jit.over_blocks`` runs one such call per thread)."""
    rng, state, init, phase, steps, tries, fpt = arrs
    budget, n_max, n_burn, horizon, Ec, a_start, a_burn, max_tries = run
    w0sq, alpha, khi = P.w0sq, P.alpha, P.khi
    half = 0.5 * h
    for b in range(first, state.shape[0], every):  # this thread's blocks
        n_paths = count[b]
        for p in range(n_paths):
            ph = phase[b, p]
            if ph >= CROSSED:
                continue
            x, v, xi = state[b, p, 0], state[b, p, 1], state[b, p, 2]
            s0, s1, s2, s3 = rng[b, p, 0], rng[b, p, 1], rng[b, p, 2], rng[b, p, 3]
            n = steps[b, p]
            left = budget
            while left > 0:
                if ph == NEW:
                    amp = a_burn if n_burn > 0 else a_start
                    x, v, xi, s0, s1, s2, s3 = orbit_start(amp, w0sq, alpha, khi, P.fold, P.x_lo,
                                                           P.x_hi, P, s0, s1, s2, s3)
                    n = 0
                    ph = BURN if n_burn > 0 else RUN
                    if ph == RUN:
                        init[b, p, 0], init[b, p, 1], init[b, p, 2] = x, v, xi
                    continue
                # BURN and RUN share one loop (one copy of the inlined step: half the compile
                # time): a burn-in tests against Ec = inf, which never fires (nor the bridge)
                burning = ph == BURN
                level = math.inf if burning else Ec
                E = energy(x, v, w0sq, alpha, khi)
                k = min(left, (n_burn if burning else n_max) - n)
                hit = -1.0
                i = 0
                while i < k:
                    x0 = x
                    x, v, xi, s0, s1, s2, s3, o = strang_step(x, v, xi, s0, s1, s2, s3, h, half, P)
                    E1 = energy(x, v, w0sq, alpha, khi)
                    i += 1
                    if E1 >= level:
                        hit = (level - E) / (E1 - E)
                        break
                    # o[8]: the velocity at the kick
                    hb, s0, s1, s2, s3 = bridge_hit(B, level, E, E1, x0, o[8], h, P, s0, s1, s2,
                                                    s3)
                    if hb >= 0.0:
                        hit = hb
                        break
                    E = E1
                if not (math.isfinite(x) and math.isfinite(v)):
                    ph = DIVERGED
                    n += i
                    break
                if burning:
                    n += k
                    left -= k
                    if n == n_burn:
                        if E < Ec:
                            ph = RUN
                            n = 0
                            init[b, p, 0], init[b, p, 1], init[b, p, 2] = x, v, xi
                        else:
                            tries[b, p] += 1
                            if tries[b, p] > max_tries:
                                ph = REFUSED
                                break
                            ph = NEW
                    continue
                if hit >= 0.0:
                    t = (n + i - 1 + hit) * h
                    n += i
                    if t <= horizon:
                        ph = CROSSED
                        fpt[b, p] = t
                    else:
                        ph = CENSORED
                        fpt[b, p] = horizon
                    break
                n += k
                left -= k
                if n >= n_max:
                    ph = CENSORED
                    fpt[b, p] = horizon
                    break
            state[b, p, 0], state[b, p, 1], state[b, p, 2] = x, v, xi
            rng[b, p, 0], rng[b, p, 1], rng[b, p, 2], rng[b, p, 3] = s0, s1, s2, s3
            steps[b, p] = n
            phase[b, p] = ph


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

