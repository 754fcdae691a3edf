"""The spring, written once: U(x), g(x) = U'(x), g'(x) and the inverse U(A) = E, with walls.

The restoring law is an odd polynomial with coefficients k = (k1, k3, k5, ...) (issue 21)::

    g(x) = k1 x + k3 x^3 + k5 x^5 + ...,     U(x) = sum_j k_{2j-1} x^{2j} / (2j),

checked by the scene (vifpk.core.scene): g > 0 on x > 0 and U growing without bound, so U is
even and increasing on x >= 0 and each energy E >= 0 has one amplitude A >= 0 with U(A) = E.

Every function here is plain arithmetic on ``x`` (a float or a numpy array) and indexing of
``k`` (a tuple or a float64 array): Horner loops over the coefficients, no numpy call that
needs an array, so numba can compile the same source on scalars (the Monte Carlo wraps it with
its own ``jit``; this package imports no numba). For k of length <= 2 (the Duffing spring of
the paper, k1 = omega0^2, k3 = alpha) the closed forms are kept, operation for operation those
the averaged models used before issue 37, so their numbers are unchanged bit for bit.

Walls (issue 37): a lower wall at a <= 0 (x >= a) and an upper wall at b >= 0 (x <= b)
truncate the orbit of energy E to [max(a, -A), min(b, A)] (:func:`turning_points`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def potential_parts(x: Any, k1: float, k3: float, khi: Any) -> Any:
    """U(x) = k1 x^2/2 + k3 x^4/4 + sum_{i>=1} khi_i x^{2i+4} / (2i + 4), ``khi`` = (k5, k7, ...)
    or None: the one formula of U (the Monte Carlo compiles it with numba on scalars, the
    averaged models call it through :func:`potential` on arrays). With khi None the Duffing
    closed form; else Horner in x^2, U = x^2 (k1/2 + x^2 (k3/4 + x^2 (k5/6 + ...)))."""
    if khi is None:
        return 0.5 * k1 * x**2 + 0.25 * k3 * x**4
    x2 = x * x
    out = 0.0 * x2
    for i in range(len(khi), 0, -1):
        out = out * x2 + khi[i - 1] / (2 * i + 4)
    out = out * x2 + k3 / 4
    out = out * x2 + k1 / 2
    return out * x2


def make_potential(parts: Any) -> Any:
    """U(x, k) for a coefficient sequence k = (k1, k3, k5, ...) built on the given
    :func:`potential_parts` (plain Python: :data:`potential`) or its numba-compiled version
    (``jit(make_potential(jit(potential_parts)))``: numba calls a compiled function it finds in
    a closure, not a plain one it finds as a module global)."""

    def potential(x: Any, k: Any) -> Any:
        """U(x) = sum_j k_{2j-1} x^{2j} / (2j): :func:`potential_parts` on k's parts."""
        if len(k) > 2:
            return parts(x, k[0], k[1], k[2:])
        return parts(x, k[0], k[1] if len(k) > 1 else 0.0, None)

    return potential


#: U(x) for k = (k1, k3, k5, ...), plain Python (see :func:`make_potential`)
potential = make_potential(potential_parts)


def restoring(x: Any, k: Any) -> Any:
    """g(x) = U'(x) = sum_j k_{2j-1} x^{2j-1}."""
    if len(k) <= 2:
        k3 = k[1] if len(k) > 1 else 0.0
        return k[0] * x + k3 * x**3
    x2 = x * x
    out = 0.0 * x2
    for j in range(len(k), 0, -1):
        out = out * x2 + k[j - 1]
    return out * x


def restoring_slope(x: Any, k: Any) -> Any:
    """g'(x) = sum_j (2j - 1) k_{2j-1} x^{2j-2}."""
    if len(k) <= 2:
        k3 = k[1] if len(k) > 1 else 0.0
        return k[0] + 3.0 * k3 * x**2
    x2 = x * x
    out = 0.0 * x2
    for j in range(len(k), 0, -1):
        out = out * x2 + (2 * j - 1) * k[j - 1]
    return out


def make_amplitude_scalar(potential_fn: Any, restoring_fn: Any) -> Any:
    """The scalar inverse A(E) built on the given U and g: pass :func:`potential` and
    :func:`restoring` (plain Python, :data:`amplitude_scalar`) or their numba-compiled versions
    (``jit(make_amplitude_scalar(P, jit(restoring)))`` with P =
    ``jit(make_potential(jit(potential_parts)))``: numba calls a compiled function it finds in
    a closure, not a plain one it finds as a module global)."""

    def amplitude(E: float, k: Any) -> float:
        """A >= 0 with U(A) = E for one energy (:func:`amplitude_of_energy` is the same
        algorithm on arrays). Duffing with k1 > 0: the cancellation-free closed form
        A^2 = 4E / (k1 + sqrt(k1^2 + 4 k3 E)); pure cubic: A = (4E / k3)^(1/4); otherwise U is
        increasing on A >= 0, so the root is bracketed (doubling), bisected to the last bit
        and polished by two Newton steps kept inside the bracket."""
        if E <= 0.0:
            return 0.0
        if len(k) <= 2:
            k3 = k[1] if len(k) > 1 else 0.0
            if k[0] > 0.0:
                return math.sqrt(4.0 * E / (k[0] + math.sqrt(k[0] * k[0] + 4.0 * k3 * E)))
            return math.sqrt(2.0 * math.sqrt(E / k3))
        lo, hi = 0.0, 1.0
        for _ in range(2100):
            if potential_fn(hi, k) >= E:
                break
            hi *= 2.0
        for _ in range(64):
            mid = 0.5 * (lo + hi)
            if potential_fn(mid, k) < E:
                lo = mid
            else:
                hi = mid
            if hi - lo <= 4e-16 * hi:
                break
        a = 0.5 * (lo + hi)
        for _ in range(2):
            g = restoring_fn(a, k)
            if g > 0.0:
                new = a - (potential_fn(a, k) - E) / g
                if lo <= new <= hi:
                    a = new
        return a

    return amplitude


#: A(E) for one energy, plain Python (see :func:`make_amplitude_scalar`)
amplitude_scalar = make_amplitude_scalar(potential, restoring)


def amplitude_of_energy(E: Any, k: Any) -> np.ndarray:
    """A = U^{-1}(E) >= 0 elementwise on an array (negative E counts as 0): the algorithm of
    :data:`amplitude_scalar`, vectorised with numpy (the averaged models' grids)."""
    E = np.maximum(np.asarray(E, dtype=float), 0.0)
    if len(k) <= 2:
        k1 = float(k[0])
        k3 = float(k[1]) if len(k) > 1 else 0.0
        if k1 > 0.0:
            return np.sqrt(4.0 * E / (k1 + np.sqrt(k1 * k1 + 4.0 * k3 * E)))
        return np.sqrt(2.0 * np.sqrt(E / k3))
    lo = np.zeros_like(E)
    hi = np.ones_like(E)
    for _ in range(2100):
        short = potential(hi, k) < E
        if not short.any():
            break
        hi = np.where(short, 2.0 * hi, hi)
    for _ in range(64):
        mid = 0.5 * (lo + hi)
        below = potential(mid, k) < E
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        if np.all(hi - lo <= 4e-16 * hi):
            break
    a = 0.5 * (lo + hi)
    for _ in range(2):
        g = restoring(a, k)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = (potential(a, k) - E) / g
        new = a - np.where(g > 0, step, 0.0)
        a = np.where((new >= lo) & (new <= hi), new, a)
    return np.where(E > 0, a, 0.0)


def turning_points(A: Any, lower: float, upper: float) -> tuple[Any, Any]:
    """(x_-, x_+) = (max(lower, -A), min(upper, A)): the ends of the orbit of amplitude A
    between a lower wall at ``lower`` <= 0 and an upper wall at ``upper`` >= 0 (pass -inf /
    +inf for no wall). U is even, so the free orbit of energy E = U(A) spans [-A, A]; a wall
    inside it is where the orbit turns (by impact) instead."""
    return np.maximum(lower, -A), np.minimum(upper, A)
