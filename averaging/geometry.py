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

import numpy as np
from numpy.typing import ArrayLike, NDArray

Array = NDArray[np.float64]


def potential(x: ArrayLike, omega0: float, alpha: float) -> Array:
    """U(x) = omega0^2 x^2 / 2 + alpha x^4 / 4."""
    x = np.asarray(x, dtype=float)
    return 0.5 * omega0**2 * x**2 + 0.25 * alpha * x**4


def restoring(x: ArrayLike, omega0: float, alpha: float) -> Array:
    """g(x) = U'(x) = omega0^2 x + alpha x^3."""
    x = np.asarray(x, dtype=float)
    return omega0**2 * x + alpha * x**3


def restoring_slope(x: ArrayLike, omega0: float, alpha: float) -> Array:
    """g'(x) = omega0^2 + 3 alpha x^2."""
    x = np.asarray(x, dtype=float)
    return omega0**2 + 3.0 * alpha * x**2


def amplitude_of_energy(E: ArrayLike, omega0: float, alpha: float) -> Array:
    """A = U^{-1}(E) >= 0, in the cancellation-free form A^2 = 4E / (w0^2 + sqrt(w0^4 + 4 a E))."""
    E = np.maximum(np.asarray(E, dtype=float), 0.0)
    return np.sqrt(4.0 * E / (omega0**2 + np.sqrt(omega0**4 + 4.0 * alpha * E)))


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
