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

from ._jit import jit
from .geometry import poly_x2
from .pieces import (
    noise_advance,
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
