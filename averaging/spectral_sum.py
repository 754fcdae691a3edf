"""sigma_E^2 of a rational (OU) spectrum on the free orbit (or the paper's wall), the exact
model's harmonic sum (exact.py's module docstring: the two Parseval forms, each A taking the one
with the smaller rounding and tail error) and the tails of Y = |y| beyond the computed
harmonics, from its asymptotics (the kinks at the impacts). Every function takes the model
(exact.ExactModel or a subclass: its spring, spectrum, noise form, f, harmonics, orbit)."""

from __future__ import annotations

from typing import Any

import numpy as np

from .geometry import Array

#: relative size of a negative sigma_E^2 that is rounding (the two terms' cancellation): on
#: the shipped scenes the ratio sigma_E^2 / (size of the terms) stays >= 2.6e-4 (alpha1-wide,
#: A = 2e-6), so 1e-9 leaves only rounding to clamp
SIGMA2_ROUNDOFF = 1e-9


def sigma2_rational(model: Any, A: Array, o: dict[str, Array]) -> Array:
    """sigma_E^2 for a rational (OU) spectrum on the free orbit (or the paper's wall)."""
    f2 = model.f**2
    S = model.spectrum
    c, a2 = S.rational_parts()  # raises for a kind without it: no silent fallback
    rest_point = o["v2"] == 0.0  # A = 0 (k1 = 0: T = inf there): no motion, no noise power
    if np.any(rest_point):  # the sums at a stand-in amplitude, then 0 there
        A = np.where(rest_point, 1.0, A)
        o = model.free_orbit(A)
    Y0, n, Yn = model.harmonics_of_Y(A, o["T"])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        Omega = 2 * np.pi / o["T"]
        u = n * Omega[..., None]
        Su = S(u)
        rest_p = np.sum(Yn**2 * Su, axis=-1)
        rest_v = np.sum(u**4 * Yn**2 * Su, axis=-1)
        err_p = err_v = 0.0
        if model.noise == "sgn":
            tail_p, beyond_err = kink_tail(model, o, Omega, n[-1])
            tail_v = kink_tail_velocity(model, o, Omega, n[-1])
            # how far the last computed harmonic is from the tails' asymptotic form: the
            # tails' relative error is below it (the next term falls as u^-4)
            K2 = (4.0 * np.sqrt(2.0 * o["E"]) / o["T"]) ** 2
            uN = u[..., -1]
            miss = np.abs(uN**4 * Yn[..., -1] ** 2 / (K2 * (1.0 + 2.0 * model.restoring[0]
                                                           / uN**2)) - 1.0)
            rest_p, rest_v = rest_p + tail_p, rest_v + tail_v
            err_p = a2 * (miss * tail_p + beyond_err)
            err_v = miss * tail_v / a2
        head_p, sub_p = c * 0.5 * (o["y2"] - Y0**2), a2 * rest_p
        head_v, sub_v = c / a2 * 0.5 * o["v2"], rest_v / a2
        eps = np.finfo(float).eps
        # each A takes the form with the smaller error estimate: rounding of the two terms
        # plus the tail's
        use_v = (eps * (head_v + sub_v) + err_v) < (eps * (head_p + sub_p) + err_p)
        head = np.where(use_v, head_v, head_p)
        sub = np.where(use_v, sub_v, sub_p)
    total = np.where(rest_point, 0.0, head - sub)
    bad = total < -SIGMA2_ROUNDOFF * (np.abs(head) + np.abs(sub))
    if np.any(bad):
        at = float(np.asarray(A)[bad].flat[0]) if np.ndim(A) else float(A)
        raise ArithmeticError(
            f"exact model: sigma_E^2 < 0 at A = {at:.4g} beyond rounding (the harmonic sum "
            f"is truncated too early); raise averaging.harmonics (now {model.harmonics}) "
            f"with averaging.theta_nodes (now {model.theta_nodes}) at least 4/3 of it")
    return 4.0 * np.pi * f2 * np.maximum(total, 0.0)

def kink_tail(model: Any, o: dict[str, Array], Omega: Array,
              n_last: float) -> tuple[Array, Array]:
    """Harmonics beyond the computed ones for Y = |y|, from its asymptotics.

    |y| has slope jumps of 2 v0 (v0 = sqrt(2E), the impact speed) at t = T/4 and 3T/4 and
    third-derivative jumps of 2 k1 v0 there, so integrating by parts,
    Y_n = 4 v0 / (T u^2) (1 + k1 / u^2 + O(u^-4)) for even n, u = n Omega. The next 400
    harmonics are summed, the rest by the integral of n^-6 with S(w) ~ c / w^2.
    Returns (sum Y_n^2 S(n Omega) over those harmonics, a bound on the error of the
    integral's S ~ c / w^2: a2 / (w^2 + a2) of it, small unless Omega << alpha1)."""
    c, a2 = model.spectrum.rational_parts()
    k1 = float(model.restoring[0])
    c2 = (4.0 * np.sqrt(2.0 * o["E"]) / (o["T"] * Omega**2)) ** 2
    n = n_last + 2.0 * np.arange(1, 401)
    W = Omega[..., None]
    part = np.sum(model.spectrum(n * W) / n**4 * (1.0 + 2.0 * k1 / (n * W) ** 2), axis=-1)
    end = (n[-1] + 1.0) * Omega
    beyond = c * 0.5 / (5.0 * Omega**2 * (n[-1] + 1.0) ** 5)
    return c2 * (part + beyond), c2 * beyond * a2 / (end**2 + a2)

def kink_tail_velocity(model: Any, o: dict[str, Array], Omega: Array, n_last: float
                       ) -> Array:
    """sum u_n^4 Y_n^2 S(u_n) over the even n > n_last, u_n = n Omega, for Y = |y|.

    Integrating by parts over the jumps of |y|'s odd derivatives at the impacts (2 v0 in
    the first, 2 k1 v0 in the third, as y'' = -g(y) and g'(0) = k1) gives
    Y_n = (K / u_n^2)(1 + k1 / u_n^2 + O(u_n^-4)), K = 4 v0 / T (v0 = sqrt(2E)), so
    u^4 Y_n^2 = K^2 (1 + 2 k1 / u^2) and, with S(u) / u^2 = (c / u^2 - S(u)) / a2, the tail
    is K^2 [(1 - 2 k1 / a2) sum S(u_n) + (2 k1 c / a2) sum 1 / u_n^2], both sums in closed
    form over n = 2m, m > M = n_last / 2, for every ratio Omega / alpha1:
    sum_{m>M} c / (4 m^2 Omega^2 + a2) = c / (4 Omega^2) Im psi(M + 1 + i b) / b
    (b = alpha1 / (2 Omega); Im psi(x + i b) = sum_{k>=0} b / ((k + x)^2 + b^2)) and
    sum_{m>M} 1 / (4 m^2 Omega^2) = psi'(M + 1) / (4 Omega^2)."""
    from scipy.special import digamma, polygamma

    c, a2 = model.spectrum.rational_parts()
    k1 = float(model.restoring[0])
    K2 = (4.0 * np.sqrt(2.0 * o["E"]) / o["T"]) ** 2
    M1 = n_last / 2.0 + 1.0
    b = np.sqrt(a2) / (2.0 * Omega)
    sum_S = c / (4.0 * Omega**2) * np.imag(digamma(M1 + 1j * b)) / b
    sum_inv = float(polygamma(1, M1)) / (4.0 * Omega**2)
    return K2 * ((1.0 - 2.0 * k1 / a2) * sum_S + 2.0 * k1 * c / a2 * sum_inv)


# --------------------------------------------------------------------------------------
# The general harmonic sum (issue 43): any spectrum S, positive terms only, with the tails
# of the orbit's kinks summed from their asymptotics.
#: harmonics of the kink tail summed one by one beyond the computed ones (each needs S only)
TAIL_HARMONICS = 400
#: Gauss-Legendre nodes of the tail's rest, an integral in s = u0 / u over (0, 1)
TAIL_NODES = 24


def _spring_derivatives(x: Array, k: tuple[float, ...]) -> tuple[Array, Array, Array, Array]:
    """g, g', g'', g''' of g(x) = k1 x + k3 x^3 + ... at x."""
    P = np.polynomial.polynomial
    c = np.zeros(2 * len(k))
    c[1::2] = k
    out = []
    for _ in range(4):
        out.append(P.polyval(x, c))
        c = P.polyder(c)
    return out[0], out[1], out[2], out[3]


def kink(x: Array, v: Array, k: tuple[float, ...], jump: Array
         ) -> tuple[Array, Array, Array]:
    """(J, g1, Q): the jumps of the odd derivatives of a coordinate reflected at x with speed v
    (x' jumps by ``jump`` = +-2v), [x'] = J, [x'''] = -g'(x) J,
    [x^(5)] = J (g'^2 + 3 g g'' - g''' v^2) (from x'' = -g(x), differentiated; the even
    derivatives are continuous), as (J, g1 = g'(x), Q = g'^2 + 3 g g'' - g''' v^2)."""
    g, g1, g2, g3 = _spring_derivatives(x, k)
    return jump, g1, g1**2 + 3.0 * g * g2 - g3 * v**2


def _kink_amplitude(J: Array, g1: Array, Q: Array, u: Array) -> Array:
    """J (1 + g1/u^2 + Q/u^4): a kink's part of -T u^2 X_n. Integrating by parts over the
    period, X_n = (1/T) sum_kinks e^{-i u t_k} sum_j [x^(j)]_k / (i u)^(j+1) (u = n Omega),
    which for jumps in the odd derivatives 1, 3, 5 is -(1/(T u^2)) sum_k e^{-i u t_k} of this
    (relative error O(u^-6))."""
    iu2 = 1.0 / u**2
    return J[..., None] * (1.0 + iu2 * (g1[..., None] + iu2 * Q[..., None]))


def tail_sum(S: Any, Omega: Array, T: Array, n_first: float, step: int, P2: Any) -> Array:
    """sum over n = n_first, n_first + step, ... of u^2 X_n^2 S(u), u = n Omega, for the
    harmonics of a kinked coordinate, X_n = -P(u) / (T u^2), P2 = P^2 a smooth function of u
    on arrays (..., m) (one parity of n at a time where the kinks' phases alternate).

    The first TAIL_HARMONICS terms one by one (S is evaluated at each: a spectral peak among
    them is summed exactly); the rest by the midpoint rule in n as an integral,
    sum_{j>=1} F(n_end + j step) = (1/step) int_{n_end+step/2}^inf F dn
    + (step/24) F'(n_end + step/2) + O(step^3 F''') (Euler-Maclaurin), the integral in
    s = u0/u on (0, 1) by Gauss-Legendre, S(u0/s) smooth there for a spectrum smooth in 1/u
    beyond the explicit terms (flat, OU, bounded: rational in u)."""
    W = Omega[..., None]
    T2 = (T**2)[..., None]

    def F(uu: Array) -> Array:  # the summand at frequencies uu (..., m)
        return P2(uu) * S(uu) / (T2 * uu**2)

    n = n_first + step * np.arange(TAIL_HARMONICS)
    total = np.sum(F(n * W), axis=-1)
    x, gw = np.polynomial.legendre.leggauss(TAIL_NODES)
    s, gw = 0.5 * (x + 1.0), 0.5 * gw
    u0 = ((n[-1] + 0.5 * step) * Omega)[..., None]
    uu = u0 / s
    integral = np.sum(F(uu) * (uu**2 / u0) * gw, axis=-1) / Omega  # int F dn
    d = 0.25 * step * W  # F'(n) by a central difference over n +- step/4
    slope = (F(u0 + d) - F(u0 - d))[..., 0] / (0.5 * step)
    return total + integral / step + step * slope / 24.0


def sigma2_harmonic(model: Any, A: Array, o: dict[str, Array]) -> Array:
    """sigma_E^2 = 4 pi f^2 sum_{n>=1} u_n^2 Y_n^2 S(u_n), u_n = n Omega, for ANY spectrum S,
    on the free orbit (or the paper's wall): the general path (exact.py's module docstring).

    The computed harmonics (model.harmonics_of_Y) summed as they are (positive terms, no
    cancellation); for Y = |y| (the paper's wall, noise "sgn") the kinks at the impacts add
    the tail beyond them, Y_n = -(4 v0 (-1)^(n/2) / (T u^2)) (1 + k1/u^2 + Q/u^4) for even n,
    v0 = sqrt(2E), Q = k1^2 - 6 k3 v0^2 (:func:`kink` at x = 0; u^-6 relative error), summed
    by :func:`tail_sum`. Y = y (noise "additive") has no kink: its harmonics fall
    geometrically and the computed ones are the sum."""
    S = model.spectrum
    rest_point = o["v2"] == 0.0  # A = 0 (k1 = 0: T = inf there): no motion, no noise power
    if np.any(rest_point):
        A = np.where(rest_point, 1.0, A)
        o = model.free_orbit(A)
    _, n, Yn = model.harmonics_of_Y(A, o["T"])
    Omega = 2 * np.pi / o["T"]
    u = n * Omega[..., None]
    total = np.sum(u**2 * Yn**2 * S(u), axis=-1)
    if model.noise == "sgn":
        k = tuple(model.restoring)
        v0 = np.sqrt(2.0 * o["E"])
        J, g1, Q = kink(np.zeros_like(v0), v0, k, 4.0 * v0)  # two kinks, 2 (-1)^m each

        def P2(uu: Array) -> Array:
            return _kink_amplitude(J, g1, Q, uu) ** 2

        total = total + tail_sum(S, Omega, o["T"], n[-1] + 2.0, 2, P2)
    return 4.0 * np.pi * model.f**2 * np.where(rest_point, 0.0, total)


def sigma2_harmonic_truncated(A: Array, k: tuple[float, ...], lower: float, upper: float, *,
                              f: float, spectrum: Any, count: int, nodes: int) -> Array:
    """sigma_E^2 = 4 pi f^2 sum_n u_n^2 X_n^2 S(u_n) for ANY spectrum on the orbit truncated by
    walls (A reaching one; averaging/truncated.py): the computed harmonics of x(t) summed as
    they are, and the tail of the kinks at the walls reached. With t = 0 at the upper turning
    point, a reached upper wall b reflects x' = v_b -> -v_b at t = 0 and a lower wall a
    x' = -v_a -> v_a at t = T/2 (v = sqrt(2 (E - U(wall)))), so (:func:`kink`)
    X_n = -(1/(T u^2)) [P_b(u) + (-1)^n P_a(u)], P = J (1 + g'/u^2 + Q/u^4)."""
    from . import truncated

    A = np.asarray(A, dtype=float)
    o = truncated.orbit(A, k, lower, upper, n_damping=0, n_velocity=0, nodes=nodes)
    Xn = _truncated_harmonics(A, o["T"], k, lower, upper, count=count, nodes=nodes)
    Omega = 2.0 * np.pi / o["T"]
    u = Omega[..., None] * np.arange(1, Xn.shape[-1] + 1)
    total = np.sum(u**2 * Xn**2 * spectrum(u), axis=-1)
    E = o["E"]
    hit_b = o["x_hi"] < A
    hit_a = o["x_lo"] > -A
    vb = np.sqrt(np.maximum(2.0 * (E - spring_potential(o["x_hi"], k)), 0.0))
    va = np.sqrt(np.maximum(2.0 * (E - spring_potential(o["x_lo"], k)), 0.0))
    Jb, gb, Qb = kink(o["x_hi"], vb, k, np.where(hit_b, -2.0 * vb, 0.0))
    Ja, ga, Qa = kink(o["x_lo"], va, k, np.where(hit_a, 2.0 * va, 0.0))

    for first in (count + 1, count + 2):  # each parity of n: P = P_b + (-1)^n P_a
        sign = 1.0 if first % 2 == 0 else -1.0

        def P2(uu: Array, sign: float = sign) -> Array:
            return (_kink_amplitude(Jb, gb, Qb, uu) + sign * _kink_amplitude(Ja, ga, Qa, uu)
                    ) ** 2

        total = total + tail_sum(spectrum, Omega, o["T"], float(first), 2, P2)
    return 4.0 * np.pi * f**2 * total


def _truncated_harmonics(A: Array, T: Array, k: tuple[float, ...], lower: float, upper: float,
                         *, count: int, nodes: int) -> Array:
    """X_n, n = 1..count, of x(t) on the truncated orbit: truncated.harmonics's quadrature
    with cos(n Omega t) by the Chebyshev recurrence c_{n+1} = 2 cos(Omega t) c_n - c_{n-1}
    (one cosine a node, not one a harmonic: the same numbers to ~1e-14 of the largest, 4x
    faster on the walls' orbits, as exact.harmonics_of_Y does)."""
    from vifpk.physics import spring as spring_

    from . import truncated
    from .geometry import nu_k, time_of_theta_k

    th, w, _, x_hi = truncated.theta_nodes(A, lower, upper, nodes)
    nu = nu_k(A[..., None], th, k)
    th_p = np.arccos(np.clip(spring_.turning_points(A, lower, upper)[1]
                             / np.where(A > 0, A, 1.0), -1.0, 1.0))
    t = time_of_theta_k(A, th, k) - time_of_theta_k(A, th_p[..., None], k)
    base = (2.0 / T)[..., None] * w * A[..., None] * np.cos(th) / nu
    c1 = np.cos((2.0 * np.pi / T)[..., None] * t)
    two = 2.0 * c1
    prev, cur = np.ones_like(c1), c1
    out = np.empty(A.shape + (count,))
    for j in range(count):
        if j:
            prev, cur = cur, two * cur - prev
        out[..., j] = np.einsum("...k,...k->...", base, cur)
    return out


def spring_potential(x: Array, k: tuple[float, ...]) -> Array:
    """U(x) (vifpk.physics.spring.potential)."""
    from vifpk.physics import spring

    return spring.potential(x, k)
