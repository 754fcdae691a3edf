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
