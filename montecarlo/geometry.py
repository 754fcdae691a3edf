"""The oscillator geometry the Monte Carlo's kernels need, compiled: the energy, amplitudes and
time-uniform starts on an orbit. U(x) itself is the physics' one formula
(vifpk.physics.spring.potential_parts, issue 37: written once), compiled here.

    E = v^2/2 + omega0^2 x^2/2 + alpha x^4/4 [+ k5 x^6/6 + k7 x^8/8 + ...]
    A = U^{-1}(E):  A^2 = 4E / (w0^2 + sqrt(w0^4 + 4 alpha E))     (no terms beyond x^3)

With higher terms (``khi`` = (k5, k7, ...), None otherwise: numba compiles the Duffing form
alone for the paper's family) U is increasing on A >= 0 (scene check) and A is its root,
by Newton's method kept inside a bracket (bisection when a step leaves it).

Starts on an orbit (``orbit_point``, ``orbit_start``): a phase uniform in TIME along the
conservative orbit, not a uniform angle (the two differ for a nonlinear spring).
"""

from __future__ import annotations

import math

from vifpk.physics import spring

from ._jit import jit
from .noise_start import noise_start
from .rng import uniform

#: U(x) = w0^2 x^2/2 + alpha x^4/4 + sum_j k_{2j+3} x^{2j+6} / (2j + 6): the physics' one
#: formula (vifpk.physics.spring.potential_parts), compiled; potential(x, w0sq, alpha, khi)
potential = jit(spring.potential_parts)


@jit
def amplitude(x: float, v: float, w0sq: float, alpha: float) -> float:
    """Amplitude of the conservative orbit through (x, v) of the Duffing spring: U(A) =
    v^2/2 + U(x)."""
    E = 0.5 * v * v + potential(x, w0sq, alpha, None)
    return math.sqrt(4.0 * E / (w0sq + math.sqrt(w0sq * w0sq + 4.0 * alpha * E)))


@jit(inline="always")
def poly_x2(c, x2: float) -> float:
    """c[0] + c[1] x2 + c[2] x2^2 + ... (Horner)."""
    out = 0.0
    for i in range(c.shape[0] - 1, -1, -1):
        out = out * x2 + c[i]
    return out




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


@jit
def amplitudes(x, v, w0sq, alpha, khi, out):
    """out[i] = A of (x[i], v[i]) (amplitude_general), for arrays."""
    for i in range(x.size):
        out[i] = amplitude_general(x[i], v[i], w0sq, alpha, khi)


@jit
def nu_sq_higher(A, c2, khi):
    """The spring's terms beyond x^3 in nu^2: sum_j k_{2j-1} A^{2j-2} (1 + c2 + ... +
    c2^{j-1}) / j for j >= 3 (khi = (k5, k7, ...); c2 = cos^2 th)."""
    out = 0.0
    part = 1.0 + c2
    cj = c2
    Aj = A * A
    for i in range(khi.shape[0]):
        j = i + 3
        cj *= c2
        part += cj
        Aj *= A * A
        out += khi[i] * Aj * part / j
    return out


@jit
def orbit_point(A, w0sq, alpha, khi, s0, s1, s2, s3):
    """(y, y', state): a time-uniform point of the orbit of amplitude A.

    On the orbit y = A cos(th), y' = -A nu sin(th), d(th)/dt = nu with
    nu^2 = w0^2 + alpha A^2 (1 + cos^2 th) / 2 [+ nu_sq_higher], so a time-uniform phase has
    density ~ 1/nu: th uniform, accepted with probability nu_min / nu (>= 1/sqrt(2) for the
    Duffing spring). With higher terms nu_min is the least nu^2 over 257 values of cos^2 th
    in [0, 1], times 0.98 (a polynomial of degree <= 9 in cos^2 th varies far less than
    that between nodes unless its minimum is near 0: then the acceptance rate, not the law,
    suffers). A softening spring (alpha < 0) has its least nu at cos^2 th = 1."""
    if khi is None:  # nu^2 is linear in cos^2 th: least at cos^2 th = 0 (alpha >= 0) or 1
        nu_min = math.sqrt(w0sq + (0.5 if alpha >= 0.0 else 1.0) * alpha * A * A)
    else:
        lo = math.inf
        for i in range(257):
            c2 = i / 256.0
            lo = min(lo, w0sq + 0.5 * alpha * A * A * (1.0 + c2) + nu_sq_higher(A, c2, khi))
        nu_min = 0.98 * math.sqrt(max(lo, 0.0))
    while True:
        u, s0, s1, s2, s3 = uniform(s0, s1, s2, s3)
        a, s0, s1, s2, s3 = uniform(s0, s1, s2, s3)
        th = 2.0 * math.pi * u
        c = math.cos(th)
        nu2 = w0sq + 0.5 * alpha * A * A * (1.0 + c * c)
        if khi is not None:
            nu2 += nu_sq_higher(A, c * c, khi)
        nu = math.sqrt(nu2)
        if a * nu <= nu_min:
            return A * c, -A * nu * math.sin(th), s0, s1, s2, s3


@jit
def orbit_position(A, w0sq, alpha, khi, fold, lo, up, s0, s1, s2, s3):
    """(y, y', generator state): orbit_start's point of the orbit, without the noise state
    (the averaged SDE's phase points)."""
    y, yp, s0, s1, s2, s3 = orbit_point(A, w0sq, alpha, khi, s0, s1, s2, s3)
    if fold and y < 0.0:
        y = -y
        yp = -yp
    while y < lo or y > up:  # lo <= 0 <= up: the orbit passes inside, so this ends
        y, yp, s0, s1, s2, s3 = orbit_point(A, w0sq, alpha, khi, s0, s1, s2, s3)
    return y, yp, s0, s1, s2, s3


@jit
def orbit_start(A, w0sq, alpha, khi, fold, lo, up, P, s0, s1, s2, s3):
    """(x, v, xi, generator state): a start on the conservative orbit of amplitude A at a
    phase uniform IN TIME (``orbit_point``), on the elastic impacting orbit when walls keep x
    in [lo, up] (lo = -inf, up = inf without): with ``fold`` (one wall at 0) folded onto
    x >= 0 (that orbit is the fold of the free one: x = |y|, v = y' sgn(y), the same time
    spent at each |y|), else the free orbit's points outside [lo, up] rejected (the elastic
    orbit truncated at the walls spends the free orbit's time at each x inside: the free law
    conditioned on [lo, up]); and xi from the noise state's stationary law (the kind of the
    kernels' record P: noise_start, its ``state_start``; OU draws xi_sd N, white nothing)."""
    y, yp, s0, s1, s2, s3 = orbit_position(A, w0sq, alpha, khi, fold, lo, up, s0, s1, s2, s3)
    xi, s0, s1, s2, s3 = noise_start(P, s0, s1, s2, s3)
    return y, yp, xi, s0, s1, s2, s3
