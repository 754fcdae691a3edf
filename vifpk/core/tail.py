"""The large-energy tail of the averaged energy's stationary law under parametric noise
(issue 37): whether a stationary law exists, whether the mean energy is finite, and the
intensities where either is lost. Derivation: docs/averaging.md section 12, "The tail".

At large energy only each law's top term counts. The spring's top term ``K x^(2n+1)``
(``U ~ K x^q / q``, ``q = 2n + 2``) makes the orbit of energy E self-similar: ``x = A s``,
``U(A) = E``, ``v^2 = 2 E (1 - s^q)``, and its time averages are Beta functions,

    <x^(2j) v^(2m)> = A^(2j) (2E)^m B((2j+1)/q, m+1/2) / B(1/q, 1/2),   A = (q E / K)^(1/q),

the period ``T = 4 A (2E)^(-1/2) B(1/q, 1/2) / q``. One wall (at a <= 0 or at b >= 0) cuts the
orbit at a point that the amplitude leaves behind (|a| / A -> 0): the orbit averages of the
even powers above are unchanged, the motion between impacts is half the free orbit, so the
impacts take ``(1 - e^2) E`` every ``T / 2`` (``e = r`` for Newton's law, ``e -> 0`` at high
speed for a law with a yield speed). Each term of the averaged energy's Ito drift ``m(E)`` and
diffusion ``sigma^2(E)`` (section 12) is then a constant times a power of E:

    loss  d_j <x^(2j) v^2>,  e_i <v^(2i+4)>,  mu <|v|>,  2 (1 - e^2) E / T
    gain  D_k K^2 <x^(4n+2)>                 sigma^2: 2 D_k K^2 <x^(4n+2) v^2>
          2 D_c d_J^2 <x^(4J) v^2>           sigma^2: 2 D_c d_J^2 <x^(4J) v^4>

(``d_J`` the damping law's top term; the external noise's diffusion, ~ E, is always of lower
degree than a parametric one, >= E^2). Each parametric diffusion is one power of E above its
drift. Where a parametric noise is of the top degree ``gamma`` of the drift, ``m ~ C_m
E^gamma`` and ``sigma^2 ~ C_s E^(gamma+1)``, and the stationary law of the averaged energy
``p(E) = C exp(int 2 m / sigma^2 dE) / sigma^2`` (section 5) decays as ``E^-kappa``,

    kappa = gamma + 1 - 2 C_m / C_s,

normalisable iff kappa > 1, with a finite mean energy iff kappa > 2 (the linear oscillator:
``kappa = 2 + 2 a / b`` of section 12, and kappa > 2 is exactly ``D_k w^2 + 2 D_c k^2 < k``,
the mean-square stability boundary of the exact second moments, docs/montecarlo.md). C_m and
C_s are linear in each intensity D (``C_m = C_m0 + D G``, ``C_s = C_s0 + D B``), so kappa > 1
holds for ``D (2 G - gamma B) < gamma C_s0 - 2 C_m0``: an upper bound on D when ``2 G >
gamma B``, none otherwise (the damping noise on the paper's ``c2 x^2 x'`` damping with its
cubic spring: 2 G < gamma B, a stationary law at every D_c, though E[H] is infinite). Two walls
keep x bounded and break the self-similar orbit: not decided here (None).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from .registry import IMPACT_LAW_PARAMS
from .system import _trim

KEYS = {"stiffness": "parametric.stiffness", "damping": "parametric.damping"}
_EPS = 1e-12  # exponents are ratios of small integers: equal when within this


@dataclass(frozen=True)
class Tail:
    """The averaged energy's law at large E: ``p(E) ~ E^-kappa`` (``kappa``), ``gamma`` the
    drift's top exponent, ``normalisable`` (kappa > 1: a stationary law exists), ``mean_finite``
    (kappa > 2: E[H] finite, mean-square stability), ``top_losses`` the loss fields of degree
    gamma (empty: the parametric noise outgrows every loss), ``bounds`` {field: D above which
    kappa <= 1} and ``mean_bounds`` {field: D above which kappa <= 2} (each key varied alone,
    the other held; a key absent has no bound), ``crossover``: with no loss at the top, the
    energy where the top loss's constant times its power equals the parametric drift's (below
    it the losses win; None otherwise)."""

    kappa: float
    gamma: float
    normalisable: bool
    mean_finite: bool
    top_losses: tuple[str, ...]
    bounds: dict[str, float]
    mean_bounds: dict[str, float]
    crossover: float | None


def _beta(a: float, b: float) -> float:
    return math.exp(math.lgamma(a) + math.lgamma(b) - math.lgamma(a + b))


def orbit_average(j2: int, m: float, q: int, K: float) -> tuple[float, float]:
    """<x^j2 v^(2m)> on the self-similar orbit of U = K x^q / q as (constant, power of E)."""
    c = (q / K) ** (j2 / q) * 2.0 ** m * _beta((j2 + 1) / q, m + 0.5) / _beta(1 / q, 0.5)
    return c, j2 / q + m


def parametric_tail(system: Any, parametric: Any) -> Tail | None:
    """The tail of the module docstring, or None when no parametric noise reaches the top
    degree of the energy drift, the spring has no confining top term (K <= 0), or two walls
    bound x."""
    D_k = float(getattr(parametric, "stiffness", 0.0) or 0.0) if parametric is not None else 0.0
    D_c = float(getattr(parametric, "damping", 0.0) or 0.0) if parametric is not None else 0.0
    k = _trim(tuple(system.restoring_law))
    walls = tuple(getattr(system, "walls", ()))
    if not (D_k > 0 or D_c > 0) or not k or k[-1] <= 0.0 or len(walls) > 1:
        return None
    n = len(k) - 1
    q, K = 2 * n + 2, k[-1]
    drift: list[tuple[str, float, float]] = []  # (field, constant, power): + gain, - loss
    diff: list[tuple[str, float, float]] = []
    d_law = tuple(system.damping_law)
    paper_d = not getattr(system, "damping", ())
    for j, c in enumerate(d_law):
        if c != 0.0:
            name = (("system.c1" if j == 0 else "system.c2") if paper_d and j < 2
                    else f"system.damping[{j}]")
            a, p = orbit_average(2 * j, 1, q, K)
            drift.append((name, -c * a, p))
    for i, c in enumerate(system.velocity_law):
        if c != 0.0:
            a, p = orbit_average(0, i + 2, q, K)
            drift.append((f"system.velocity_damping[{i}]", -c * a, p))
    if system.mu > 0:
        a, p = orbit_average(0, 0.5, q, K)
        drift.append(("system.mu", -system.mu * a, p))
    for w in walls:
        e = 0.0 if IMPACT_LAW_PARAMS.get(w.law) else w.r
        if e < 1.0:
            # 2 (1 - e^2) E / T, T = 4 (q/K)^(1/q) E^(1/q) (2E)^(-1/2) B(1/q, 1/2) / q
            c = 2 * (1 - e * e) * q * math.sqrt(2.0) / (4 * (q / K) ** (1 / q)
                                                        * _beta(1 / q, 0.5))
            name = "system.r" if getattr(system, "r", None) is not None else \
                f"system.{w.side}_wall"
            drift.append((name, -c, 1.5 - 1 / q))
    per: dict[str, tuple[float, float, float]] = {}  # field: (G, B, power of the drift)
    if D_k > 0:
        a, p = orbit_average(4 * n + 2, 0, q, K)
        b, _ = orbit_average(4 * n + 2, 1, q, K)
        per[KEYS["stiffness"]] = (K * K * a, 2 * K * K * b, p)
    top_d = max((j for j, c in enumerate(d_law) if c != 0.0), default=None)
    if D_c > 0 and top_d is not None:
        dJ = d_law[top_d]
        a, p = orbit_average(4 * top_d, 1, q, K)
        b, _ = orbit_average(4 * top_d, 2, q, K)
        per[KEYS["damping"]] = (2 * dJ * dJ * a, 2 * dJ * dJ * b, p)
    level = {KEYS["stiffness"]: D_k, KEYS["damping"]: D_c}
    for name, (G, B, p) in per.items():
        drift.append((name, level[name] * G, p))
        diff.append((name, level[name] * B, p + 1))
    if not diff:
        return None
    gamma = max(p for _, c, p in drift if c != 0.0)
    delta = max(p for _, _, p in diff)
    if delta < gamma + 1 - _EPS:
        return None  # a loss (or a gain that is not parametric) outranks every parametric term
    C_m = sum(c for _, c, p in drift if abs(p - gamma) < _EPS)
    C_s = sum(c for _, c, p in diff if abs(p - delta) < _EPS)
    kappa = gamma + 1 - 2 * C_m / C_s
    bounds, mean_bounds = {}, {}
    for name, (G, B, p) in per.items():
        if abs(p - gamma) > _EPS:
            continue
        m0, s0 = C_m - level[name] * G, C_s - level[name] * B
        for out, g in ((bounds, gamma), (mean_bounds, gamma - 1)):
            slope = 2 * G - g * B
            if slope > 0:
                out[name] = max((g * s0 - 2 * m0) / slope, 0.0)
    top_losses = tuple(nm for nm, c, p in drift if c < 0 and abs(p - gamma) < _EPS)
    crossover = None
    losses = [(c, p) for _, c, p in drift if c < 0]
    if not top_losses and losses:
        c_l, p_l = max(losses, key=lambda t: t[1])
        c_l = sum(c for _, c, p in drift if c < 0 and abs(p - p_l) < _EPS)
        crossover = (-c_l / C_m) ** (1 / (gamma - p_l)) if C_m > 0 else None
    return Tail(kappa=kappa, gamma=gamma, normalisable=kappa > 1 + _EPS,
                mean_finite=kappa > 2 + _EPS, top_losses=top_losses, bounds=bounds,
                mean_bounds=mean_bounds, crossover=crossover)
