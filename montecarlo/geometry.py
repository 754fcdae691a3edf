"""The few lines of oscillator geometry the Monte Carlo needs, kept apart from ``averaging``
so that a bug there cannot hide here too.

    E = v^2/2 + omega0^2 x^2/2 + alpha x^4/4 [+ k5 x^6/6 + k7 x^8/8 + ...]
    A = U^{-1}(E):  A^2 = 4E / (w0^2 + sqrt(w0^4 + 4 alpha E))     (no terms beyond x^3)

With higher terms (``khi`` = (k5, k7, ...), None otherwise: numba compiles the Duffing form
alone for the paper's family) U is increasing on A >= 0 (scene check) and A is its root,
by Newton's method kept inside a bracket (bisection when a step leaves it).
"""

from __future__ import annotations

import math

from ._jit import jit


@jit
def amplitude(x: float, v: float, w0sq: float, alpha: float) -> float:
    """Amplitude of the conservative orbit through (x, v): U(A) = v^2/2 + U(x)."""
    E = 0.5 * v * v + 0.5 * w0sq * x * x + 0.25 * alpha * x * x * x * x
    return math.sqrt(4.0 * E / (w0sq + math.sqrt(w0sq * w0sq + 4.0 * alpha * E)))


@jit(inline="always")
def poly_x2(c, x2: float) -> float:
    """c[0] + c[1] x2 + c[2] x2^2 + ... (Horner)."""
    out = 0.0
    for i in range(c.shape[0] - 1, -1, -1):
        out = out * x2 + c[i]
    return out


@jit
def potential(x: float, w0sq: float, alpha: float, khi) -> float:
    """U(x) = w0^2 x^2/2 + alpha x^4/4 + sum_j k_{2j+3} x^{2j+6} / (2j + 6)."""
    x2 = x * x
    u = 0.5 * w0sq * x2 + 0.25 * alpha * x2 * x2
    if khi is not None:
        s = 0.0
        for i in range(khi.shape[0] - 1, -1, -1):
            s = s * x2 + khi[i] / (2 * i + 6)
        u += s * x2 * x2 * x2
    return u


@jit
def energy(x: float, v: float, w0sq: float, alpha: float, khi) -> float:
    """E = v^2/2 + U(x): the energy whose level sets are the conservative orbits, U(A) = E."""
    return 0.5 * v * v + potential(x, w0sq, alpha, khi)


@jit
def restoring(x: float, w0sq: float, alpha: float, khi) -> float:
    """g(x) = U'(x)."""
    x2 = x * x
    g = (w0sq + alpha * x2) * x
    if khi is not None:
        g += poly_x2(khi, x2) * x2 * x2 * x
    return g


@jit
def amplitude_general(x: float, v: float, w0sq: float, alpha: float, khi) -> float:
    """A with U(A) = v^2/2 + U(x), any admissible spring (see module)."""
    if khi is None:
        return amplitude(x, v, w0sq, alpha)
    E = 0.5 * v * v + potential(x, w0sq, alpha, khi)
    lo = abs(x)
    if v == 0.0:
        return lo
    hi = max(2.0 * lo, 1e-3)
    while potential(hi, w0sq, alpha, khi) < E:
        lo = hi
        hi *= 2.0
    a = hi
    for _ in range(200):
        fa = potential(a, w0sq, alpha, khi) - E
        if fa > 0.0:
            hi = a
        else:
            lo = a
        g = restoring(a, w0sq, alpha, khi)
        new = a - fa / g if g > 0.0 else 0.5 * (lo + hi)
        if not (lo < new < hi):
            new = 0.5 * (lo + hi)
        if abs(new - a) <= 1e-15 * a or hi - lo <= 1e-15 * hi:
            return new
        a = new
    return a
