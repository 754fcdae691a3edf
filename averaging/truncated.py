"""Orbit averages on the orbit of energy E truncated by walls (issue 37; docs/averaging.md,
"Walls anywhere").

The conservative orbit of energy E = U(A) in the walls a <= 0 <= b runs between the turning
points x_- = max(a, -A) and x_+ = min(b, A) (vifpk.physics.spring.turning_points) and back: a
free turning point where the wall is out of reach (A <= |wall|), an elastic reflection at the
wall otherwise (the conservative limit of an impact). On the free orbit's parametrisation
x = A cos(theta), |v| = A nu(A, theta) sin(theta), dt = d theta / nu (averaging/geometry.py),
the truncated orbit is theta in [theta_+, theta_-], theta_+ = arccos(x_+ / A),
theta_- = arccos(x_- / A), traversed once each way per period::

    T(E) = 2 int_{theta_+}^{theta_-} d theta / nu,
    <h>  = (2 / T) int_{theta_+}^{theta_-} h(x, |v|) d theta / nu       (h even in v),
    <|v|> = 2 (x_+ - x_-) / T.

1/nu is smooth (nu >= sqrt(k1) > 0, or k3 A^2 / 2 for k1 = 0), so Gauss-Legendre on the
theta interval converges geometrically whether or not an end is a wall.

Harmonics of x(t) (t = 0 at x_+, x even in t): X_n = (1/T) int_0^T x cos(n Omega t) dt
= (2 / T) int x cos(n Omega t(theta)) d theta / nu, Omega = 2 pi / T, with t(theta) the time
from theta_+ (averaging.geometry.time_of_theta_k). x(t) is continuous with slope jumps at the
walls, so X_n ~ n^-2.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from vifpk.physics import spring

from .geometry import Array, nu_k, time_of_theta_k


@functools.lru_cache(maxsize=8)
def _gauss(nodes: int) -> tuple[Array, Array]:
    x, w = np.polynomial.legendre.leggauss(nodes)
    x.flags.writeable = False
    w.flags.writeable = False
    return x, w


def theta_nodes(A: Array, lower: float, upper: float, nodes: int
                ) -> tuple[Array, Array, Array, Array]:
    """(theta, weights, x_-, x_+): Gauss-Legendre nodes (..., nodes) on [theta_+, theta_-]."""
    A = np.asarray(A, dtype=float)
    x_lo, x_hi = spring.turning_points(A, lower, upper)
    safe = np.where(A > 0, A, 1.0)
    th_p = np.arccos(np.clip(x_hi / safe, -1.0, 1.0))
    th_m = np.arccos(np.clip(x_lo / safe, -1.0, 1.0))
    gx, gw = _gauss(nodes)
    mid, half = 0.5 * (th_m + th_p), 0.5 * (th_m - th_p)
    th = mid[..., None] + half[..., None] * gx
    return th, half[..., None] * gw, x_lo, x_hi


def orbit(A: Array, k: tuple[float, ...], lower: float, upper: float, *, n_damping: int,
          n_velocity: int, nodes: int) -> dict[str, Array]:
    """T and the time averages of ExactModel.orbit on the truncated orbit of amplitude A
    (A > 0): ``v2`` <v^2>, ``x2v2`` <x^2 v^2>, ``y2`` <x^2>, ``x1`` <x>, ``absv`` <|v|>,
    ``E`` U(A), ``x2jv2`` [<x^2j v^2>, j < n_damping], ``v2jv2`` [<v^(2j+2)>, 1 <= j <=
    n_velocity], ``x_lo``/``x_hi`` the turning points."""
    A = np.asarray(A, dtype=float)
    th, w, x_lo, x_hi = theta_nodes(A, lower, upper, nodes)
    nu = nu_k(A[..., None], th, k)
    x = A[..., None] * np.cos(th)
    v2 = (A[..., None] * np.sin(th)) ** 2 * nu**2
    wt = w / nu
    half = wt.sum(axis=-1)
    T = 2.0 * half

    def avg(h: Array) -> Array:
        return np.einsum("...k,...k->...", wt, h) / half

    x2 = x * x
    out = {"T": T, "v2": avg(v2), "x2v2": avg(x2 * v2), "y2": avg(x2), "x1": avg(x),
           "absv": 2.0 * (x_hi - x_lo) / T, "E": spring.potential(A, k),
           "x_lo": x_lo, "x_hi": x_hi}
    out["x2jv2"] = [out["v2"], out["x2v2"]] + [avg(x2**j * v2) for j in range(2, n_damping)]
    out["v2jv2"] = [avg(v2 ** (j + 1)) for j in range(1, n_velocity + 1)]
    return out


def harmonics(A: Array, T: Array, k: tuple[float, ...], lower: float, upper: float, *,
              count: int, nodes: int) -> tuple[Array, Array]:
    """(X_0, X_n for n = 1..count) of x(t) on the truncated orbit (module docstring)."""
    A = np.asarray(A, dtype=float)
    th, w, _, _ = theta_nodes(A, lower, upper, nodes)
    nu = nu_k(A[..., None], th, k)
    th_p = np.arccos(np.clip(spring.turning_points(A, lower, upper)[1]
                             / np.where(A > 0, A, 1.0), -1.0, 1.0))
    t = time_of_theta_k(A, th, k) - time_of_theta_k(A, th_p[..., None], k)
    base = (2.0 / T)[..., None] * w * A[..., None] * np.cos(th) / nu
    Omega = (2.0 * np.pi / T)[..., None, None]
    n = np.arange(1, count + 1)
    cos = np.cos(Omega * n[:, None] * t[..., None, :])  # (..., count, nodes)
    return base.sum(axis=-1), np.einsum("...k,...nk->...n", base, cos)



def sigma2(A: Array, k: tuple[float, ...], lower: float, upper: float, *, f: float,
           spectrum: Any, count: int, nodes: int) -> Array:
    """sigma_E^2 of a rational (OU) spectrum on the truncated orbit (A reaching a wall):
    4 pi f^2 sum_n (n Omega)^2 X_n^2 S(n Omega) for x(t) itself (G = f dx/dt), summed as
    (P) c (<x^2> - X_0^2)/2 - a2 sum_n X_n^2 S(n Omega) (X_n ~ n^-2 at a wall: the remainder
    falls as n^-6), or directly where (P)'s two terms cancel to 1e-6 (a slow orbit). ``count``
    harmonics, Gauss-Legendre on ``nodes`` nodes; a lower Newton wall at 0 agrees with the
    paper's wall done in y (tails included) to 7.7e-10 at 48 and 128 (tests)."""
    c, a2 = spectrum.rational_parts()
    o = orbit(A, k, lower, upper, n_damping=0, n_velocity=0, nodes=nodes)
    X0, Xn = harmonics(A, o["T"], k, lower, upper, count=count, nodes=nodes)
    u = (2.0 * np.pi / o["T"])[..., None] * np.arange(1, Xn.shape[-1] + 1)
    Su = spectrum(u)
    head = 0.5 * c * (o["y2"] - X0**2)
    sub = a2 * np.sum(Xn**2 * Su, axis=-1)
    direct = np.sum(u**2 * Xn**2 * Su, axis=-1)
    total = np.where(head - sub > 1e-6 * head, head - sub, direct)
    return 4.0 * np.pi * f**2 * np.maximum(total, 0.0)
