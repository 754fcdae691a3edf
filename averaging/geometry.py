"""Geometry of the conservative Duffing oscillator y'' + g(y) = 0 shared by both models.

    g(y) = omega0^2 y + alpha y^3,    U(y) = omega0^2 y^2 / 2 + alpha y^4 / 4,    E = U(A).

Orbit of amplitude A in the generalised-harmonic form (paper eq. 7-8)::

    y = A cos(theta),  y' = -A nu(A, theta) sin(theta),
    nu^2 = 2 (U(A) - U(A cos theta)) / (A^2 sin^2 theta)
         = omega0^2 + alpha A^2 (1 + cos^2 theta) / 2 = w1^2 (1 + eta cos 2 theta),
    w1^2 = omega0^2 + 3 alpha A^2 / 4,   eta = (alpha A^2 / 4) / w1^2  (0 <= eta < 1/3).

Along the exact orbit d(theta)/dt = nu(A, theta) (differentiate y = A cos theta), hence
period T(A) = int_0^{2 pi} d theta / nu and time averages <h>_t = int h d theta/nu / T.
The integrands are smooth and periodic in theta, so the trapezoid rule converges
geometrically; on a quarter orbit (not periodic) Gauss-Legendre is used.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vifpk.physics import spring

Array = NDArray[np.float64]


def amplitudes(method: Any) -> Any:
    """A model's ``drift(A)`` / ``diffusion(A)`` with its input checked: amplitudes A >= 0.
    A negative or NaN amplitude is a caller's mistake, refused in one line (ValueError), not
    evaluated: the formulas are even or odd in A and returned finite numbers at A = -1 (issue
    28). A = 0 is kept (the A -> 0 limit, inf or nan, as the formula gives it)."""

    @functools.wraps(method)
    def checked(self: Any, A: ArrayLike) -> Array:
        A = np.asarray(A, dtype=float)
        bad = ~(A >= 0)
        if np.any(bad):
            raise ValueError(f"{type(self).__name__}.{method.__name__}(A): an amplitude must "
                             f"be >= 0, got {float(A[bad].flat[0])!r}")
        return method(self, A)

    return checked


def potential(x: ArrayLike, omega0: float, alpha: float) -> Array:
    """U(x) = omega0^2 x^2 / 2 + alpha x^4 / 4 (vifpk.physics.spring.potential)."""
    return spring.potential(np.asarray(x, dtype=float), (omega0**2, alpha))


def restoring(x: ArrayLike, omega0: float, alpha: float) -> Array:
    """g(x) = U'(x) = omega0^2 x + alpha x^3 (vifpk.physics.spring.restoring)."""
    return spring.restoring(np.asarray(x, dtype=float), (omega0**2, alpha))


def restoring_slope(x: ArrayLike, omega0: float, alpha: float) -> Array:
    """g'(x) = omega0^2 + 3 alpha x^2 (vifpk.physics.spring.restoring_slope)."""
    return spring.restoring_slope(np.asarray(x, dtype=float), (omega0**2, alpha))


def amplitude_of_energy(E: ArrayLike, omega0: float, alpha: float) -> Array:
    """A = U^{-1}(E) >= 0 (vifpk.physics.spring.amplitude_of_energy)."""
    return spring.amplitude_of_energy(E, (omega0**2, alpha))


def w1_eta(A: ArrayLike, omega0: float, alpha: float) -> tuple[Array, Array]:
    """w1(A) = sqrt(omega0^2 + 3 alpha A^2 / 4) and eta(A) = alpha A^2 / (4 w1^2)."""
    A = np.asarray(A, dtype=float)
    w1sq = omega0**2 + 0.75 * alpha * A**2
    return np.sqrt(w1sq), 0.25 * alpha * A**2 / w1sq


def nu_exact(A: ArrayLike, theta: ArrayLike, omega0: float, alpha: float) -> Array:
    """Exact instantaneous frequency nu(A, theta) = w1 sqrt(1 + eta cos 2 theta)."""
    w1, eta = w1_eta(A, omega0, alpha)
    return w1 * np.sqrt(1.0 + eta * np.cos(2.0 * np.asarray(theta, dtype=float)))


def period(A: ArrayLike, omega0: float, alpha: float, *, nodes: int = 64) -> Array:
    """Exact period T(A) = int_0^{2 pi} d theta / nu(A, theta) (trapezoid, periodic)."""
    A = np.asarray(A, dtype=float)
    th = np.arange(nodes) * (np.pi / nodes)  # 1/nu is pi-periodic in theta
    inv = 1.0 / nu_exact(A[..., None], th, omega0, alpha)
    return 2.0 * np.pi * inv.mean(axis=-1)


@functools.lru_cache(maxsize=16)
def gauss_quarter(nodes: int) -> tuple[Array, Array]:
    """Gauss-Legendre nodes and weights on theta in [0, pi/2] (computed once per node count:
    an eigenvalue problem; the arrays are read-only)."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    th, wq = (x + 1.0) * np.pi / 4.0, w * np.pi / 4.0
    th.flags.writeable = False
    wq.flags.writeable = False
    return th, wq


def time_of_theta(A: ArrayLike, theta: ArrayLike, omega0: float, alpha: float,
                  *, modes: int = 32) -> Array:
    """t(theta) = int_0^theta d theta' / nu(A, theta') along the exact orbit.

    1/nu is even and pi-periodic: 1/nu = c0 + sum_k c_k cos(2 k theta), with c_k from a
    discrete cosine sum (geometric convergence since eta < 1/3); integrate term by term:
    t = c0 theta + sum_k c_k sin(2 k theta) / (2 k).
    """
    A = np.asarray(A, dtype=float)[..., None]
    n = 2 * modes
    th = np.arange(n) * (np.pi / n)
    inv = 1.0 / nu_exact(A, th, omega0, alpha)  # (..., n)
    k = np.arange(modes + 1)
    cosk = np.cos(2.0 * np.outer(th, k))  # (n, modes+1)
    c = 2.0 * (inv @ cosk) / n
    c[..., 0] *= 0.5
    theta = np.asarray(theta, dtype=float)
    sink = np.sin(2.0 * theta[..., None] * k[1:]) / (2.0 * k[1:])  # (..., m, modes)
    t = c[..., :1] * theta + np.einsum("...k,...mk->...m", c[..., 1:], sink)
    return t


# --------------------------------------------------------------------------------------------
# The general odd polynomial spring g(x) = k1 x + k3 x^3 + k5 x^5 + ...,  k = (k1, k3, k5, ...)
# (issue 21). U(x) = sum_j k_{2j-1} x^{2j} / (2j). The admissible laws (g > 0 on x > 0 and U
# growing without bound, checked by the scene) give one orbit per energy around x = 0. On the
# orbit y = A cos(theta) the generalised-harmonic frequency has an exact, cancellation-free
# form, a polynomial in c = cos^2(theta) (divide U(A) - U(A cos theta) by A^2 sin^2 theta):
#
#     nu^2(A, theta) = sum_j k_{2j-1} A^{2j-2} (1 + c + ... + c^{j-1}) / j,
#
# (j = 1: k1; j = 2: k3 A^2 (1 + cos^2 theta)/2, the Duffing line above). For k of length
# <= 2 the functions below evaluate the Duffing closed forms above with omega0^2 = k1, so the
# paper family's numbers are bit for bit those of the (omega0, alpha) functions.
def _duffing(k: tuple[float, ...]) -> bool:
    return len(k) <= 2


def _k13(k: tuple[float, ...]) -> tuple[float, float]:
    return float(k[0]), float(k[1]) if len(k) > 1 else 0.0


def potential_k(x: ArrayLike, k: tuple[float, ...]) -> Array:
    """U(x) = sum_j k_{2j-1} x^{2j} / (2j) (vifpk.physics.spring.potential)."""
    return spring.potential(np.asarray(x, dtype=float), k)


def restoring_k(x: ArrayLike, k: tuple[float, ...]) -> Array:
    """g(x) = U'(x) = sum_j k_{2j-1} x^{2j-1} (vifpk.physics.spring.restoring)."""
    return spring.restoring(np.asarray(x, dtype=float), k)


def restoring_slope_k(x: ArrayLike, k: tuple[float, ...]) -> Array:
    """g'(x) = sum_j (2j - 1) k_{2j-1} x^{2j-2} (vifpk.physics.spring.restoring_slope)."""
    return spring.restoring_slope(np.asarray(x, dtype=float), k)


def nu_k(A: ArrayLike, theta: ArrayLike, k: tuple[float, ...]) -> Array:
    """Exact instantaneous frequency nu(A, theta) of the orbit of amplitude A (see above)."""
    A = np.asarray(A, dtype=float)
    theta = np.asarray(theta, dtype=float)
    if _duffing(k):
        k1, k3 = _k13(k)
        if k1 > 0.0:
            w1sq = k1 + 0.75 * k3 * A**2
            return np.sqrt(w1sq) * np.sqrt(1.0 + 0.25 * k3 * A**2 / w1sq * np.cos(2.0 * theta))
    c = np.cos(theta) ** 2
    A2 = A * A
    partial = np.ones_like(c)  # 1 + c + ... + c^{j-1}
    cj = np.ones_like(c)
    total = k[0] * np.ones(np.broadcast(A2, c).shape)
    Aj = np.ones_like(A2)
    for j in range(2, len(k) + 1):
        cj = cj * c
        partial = partial + cj
        Aj = Aj * A2
        total = total + k[j - 1] * Aj * partial / j
    return np.sqrt(np.maximum(total, 0.0))


def amplitude_of_energy_k(E: ArrayLike, k: tuple[float, ...]) -> Array:
    """A = U^{-1}(E) >= 0 (vifpk.physics.spring.amplitude_of_energy)."""
    return spring.amplitude_of_energy(E, k)


def time_of_theta_k(A: ArrayLike, theta: ArrayLike, k: tuple[float, ...],
                    *, modes: int = 32) -> Array:
    """t(theta) along the exact orbit of the general spring (as :func:`time_of_theta`)."""
    A = np.asarray(A, dtype=float)[..., None]
    n = 2 * modes
    th = np.arange(n) * (np.pi / n)
    inv = 1.0 / nu_k(A, th, k)
    kk = np.arange(modes + 1)
    cosk = np.cos(2.0 * np.outer(th, kk))
    c = 2.0 * (inv @ cosk) / n
    c[..., 0] *= 0.5
    theta = np.asarray(theta, dtype=float)
    sink = np.sin(2.0 * theta[..., None] * kk[1:]) / (2.0 * kk[1:])
    return c[..., :1] * theta + np.einsum("...k,...mk->...m", c[..., 1:], sink)


def period_k(A: ArrayLike, k: tuple[float, ...], *, nodes: int = 64) -> Array:
    """Exact period T(A) = int_0^{2 pi} d theta / nu(A, theta) of the general spring."""
    A = np.asarray(A, dtype=float)
    th = np.arange(nodes) * (np.pi / nodes)
    with np.errstate(divide="ignore"):  # k1 = 0: T = inf at A = 0
        return 2.0 * np.pi * (1.0 / nu_k(A[..., None], th, k)).mean(axis=-1)
