"""numba kernels for the ORIGINAL non-smooth system (Liu et al. 2019, eq. 17)::

    x'' + (c2 x^2 - c1) x' + w0^2 x + alpha x^3 + mu sgn(x') = f xi(t),   x > 0
    x'(+) = -r x'(-) at x = 0;   xi' = -alpha1 xi + W (OU)  or  xi = W (white), E[W W] = 2 D delta

and its generalisation (issue 37): walls anywhere, a lower wall at x = a <= 0 and/or an upper
wall at x = b >= 0, each with its impact law x'(+) = -e(|x'(-)|) x'(-) (vifpk/physics/impact/:
Newton's e = r, Johnson's elastic-plastic e(v)); the noise kind's stage and state update are
its own pieces (vifpk/physics/noise/, compiled by montecarlo/pieces.py). Every kernel takes one
physics record (pieces.record); the walls' laws and the noise kind are its class.

One step of size h is the Strang splitting (weak order 2 on the smooth sub-system)::

    OU:    A(h/2)  B(h; xi)                     A(h/2)  C(h)
    white: A(h/2)  B(h/2)  kick f sqrt(2 D h) N  B(h/2)  A(h/2)

- A(tau), drift: x += v tau. With a wall the root of x = a (or b) inside the sub-step is
  exact (x is linear there): v -> -e v and the rest of the sub-step is completed (pieces.py:
  ``wall_drift``, ``reflect``; one impact per drift sub-step).
  Chatter guard: if the rebound speed e|v| is below P h, with P > 0 the net force pressing
  the mass back onto the wall (the spring's g(a) and the noise force held at the wall, plus
  friction mu against the rebound), the next flight is shorter than one step: the mass comes
  to rest on the wall, v = 0. It leaves when the net force pulls it away by more than mu (the
  rule of B at the wall).
- B(tau), velocity: x and xi frozen, v' = F - k v - mu sgn(v) with F = -g(x) + f xi,
  k = c2 x^2 - c1. Linear in v between sign changes, so solved exactly:
  v(t) = v e^{-kt} + (F - mu s) t phi(kt), phi(z) = (1 - e^{-z}) / z. A zero crossing at
  t* = (-v/F') log1p(z)/z, z = -k v / F', is found analytically; at v = 0 the mass sticks
  while |F| <= mu (at the wall: while F <= mu), else slips the other way.
- C(h): the exact OU update xi <- a xi + sqrt(D/alpha1 (1 - a^2)) N, a = e^{-alpha1 h}.
  (C(h/2) C(h/2) of consecutive steps merge: xi lives at the middle of each step.)

The general system (issue 21) adds, each ``None`` when the scene does not have it:
``khi`` = (k5, k7, ...) to the spring, g += x^5 (k5 + k7 x^2 + ...); ``dhi`` = (d4, d6, ...) to
the damping coefficient, k += x^4 (d4 + d6 x^2 + ...) (k = d0 + d2 x^2 = c2 x^2 - c1 as above);
``ev`` = (e2, e4, ...) the velocity damping (e2 v^2 + ...) v, taken as its own sub-flow
V(h/2) around B (velocity_decay; the composition stays symmetric, so Strang's order holds).

Switched-off effects are ``None`` (mu, r, alpha1 for white noise, higher-order terms): numba
prunes those branches at compile time, so the paper's scenes compile no code of the general
terms. Unrequested outputs (histograms, moments, the certificate's windows, the energy
balance) are empty arrays (last axis 0), tested once a sample (the energy balance: once a
step): one machine code for every choice of observables. (As None they were compile-time
switches too, and the test suite compiled 53 specialisations of ``run_paths`` for 10 physics
combinations, ~10 s each from a cold cache: most of a fresh CI run's time.)
"""

from __future__ import annotations

import math

from ._jit import jit, over_blocks
from .geometry import amplitude_general, poly_x2
from .pieces import (
    noise_advance,
    noise_energy,
    noise_press,
    noise_velocity,
    wall_drift,
    wall_side,
)
from .rng import normal

# columns of the per-block event array (whole numbers: counts; EV_TIME the sampled path-steps,
# times h is the sampled path-time; EV_STUCK filled by the caller from the per-path stuck_time)
(EV_IMPACTS, EV_STUCK, EV_CHATTER, EV_TIME, EV_SAMPLES, EV_OUT_A, EV_OUT_X, EV_OUT_V,
 EV_ATOM) = range(9)
N_EVENTS = 9
# columns of the per-block moment array
MO_A, MO_A2, MO_X, MO_X2, MO_V, MO_V2, MO_MAXA, MO_MAXX, MO_MAXV = range(9)
N_MOMENTS = 9
# columns of the per-block energy-balance array (observable "energy")
EN_INPUT, EN_DAMP, EN_FRICTION, EN_IMPACT = range(4)
N_ENERGY = 4

# declared weak orders (measured in tests/test_montecarlo.py against these constants)
WEAK_ORDER_SMOOTH = 2  # Strang splitting, no barrier and no friction
WEAK_ORDER_NONSMOOTH = 1  # across impacts and stick-slip events


_C6, _C24, _C120 = 1.0 / 6.0, 1.0 / 24.0, 1.0 / 120.0  # multiplications, not divisions


@jit
def exp_phi(z: float) -> tuple[float, float]:
    """(e^{-z}, (1 - e^{-z}) / z) for all z. Below |z| = 0.02 (every step at the default dt)
    a series whose first neglected terms are z^5/120 and z^5/720 (< 3e-11 relative), in
    Estrin's form with multiplications only: this series is on the step's critical path
    (x -> k -> e^{-k h} -> v -> x), and Horner's form with a division by 120 cost 23% of the
    kernel's speed (docs/performance.md)."""
    if abs(z) < 0.02:
        z2 = z * z
        phi = (1.0 - 0.5 * z) + z2 * ((_C6 - _C24 * z) + _C120 * z2)
        return 1.0 - z * phi, phi
    em = math.expm1(-z)
    return 1.0 + em, -em / z


@jit
def holds(F: float, mu: float, at_wall: int) -> bool:
    """Static friction (and the wall) hold a mass at rest under the net force F; ``at_wall``
    1 on the lower wall (held while F <= mu), -1 on the upper (while -F <= mu), 0 off."""
    if at_wall != 0:
        return at_wall * F <= mu
    return abs(F) <= mu


@jit
def velocity_flow(v: float, tau: float, F: float, k: float, mu, at_wall: int):
    """Exact v after tau under v' = F - k v - mu sgn(v) (x, xi frozen); (v, time stuck)."""
    if mu is None:
        e, phi = exp_phi(k * tau)
        return v * e + F * tau * phi, 0.0
    if v == 0.0:
        if holds(F, mu, at_wall):
            return 0.0, tau
        s = 1.0 if F > 0.0 else -1.0
        e, phi = exp_phi(k * tau)
        return (F - mu * s) * tau * phi, 0.0
    s = 1.0 if v > 0.0 else -1.0
    Fs = F - mu * s
    e, phi = exp_phi(k * tau)
    vt = v * e + Fs * tau * phi
    if vt * s > 0.0:
        return vt, 0.0
    # the velocity reaches zero inside the sub-step (Fs opposes v)
    z = -k * v / Fs
    if abs(z) < 1e-8:
        L = 1.0 - 0.5 * z
    elif z > -1.0:
        L = math.log1p(z) / z
    else:
        L = math.inf
    t_star = min((-v / Fs) * L, tau)
    rest = tau - t_star
    if holds(F, mu, at_wall):
        return 0.0, rest
    s2 = 1.0 if F > 0.0 else -1.0
    e, phi = exp_phi(k * rest)
    return (F - mu * s2) * rest * phi, 0.0


@jit
def velocity_decay(v: float, tau: float, ev) -> float:
    """Exact v after tau under v' = -e(v) v, e(v) = ev[0] v^2 + ev[1] v^4 + ... (the
    velocity-damping sub-flow). One term: v / sqrt(1 + 2 e2 v^2 tau) (closed form; for
    e2 < 0 it blows up where the flow does). More terms: one classical RK4 step (local
    error O(tau^5), beyond the splitting's weak order 2)."""
    if ev.shape[0] == 1:
        return v / math.sqrt(1.0 + 2.0 * ev[0] * v * v * tau)
    k1 = -poly_x2(ev, v * v) * v * v * v
    w = v + 0.5 * tau * k1
    k2 = -poly_x2(ev, w * w) * w * w * w
    w = v + 0.5 * tau * k2
    k3 = -poly_x2(ev, w * w) * w * w * w
    w = v + tau * k3
    k4 = -poly_x2(ev, w * w) * w * w * w
    return v + tau * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0


# The helpers below take a record field that may be None as an ARGUMENT and are compiled as
# functions of their own (not inline="always", which would inline them at numba-IR level,
# before the pruning): numba prunes ``if a is None`` only for a function's arguments; LLVM
# inlines the compiled helpers afterwards.
@jit
def spring_g(x, w0sq, alpha, khi):
    """g(x) = (w0^2 + alpha x^2) x [+ x^5 (k5 + k7 x^2 + ...) when khi is not None]."""
    g = (w0sq + alpha * x * x) * x
    if khi is not None:
        x2 = x * x
        g += poly_x2(khi, x2) * x2 * x2 * x
    return g


@jit
def damping_k(x, c1, c2, dhi):
    """k(x) = c2 x^2 - c1 [+ x^4 (d4 + d6 x^2 + ...) when dhi is not None]."""
    k = c2 * x * x - c1
    if dhi is not None:
        x2 = x * x
        k += poly_x2(dhi, x2) * x2 * x2
    return k


@jit
def wall_press(at, g_at, sign, mu, pn):
    """The net force pressing the mass onto the wall at ``at`` (the chatter guard's P):
    sign (pn + g(at)) with pn the noise piece's (minus the noise force held), sign 1 for the
    lower wall, -1 for the upper, plus the friction against the rebound; 0 without the wall."""
    if at is None:
        return 0.0
    if mu is not None:
        return sign * (pn + g_at) + mu
    return sign * (pn + g_at)


#: declared weak order of the scheme with parametric noise, no wall and no friction (measured
#: in tests/test_parametric_mc.py on a linear oscillator's stationary second moments): the
#: step is a symmetric (Strang) composition of exactly solved sub-flows, A(h/2) P(h/2) B..
#: P'(h/2) A(h/2), P' the parts of P in the reverse order.
WEAK_ORDER_PARAMETRIC = 2


@jit
def parametric(v, g, k, pk, pc, s0, s1, s2, s3):
    """The parametric sub-flow P(h/2) (x frozen): the Stratonovich SDE dv = -g(x) sqrt(2 D_k)
    o dW_k - k(x) v sqrt(2 D_c) o dW_c over h/2, its two parts solved exactly in turn: the
    damping noise's flow, linear in v, v e^{-k sqrt(2 D_c h/2) N'} (pc = sqrt(D_c h)), then
    the spring noise's, additive while x is frozen, v - g sqrt(2 D_k h/2) N (pk = sqrt(D_k
    h)). Returns (v, the change of v^2/2: the work of the parametric noises, generator)."""
    w = v
    if pc is not None:
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        w = w * math.exp(-k * pc * z)
    if pk is not None:
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        w = w - g * pk * z
    return w, 0.5 * (w * w - v * v), s0, s1, s2, s3


@jit
def parametric_back(v, g, k, pk, pc, s0, s1, s2, s3):
    """P(h/2) with its two parts in the reverse order (the step stays symmetric)."""
    w = v
    if pk is not None:
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        w = w - g * pk * z
    if pc is not None:
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        w = w * math.exp(-k * pc * z)
    return w, 0.5 * (w * w - v * v), s0, s1, s2, s3


@jit
def decay(v, tau, ev):
    """(v after the velocity-damping sub-flow, the kinetic energy it removed); (v, 0) without."""
    if ev is None:
        return v, 0.0
    w = velocity_decay(v, tau, ev)
    return w, 0.5 * (v * v - w * w)


@jit(inline="always")
def strang_step(x, v, xi, s0, s1, s2, s3, h, half, P):
    """One step of one path (the splitting of the module docstring) with the physics record P
    (plan.Record): the new (x, v, xi), the generator state, and what the bookkeeping needs:
    (impacts and chatter entries of the two drifts, time stuck, k, the velocities between the
    sub-flows, the xi used, the kinetic energy removed by the two velocity-damping sub-flows).
    The noise's stage B and state update are its kind's pieces (pieces.py)."""
    pn = noise_press(P, xi)
    p_lo = wall_press(P.lo, P.lo_g, 1.0, P.mu, pn)
    p_up = wall_press(P.up, P.up_g, -1.0, P.mu, pn)
    va = v
    x, v, imp1, ch1, loss1 = wall_drift(P, x, v, half, p_lo, p_up, h)
    at_wall = wall_side(P, x)
    k = damping_k(x, P.c1, P.c2, P.dhi)
    g = spring_g(x, P.w0sq, P.alpha, P.khi)
    v, dv1 = decay(v, half, P.ev)
    v, wp1, s0, s1, s2, s3 = parametric(v, g, k, P.pk, P.pc, s0, s1, s2, s3)
    vb = v
    v, stuck, vc, vk, vd, s0, s1, s2, s3 = noise_velocity(P, v, xi, g, k, P.mu, at_wall,
                                                          h, half, s0, s1, s2, s3)
    v, wp2, s0, s1, s2, s3 = parametric_back(v, g, k, P.pk, P.pc, s0, s1, s2, s3)
    v, dv2 = decay(v, half, P.ev)
    ve = v
    x, v, imp2, ch2, loss2 = wall_drift(P, x, v, half, p_lo, p_up, h)
    xi_used = xi
    xi, s0, s1, s2, s3 = noise_advance(P, xi, s0, s1, s2, s3)
    return (x, v, xi, s0, s1, s2, s3,
            (imp1, ch1, imp2, ch2, stuck, k, va, vb, vc, vk, vd, ve, xi_used, dv1, dv2, loss1,
             loss2, wp1 + wp2))


def run_paths(rng, state, n_steps, step0, n_burn, stride, h, P, bins, out, spw):
    """Advance every path of every block by ``n_steps`` steps (global step indices
    ``step0 .. step0 + n_steps - 1``) with the physics record P (plan.Record; its noise
    coefficients made for this h). ``bins`` = (a_lo, a_inv, x_lo, x_inv, v_lo, v_inv), ``out``
    = (hist_A, hist_x, hist_v, hist_joint, moments, events, stuck_time, energy, windows). Each
    path has its own generator state rng[b, p] and its own (x, v, xi) in state[b, p], both
    updated in place, so a run cut into any number of calls gives bit-identical results, for
    any thread count (one block per thread at a time: ``_block`` by ``_jit.over_blocks``). The
    docstring of ``_block`` says what is accumulated where."""
    over_blocks(_block, state.shape[0], rng, state, n_steps, step0, n_burn, stride, h, P, bins,
                out, spw)


@jit(inline="always")
def _lane(rng, state, stuck_time, b, p):
    """Path p of block b into registers: (x, v, xi, its four generator words, time at rest)."""
    return (state[b, p, 0], state[b, p, 1], state[b, p, 2],
            rng[b, p, 0], rng[b, p, 1], rng[b, p, 2], rng[b, p, 3], stuck_time[b, p])


@jit(inline="always")
def _put(rng, state, stuck_time, b, p, x, v, xi, s0, s1, s2, s3, rest):
    """The inverse of ``_lane``."""
    state[b, p, 0], state[b, p, 1], state[b, p, 2] = x, v, xi
    rng[b, p, 0], rng[b, p, 1], rng[b, p, 2], rng[b, p, 3] = s0, s1, s2, s3
    stuck_time[b, p] = rest


LANES = 4  # paths one thread advances together, step by step in turn (_block)


@jit(nogil=True)
def _block(first, every, rng, state, n_steps, step0, n_burn, stride, h, P, bins, out, spw):
    """run_paths for the paths of blocks first, first + every, ... (``_jit.over_blocks`` runs
    one such call per thread; compiled ``nogil``).

    The paths are advanced LANES = 4 at a time, the four paths' steps in turn (paths p .. p + 3
    at step n, then at step n + 1; when fewer than four are left, the missing lanes run
    throwaway copies of the last path and are neither counted nor stored). One path's step is
    a chain of dependent operations whose latency, not the arithmetic, bounds the speed
    (docs/performance.md); the chains of different paths are independent, so the core
    overlaps them (measured: 2 lanes 1.4x, 4 lanes 1.5x, 8 lanes no better than 4). Each
    path's arithmetic (``strang_step``) is the same whatever the grouping, so the results do not
    depend on it.

    Steps with global index < ``n_burn`` are burn-in. After it, event counts (and, with
    ``energy``, the power balance) are accumulated every step, and every ``stride`` steps a
    sample is taken: histograms, moments, and with ``windows`` the per-path sum of A over
    windows of ``spw`` samples (windows[b, p, w]; the certificate's raw data). A sample with
    v == 0 exactly (the mass at rest: stuck, or resting on the wall) is the atom of p(x2) at 0
    and is counted in EV_ATOM, not in the x2 (or joint) bins. events[b, EV_TIME] counts the
    block's sampled path-steps (the caller multiplies by h).

    ``moments[b, p]``, ``energy[b, p]`` and ``stuck_time[b, p]`` (the time at rest: EV_STUCK
    of the block once summed by the caller) are per path: each path's float sums are taken in
    step order whatever the cut into calls and the pairing, so they too are bit-identical
    (per-block float sums, interleaving the paths of a block call by call, were not: issue
    11.5). The caller sums over paths. The block's event columns hold whole numbers, whose
    sums do not depend on the order.

    energy[b, p] columns (time integrals over the sampled time, Strang sub-flow by sub-flow):
    EN_INPUT the work of the noise (OU: f xi v, trapezoid over B; white: the kick's exact
    change of v^2/2), EN_DAMP (c2 x^2 - c1) v^2 [+ the exact kinetic energy each velocity-
    damping sub-flow removes], EN_FRICTION mu |v| (trapezoid over B),
    EN_IMPACT the kinetic energy lost at impacts, (1 - r^2) v^2 / 2 each, and v^2 / 2 when
    the chatter guard rests the mass."""
    a_lo, a_inv, x_lo, x_inv, v_lo, v_inv = bins
    hist_A, hist_x, hist_v, hist_joint, moments, events, stuck_time, energy, windows = out
    w0sq, alpha, khi = P.w0sq, P.alpha, P.khi
    half = 0.5 * h
    with_energy = energy.shape[2] > 0  # the power balance asked for (an empty array: not)
    n_paths = state.shape[1]
    for b in range(first, state.shape[0], every):  # this thread's blocks
        for p0 in range(0, n_paths, LANES):
            lanes = min(LANES, n_paths - p0)  # the lanes beyond are throwaway copies of the last
            p1, p2, p3 = p0 + min(1, lanes - 1), p0 + min(2, lanes - 1), p0 + min(3, lanes - 1)
            x0, v0, xi0, a0, a1, a2, a3, rest0 = _lane(rng, state, stuck_time, b, p0)
            x1, v1, xi1, b0, b1, b2, b3, rest1 = _lane(rng, state, stuck_time, b, p1)
            x2, v2, xi2, c0, c1_, c2_, c3, rest2 = _lane(rng, state, stuck_time, b, p2)
            x3, v3, xi3, d0, d1, d2, d3, rest3 = _lane(rng, state, stuck_time, b, p3)
            impacts = 0
            chatter = 0
            steps = 0
            left = -1  # steps until the next sample (a counter: no integer division per step)
            for n in range(step0, step0 + n_steps):
                x0, v0, xi0, a0, a1, a2, a3, o0 = strang_step(
                    x0, v0, xi0, a0, a1, a2, a3, h, half, P)
                x1, v1, xi1, b0, b1, b2, b3, o1 = strang_step(
                    x1, v1, xi1, b0, b1, b2, b3, h, half, P)
                x2, v2, xi2, c0, c1_, c2_, c3, o2 = strang_step(
                    x2, v2, xi2, c0, c1_, c2_, c3, h, half, P)
                x3, v3, xi3, d0, d1, d2, d3, o3 = strang_step(
                    x3, v3, xi3, d0, d1, d2, d3, h, half, P)
                if n < n_burn:
                    continue
                # o[0], o[2]: impacts, o[1], o[3]: chatter entries, o[4]: time at rest
                impacts += o0[0] + o0[2]
                chatter += o0[1] + o0[3]
                rest0 += o0[4]
                if lanes > 1:
                    impacts += o1[0] + o1[2]
                    chatter += o1[1] + o1[3]
                    rest1 += o1[4]
                if lanes > 2:
                    impacts += o2[0] + o2[2]
                    chatter += o2[1] + o2[3]
                    rest2 += o2[4]
                if lanes > 3:
                    impacts += o3[0] + o3[2]
                    chatter += o3[1] + o3[3]
                    rest3 += o3[4]
                steps += lanes
                if left < 0:  # the first step after the burn-in in this call
                    left = (stride - (n - n_burn + 1) % stride) % stride
                sample = left == 0  # i.e. (n - n_burn + 1) % stride == 0
                left = stride - 1 if sample else left - 1
                if not with_energy and not sample:
                    continue
                for j in range(lanes):
                    p = p0 + j
                    if j == 0:
                        x, v, o = x0, v0, o0
                    elif j == 1:
                        x, v, o = x1, v1, o1
                    elif j == 2:
                        x, v, o = x2, v2, o2
                    else:
                        x, v, o = x3, v3, o3
                    if with_energy:
                        (imp1, ch1, imp2, ch2, st, k, va, vb, vc, vk, vd, ve, xi_used, dv1, dv2,
                         loss1, loss2, wpar) = o
                        # (a switched-off effect adds +0.0: the sums are unchanged, bit for bit)
                        energy[b, p, EN_DAMP] += dv1
                        energy[b, p, EN_DAMP] += dv2
                        e_in, e_damp, e_fric = noise_energy(P, h, half, k, P.mu, vb, vc, vk,
                                                            vd, ve, xi_used)
                        energy[b, p, EN_INPUT] += e_in
                        energy[b, p, EN_INPUT] += wpar  # the parametric noises' work (0: off)
                        energy[b, p, EN_DAMP] += e_damp
                        energy[b, p, EN_FRICTION] += e_fric
                        energy[b, p, EN_IMPACT] += loss1  # each wall's loss by its own law
                        energy[b, p, EN_IMPACT] += loss2
                    if not sample:
                        continue
                    events[b, EV_SAMPLES] += 1.0
                    A = amplitude_general(x, v, w0sq, alpha, khi)
                    if windows.shape[2] > 0:
                        w = ((n - n_burn + 1) // stride - 1) // spw
                        if w < windows.shape[2]:
                            windows[b, p, w] += A
                    if hist_A.shape[1] > 0:
                        i = math.floor((A - a_lo) * a_inv)
                        if 0 <= i < hist_A.shape[1]:
                            hist_A[b, i] += 1.0
                        else:
                            events[b, EV_OUT_A] += 1.0
                    ix = -1
                    iv = -1
                    if hist_x.shape[1] > 0 or hist_joint.shape[1] > 0:
                        ix = math.floor((x - x_lo) * x_inv)
                    if hist_v.shape[1] > 0 or hist_joint.shape[1] > 0:
                        iv = math.floor((v - v_lo) * v_inv)
                        if v == 0.0:
                            iv = -2
                            events[b, EV_ATOM] += 1.0
                    if hist_x.shape[1] > 0:
                        if 0 <= ix < hist_x.shape[1]:
                            hist_x[b, ix] += 1.0
                        else:
                            events[b, EV_OUT_X] += 1.0
                    if hist_v.shape[1] > 0:
                        if 0 <= iv < hist_v.shape[1]:
                            hist_v[b, iv] += 1.0
                        elif iv != -2:
                            events[b, EV_OUT_V] += 1.0
                    if hist_joint.shape[1] > 0:
                        if 0 <= ix < hist_joint.shape[1] and 0 <= iv < hist_joint.shape[2]:
                            hist_joint[b, ix, iv] += 1.0
                    if moments.shape[2] > 0:
                        moments[b, p, MO_A] += A
                        moments[b, p, MO_A2] += A * A
                        moments[b, p, MO_X] += x
                        moments[b, p, MO_X2] += x * x
                        moments[b, p, MO_V] += v
                        moments[b, p, MO_V2] += v * v
                        moments[b, p, MO_MAXA] = max(moments[b, p, MO_MAXA], A)
                        moments[b, p, MO_MAXX] = max(moments[b, p, MO_MAXX], abs(x))
                        moments[b, p, MO_MAXV] = max(moments[b, p, MO_MAXV], abs(v))
            events[b, EV_IMPACTS] += impacts
            events[b, EV_CHATTER] += chatter
            events[b, EV_TIME] += steps
            _put(rng, state, stuck_time, b, p0, x0, v0, xi0, a0, a1, a2, a3, rest0)
            if lanes > 1:
                _put(rng, state, stuck_time, b, p1, x1, v1, xi1, b0, b1, b2, b3, rest1)
            if lanes > 2:
                _put(rng, state, stuck_time, b, p2, x2, v2, xi2, c0, c1_, c2_, c3, rest2)
            if lanes > 3:
                _put(rng, state, stuck_time, b, p3, x3, v3, xi3, d0, d1, d2, d3, rest3)
