"""Whether a system can hold its energy: the orbit-averaged energy balance at large amplitude,
which decides before any work whether a stationary density can exist.

**The tail under parametric noise** (``parametric_tail``; issue 37): the large-energy tail of
the averaged energy's stationary law, whether a stationary law exists, whether the mean energy
is finite, and the intensities where either is lost. Derivation: docs/averaging.md section 12,
"The tail".

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
from dataclasses import dataclass, field
from typing import Any

from . import registry
from .system import _trim

KEYS = {"stiffness": "parametric.stiffness", "damping": "parametric.damping"}
_EPS = 1e-12  # exponents are ratios of small integers: equal when within this


@dataclass(frozen=True)
class Tail:
    """The averaged energy's law at large E: ``p(E) ~ E^-kappa`` (``kappa``), ``gamma`` the
    drift's top exponent, ``normalisable`` (kappa > 1: a stationary law exists), ``mean_finite``
    (kappa > 2: the averaged law's E[H] finite; for the linear oscillator exactly its
    mean-square stability, for a nonlinear scene only the averaged mean energy),
    ``top_losses`` the loss fields of degree
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
    #: {field: (m0, s0, G, B)} of each intensity of the top degree: C_m = m0 + D G, C_s = s0 +
    #: D B with the other intensity held (what :meth:`bound` reads)
    levels: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    #: the spring's top degree + 1 (U ~ A^q): p_A(A) ~ A^(q (1 - kappa) - 1) in the tail
    q: int = 0

    def bound(self, name: str, kappa: float) -> float | None:
        """The intensity of ``name`` (the other held) at which the tail's exponent reaches
        ``kappa`` from above: kappa(D) = gamma + 1 - 2 (m0 + D G) / (s0 + D B) falls with D
        where g B < 2 G (g = gamma + 1 - kappa), and equals kappa at D = (g s0 - 2 m0) /
        (2 G - g B); None where it never falls (or ``name`` is not of the top degree)."""
        if name not in self.levels:
            return None
        m0, s0, G, B = self.levels[name]
        g = self.gamma + 1 - kappa
        slope = 2 * G - g * B
        return max((g * s0 - 2 * m0) / slope, 0.0) if slope > 0 else None


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
        e = _limit(w)
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
    levels = {name: (C_m - level[name] * G, C_s - level[name] * B, G, B)
              for name, (G, B, p) in per.items() if abs(p - gamma) <= _EPS}
    probe = Tail(kappa=0.0, gamma=gamma, normalisable=False, mean_finite=False, top_losses=(),
                 bounds={}, mean_bounds={}, crossover=None, levels=levels)
    bounds = {n: b for n in levels if (b := probe.bound(n, 1.0)) is not None}
    mean_bounds = {n: b for n in levels if (b := probe.bound(n, 2.0)) is not None}
    top_losses = tuple(nm for nm, c, p in drift if c < 0 and abs(p - gamma) < _EPS)
    crossover = None
    losses = [(c, p) for _, c, p in drift if c < 0]
    if not top_losses and losses:
        c_l, p_l = max(losses, key=lambda t: t[1])
        c_l = sum(c for _, c, p in drift if c < 0 and abs(p - p_l) < _EPS)
        crossover = (-c_l / C_m) ** (1 / (gamma - p_l)) if C_m > 0 else None
    return Tail(kappa=kappa, gamma=gamma, normalisable=kappa > 1 + _EPS,
                mean_finite=kappa > 2 + _EPS, top_losses=top_losses, bounds=bounds,
                mean_bounds=mean_bounds, crossover=crossover, levels=levels, q=q)


@dataclass(frozen=True)
class EnergyBalance:
    """Which effects win the orbit-averaged energy balance at large amplitude (see
    :func:`energy_balance`): ``grows`` (no stationary density), ``tie`` (gains and losses of
    the same leading degree: their constants decide), ``degree`` the leading power's exponent,
    ``gains`` and ``losses`` the fields at that degree, ``terms`` every (field, exponent,
    sign) and ``text`` the verdict in words (one line)."""

    grows: bool
    tie: bool
    degree: int
    gains: tuple[str, ...]
    losses: tuple[str, ...]
    terms: tuple[tuple[str, int, int], ...]
    text: str
    #: the parametric tail (vifpk.core.energy.Tail) where a parametric noise is of the top degree
    tail: Any = None


def energy_balance(system: Any, parametric: Any = None) -> EnergyBalance:
    """Does a mechanism remove energy at large amplitude faster than the noise feeds it?

    With H = x'^2 / 2 + U(x), dH/dt = -(d(x) + e(x'^2)) x'^2 - mu |x'| + f x' xi, and each
    impact with the wall takes (1 - r^2) H. The noise input per unit time is bounded at large
    amplitude (f^2 D for white noise, exactly, Ito; less for the OU band once the orbit's
    frequency leaves it). Along the orbit of amplitude A with the spring's top term
    k_{2n+1} x^{2n+1} (U(A) ~ A^{2n+2}): x ~ A, x' ~ sqrt(2 U(A)) ~ A^{n+1}, and the period
    (between impacts with the wall) T(A) ~ A / A^{n+1} = A^{-n}. The orbit-averaged powers:

        damping  d_{2j} <x^{2j} x'^2>    ~ d_{2j} A^{2j + 2n + 2}
        velocity e_{2m} <x'^{2m} x'^2>   ~ e_{2m} A^{(2m + 2)(n + 1)}
        friction mu <|x'|>               ~ mu A^{n + 1}
        impacts  (1 - r^2) H / T(A)      ~ (1 - r^2) A^{3n + 2}   (barrier and r < 1)

    (the orbit averages are positive constants times these powers). The term of the highest
    exponent decides: a positive coefficient (a loss) outgrows the bounded input, so the energy
    is held and a stationary density exists; a negative one (a gain: c1 > 0 with nothing of
    higher degree, or a negative leading velocity_damping) outgrows every loss, and so does the
    noise input when no term is left at all (no damping, mu = 0, r = 1 or no barrier): the
    energy grows without bound and no stationary density exists (``grows``). Gains and losses
    of the same top degree (a linear spring with c1 > 0, c2 = 0 and impacts r < 1: both
    ~ A^2) balance by their constants: ``tie``, not decided here (the averaged model decides).
    Derived here from the energy equation above (the sign of the orbit-averaged energy drift
    at large amplitude, as first-order stochastic averaging would give it); docs/edges.md,
    "No stationary density".

    Walls on both sides (issue 37) hold x in [a, b]: x stays bounded while x' ~ A^{n+1}, so
    every damping term ~ A^{2n+2}, the period ~ A^{-(n+1)} and the impacts (1 - e^2) H / T ~
    A^{3n+3}. A wall whose law's e tends to a limit below 1 at high
    impact speed (ImpactLaw.limit; "johnson": 0) loses (1 - limit^2) of the energy there even
    with r = 1. Parametric noises
    (``parametric``: the scene's section) feed energy that grows with the amplitude
    (D_k <g(x)^2>, D_c <d(x)^2 x'^2>); they are counted as gains of their degree that never
    decide alone: at or above the top loss they make a ``tie`` (the averaged model decides),
    since a multiplicative noise also spreads the law without making its mean energy grow.
    A parametric tie with a loss of the same degree is then decided by the constants
    (vifpk.core.energy.parametric_tail, wall-free or one wall): the averaged energy's law decays
    as E^-kappa, so it ``grows`` (no stationary law) when kappa <= 1, and holds otherwise
    (``tail``; E[H] is infinite when kappa <= 2). A parametric gain of a degree above every
    loss stays a tie: the law is E^-kappa beyond the crossover energy only, the averaged model
    decides on its grid.
    """
    k = _trim(tuple(system.restoring_law))
    n = max(len(k) - 1, 0)
    walls = tuple(getattr(system, "walls", ()))
    bounded = len(walls) == 2  # both sides: x stays in [a, b]
    paper_k = not getattr(system, "restoring", ())
    paper_d = not getattr(system, "damping", ())
    terms: list[tuple[str, int, int]] = []
    d_law = tuple(system.damping_law)
    for j, c in enumerate(d_law):
        if c != 0.0:
            name = (("system.c1" if j == 0 else "system.c2") if paper_d and j < 2
                    else f"system.damping[{j}]")
            terms.append((name, (2 * n + 2) if bounded else 2 * j + 2 * n + 2,
                          1 if c > 0 else -1))
    for i, c in enumerate(system.velocity_law):
        if c != 0.0:
            terms.append((f"system.velocity_damping[{i}]", (2 * i + 4) * (n + 1),
                          1 if c > 0 else -1))
    if system.mu > 0:
        terms.append(("system.mu", n + 1, 1))
    for w in walls:
        if _limit(w) < 1.0:
            name = "system.r" if getattr(system, "r", None) is not None else (
                f"system.{w.side}_wall")
            terms.append((name, (3 * n + 3) if bounded else 3 * n + 2, 1))
    gains_p: list[tuple[str, int]] = []
    if parametric is not None and getattr(parametric, "stiffness", 0.0) > 0.0:
        gains_p.append(("parametric.stiffness", 0 if bounded else 4 * n + 2))
    if parametric is not None and getattr(parametric, "damping", 0.0) > 0.0:
        top_d = max((j for j, c in enumerate(d_law) if c != 0.0), default=None)
        if top_d is not None:
            gains_p.append(("parametric.damping",
                            (4 * n + 4) if bounded else 4 * top_d + 2 * n + 2))
    spring = (f"system.restoring[{n}]" if not paper_k else
              "system.alpha" if n == 1 else "system.omega0")
    if gains_p and terms:
        top_loss = max(p for _, p, s in terms) if terms else 0
        reach = [nm for nm, p in gains_p if p >= top_loss]
        if reach:
            losses = tuple(nm for nm, p, s in terms if p == top_loss and s > 0)
            tail = parametric_tail(system, parametric)
            if tail is not None:
                return _decided(tail, top_loss, tuple(reach), losses, tuple(terms))
            text = (f"the parametric noise ({', '.join(reach)}) feeds energy that grows with "
                    f"the amplitude as fast as the losses ({', '.join(losses) or 'none'}): "
                    "their constants decide whether the energy is held")
            return EnergyBalance(False, True, top_loss, tuple(reach), losses, tuple(terms),
                                 text)
    if not terms:
        wall = ("system.r = 1" if walls and getattr(system, "r", None) is not None
                else "elastic walls" if walls else "no barrier")
        text = (f"nothing removes energy at large amplitude (no damping law, no "
                f"velocity_damping, system.mu = 0, {wall}): the noise feeds the energy "
                "without bound, so there is no stationary density")
        return EnergyBalance(True, False, 0, (), (), (), text)
    top = max(p for _, p, _ in terms)
    gains = tuple(nm for nm, p, s in terms if p == top and s < 0)
    losses = tuple(nm for nm, p, s in terms if p == top and s > 0)

    def listed(sel: Any) -> str:
        return ", ".join(f"{nm} ~ A^{p}" for nm, p, s in terms if sel(p, s)) or "none"

    if gains and not losses:
        text = (f"at large amplitude A the energy gain of {', '.join(gains)} (power ~ A^{top}"
                f" with the spring's top term {spring}, degree {2 * n + 1}) outgrows every "
                f"loss ({listed(lambda p, s: s > 0)}): the energy grows without bound, so "
                "there is no stationary density")
        return EnergyBalance(True, False, top, gains, (), tuple(terms), text)
    if gains:
        text = (f"at large amplitude A the gain of {', '.join(gains)} and the loss of "
                f"{', '.join(losses)} grow alike (~ A^{top}): their constants decide whether "
                "the energy is held")
        return EnergyBalance(False, True, top, gains, losses, tuple(terms), text)
    text = (f"at large amplitude A the loss of {', '.join(losses)} (~ A^{top}) outgrows the "
            "bounded noise input and every gain")
    return EnergyBalance(False, False, top, (), losses, tuple(terms), text)


def _decided(tail: Tail, degree: int, gains: tuple[str, ...], losses: tuple[str, ...],
             terms: tuple[tuple[str, int, int], ...]) -> EnergyBalance:
    """The verdict of a parametric tie from its tail (vifpk.core.energy)."""
    law = f"the averaged energy's law decays as E^-{tail.kappa:.3g} at large E"
    mean = "" if tail.mean_finite else ("; its mean energy is infinite (the averaged law's E[H]: "
                                        "kappa <= 2)")
    if not tail.top_losses:
        where = (f"beyond E ~ {tail.crossover:.3g}" if tail.crossover
                 else "beyond an energy too small for double precision" if tail.crossover == 0.0
                 else "at large amplitude")
        verdict = ("no stationary law strictly: the law describes the motion below that "
                   "energy (metastable)" if not tail.normalisable else "a stationary law exists")
        text = (f"the parametric noise ({', '.join(gains)}) outgrows every loss {where}: {law}, "
                f"{verdict}{mean}")
        return EnergyBalance(False, True, degree, gains, (), terms, text, tail)
    if not tail.normalisable:
        text = (f"the parametric noise ({', '.join(gains)}) outweighs the losses of the same "
                f"degree ({', '.join(losses)}): {law} (kappa <= 1), so there is no stationary "
                "law")
        return EnergyBalance(True, False, degree, gains, losses, terms, text, tail)
    text = (f"the losses ({', '.join(losses)}) hold the parametric noise ({', '.join(gains)}) "
            f"of the same degree: {law} (kappa > 1){mean}")
    return EnergyBalance(False, False, degree, gains, losses, terms, text, tail)


def _limit(wall: Any) -> float:
    """The wall's restitution as |v| -> inf, as its law declares it (ImpactLaw.limit): what
    impacts do to the energy at large amplitude (below 1: they take energy)."""
    from .result import BadInput

    law = registry.impact_law(wall.law)
    if not callable(getattr(law, "limit", None)):
        raise BadInput(f"impact law {wall.law!r} lacks the piece 'limit' "
                       "(vifpk.core.protocols.ImpactLaw): its energy balance is unknown")
    return float(law.limit(*(v for _, v in wall.params)))
def tail_note(system: Any, parametric: Any) -> str | None:
    """What a solved law under parametric noise must say beside its numbers (issue 45), from
    its tail (:func:`parametric_tail`): with no stationary law strictly (the noise outgrows
    every loss beyond a crossover energy) the law is the metastable one below that energy,
    and it says where; with kappa <= 2 the mean energy is infinite (paper-base with D_c =
    0.1: kappa = 7/6), so a mean taken on a grid is that of the truncated law. None
    otherwise."""
    tail = parametric_tail(system, parametric)
    if tail is None:
        return None
    law = f"the averaged energy's law decays as E^-{tail.kappa:.3g} at large E"
    if not tail.normalisable and tail.crossover:
        return (f"no stationary law strictly: the parametric noise outgrows every loss beyond "
                f"E ~ {tail.crossover:.3g} ({law}); the law given is the metastable one of the "
                "motion below that energy (the closed form's grid ends before it)")
    if not tail.mean_finite:
        return (f"{law} (kappa <= 2): its mean energy is infinite; the moments given are "
                "those of the law on the closed form's grid (its mass outside is the grid's "
                "tail mass)")
    return None
