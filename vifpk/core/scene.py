"""Scenes: a frozen description of one physical system, read from TOML.

A scene switches physics on and off and says what to compute. Its format is documented in
``docs/scenes.md``. Every field is validated on load; a bad value raises :class:`SceneError`
whose message is one line naming the field and its allowed range (the CLI prints it and exits
with code 2).

The system (Liu, Xu, Yue & Huang, Symmetry 2019, 11(1):4, eq. 17)::

    x'' + (c2 x^2 - c1) x' + omega0^2 x + alpha x^3 + mu sgn(x') = f xi(t),   x > 0
    x'(+) = -r x'(-)  at the barrier x = 0
    xi' + alpha1 xi = W(t),  E[W(t) W(t+s)] = 2 D delta(s)      (kind = "ou")
    xi = W(t)                                                     (kind = "white")
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import re
import tomllib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

from .registry import NOISE_KINDS
from .result import BadInput
from .walls import Parametric, Wall, check_walls, wall_from_table


class SceneError(BadInput):
    """A scene that cannot be used; the message is one line naming the field."""


# --------------------------------------------------------------------------------------------
# range checks: each returns None when the value is fine, else the allowed range in words
Check = Callable[[Any], "str | None"]


def _finite(v: float) -> str | None:
    return None if math.isfinite(v) else "a finite number"


def _positive(v: float) -> str | None:
    return None if math.isfinite(v) and v > 0 else "a finite number > 0"


def _nonneg(v: float) -> str | None:
    return None if math.isfinite(v) and v >= 0 else "a finite number >= 0"


def _tail(v: float) -> str | None:
    """The probability mass the amplitude grid may leave beyond A_max: a small tolerance (a
    tail of 0.5 would cut half the density off the grid)."""
    return None if math.isfinite(v) and 0.0 < v <= 1e-3 else "0 < tail <= 0.001"


def _floor(v: float) -> str | None:
    """A target L1 noise floor: an L1 distance between densities is at most 2."""
    return None if math.isfinite(v) and 0.0 <= v < 2.0 else "0 <= floor < 2 (0: none)"


def _wall(v: Any) -> str | None:
    return None if v is None or isinstance(v, Wall) else "a table (vifpk.core.walls)"


def _restitution(v: float) -> str | None:
    return None if math.isfinite(v) and 0 < v <= 1 else "0 < r <= 1"


def _int_at_least(lo: int) -> Check:
    def check(v: Any) -> str | None:
        ok = isinstance(v, int) and not isinstance(v, bool) and v >= lo
        return None if ok else f"a whole number >= {lo}"

    return check


def _int_between(lo: int, hi: int) -> Check:
    def check(v: Any) -> str | None:
        ok = isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi
        return None if ok else f"a whole number from {lo} to {hi}"

    return check


def _one_of(*allowed: str) -> Check:
    def check(v: Any) -> str | None:
        return None if v in allowed else "one of " + ", ".join(repr(a) for a in allowed)

    return check


def _bool(v: Any) -> str | None:
    return None if isinstance(v, bool) else "true or false"


def _auto_or(check: Check) -> Check:
    def auto(v: Any) -> str | None:
        if v == "auto":
            return None
        if isinstance(v, bool) or not isinstance(v, int | float):
            return '"auto" or ' + (check(float("nan")) or "a number")
        problem = check(float(v))
        return None if problem is None else f'"auto" or {problem}'

    return auto


def _meta(check: Check, doc: str) -> dict[str, Any]:
    return {"check": check, "doc": doc}


# --------------------------------------------------------------------------------------------
MAX_TERMS = 10  # polynomial laws: up to 10 coefficients (a restoring force of degree 19)


def _coefficients(allow_empty: bool) -> Check:
    def check(v: Any) -> str | None:
        ok = (isinstance(v, tuple) and (allow_empty or len(v) >= 1) and len(v) <= MAX_TERMS
              and all(isinstance(c, float) and math.isfinite(c) for c in v))
        lo = 0 if allow_empty else 1
        return None if ok else f"a list of {lo} to {MAX_TERMS} finite numbers"

    return check


# the paper's names of polynomial coefficients: name -> (law, index, value -> coefficient)
ALIASES: dict[str, tuple[str, int, Callable[[float], float]]] = {
    "omega0": ("restoring", 0, lambda v: v * v),
    "alpha": ("restoring", 1, lambda v: v),
    "c1": ("damping", 0, lambda v: -v),
    "c2": ("damping", 1, lambda v: v),
}


@dataclass(frozen=True, kw_only=True)
class System:
    """Oscillator parameters. ``barrier = false`` removes the impact wall. The general system
    (issue 21; the paper's eq. 17 is d = -c1 + c2 x^2, g = omega0^2 x + alpha x^3, e = 0)::

        x'' + (d0 + d2 x^2 + d4 x^4 + ...) x' + (e2 x'^2 + e4 x'^4 + ...) x'
            + k1 x + k3 x^3 + k5 x^5 + ... + mu sgn(x') = f xi(t)

    ``restoring = [k1, k3, ...]``, ``damping = [d0, d2, ...]``, ``velocity_damping =
    [e2, e4, ...]``; the paper's names are the same coefficients (k1 = omega0^2, k3 = alpha,
    d0 = -c1, d2 = c2) and a scene gives one spelling of each law. The law actually used is
    :attr:`restoring_law`, :attr:`damping_law`, :attr:`velocity_law`; a paper name is None
    when its law is given as a list."""

    c1: float | None = field(default=0.025, metadata=_meta(
        _finite, "negative: positive linear damping (d0 = -c1)"))
    c2: float | None = field(default=0.05, metadata=_meta(
        _nonneg, "Van der Pol cubic damping (d2 = c2)"))
    omega0: float | None = field(default=1.0, metadata=_meta(
        _positive, "linear natural frequency (k1 = omega0^2)"))
    alpha: float | None = field(default=0.6, metadata=_meta(
        _nonneg, "Duffing hardening (k3 = alpha)"))
    restoring: tuple[float, ...] = field(default=(), metadata=_meta(
        _coefficients(False), "[k1, k3, k5, ...]: g(x) = k1 x + k3 x^3 + ...; g > 0 on x > 0 "
        "and the last non-zero k > 0"))
    damping: tuple[float, ...] = field(default=(), metadata=_meta(
        _coefficients(False), "[d0, d2, ...]: force (d0 + d2 x^2 + ...) x'; d0 > 0 dissipates"))
    velocity_damping: tuple[float, ...] = field(default=(), metadata=_meta(
        _coefficients(True), "[e2, e4, ...]: Rayleigh force (e2 x'^2 + e4 x'^4 + ...) x'"))
    mu: float = field(default=0.001, metadata=_meta(_nonneg, "Coulomb friction amplitude"))
    r: float | None = field(default=0.96, metadata=_meta(_restitution, "restitution at x = 0"))
    f: float = field(default=1.0, metadata=_meta(_finite, "noise gain (not given in paper)"))
    barrier: bool | None = field(default=True, metadata=_meta(_bool, "impact barrier at x = 0"))
    lower_wall: Wall | None = field(default=None, metadata=_meta(
        _wall, "[system.lower_wall]: at <= 0, r, law, v_yield (vifpk.core.walls)"))
    upper_wall: Wall | None = field(default=None, metadata=_meta(
        _wall, "[system.upper_wall]: at >= 0, r, law, v_yield (vifpk.core.walls)"))

    def __post_init__(self) -> None:
        # a law given as a list: its paper names do not apply (None, never a stale default)
        if self.restoring:
            object.__setattr__(self, "omega0", None)
            object.__setattr__(self, "alpha", None)
        if self.damping:
            object.__setattr__(self, "c1", None)
            object.__setattr__(self, "c2", None)
        lo, up = self.lower_wall, self.upper_wall
        if lo is not None and up is None and lo.at == 0.0 and lo.law == "newton":
            # the paper's wall spelled as a table: one meaning, one spelling (r, barrier)
            object.__setattr__(self, "r", lo.r)
            object.__setattr__(self, "barrier", True)
            object.__setattr__(self, "lower_wall", None)
        elif lo is not None or up is not None:
            # walls given as tables: the old spelling does not apply (None, never stale)
            object.__setattr__(self, "r", None)
            object.__setattr__(self, "barrier", None)

    @property
    def walls(self) -> tuple[Wall, ...]:
        """Every wall, lower first: the tables, or the paper's wall at x = 0 (``barrier`` with
        restitution ``r``, Newton's law), or none."""
        if self.r is not None:
            return (Wall(side="lower", at=0.0, r=self.r),) if self.barrier else ()
        return tuple(w for w in (self.lower_wall, self.upper_wall) if w is not None)

    def walls_problem(self) -> str | None:
        """None when the walls are the paper's (at most one, at x = 0, Newton's law), else
        what they are, in words (for a solver or model that covers the paper's wall only)."""
        if self.r is not None:
            return None
        named = "; ".join(f"system.{w.side}_wall at {w.at:g} ({w.law})" for w in self.walls)
        return f"walls other than one at x = 0 with Newton's law ({named})"

    @property
    def restoring_law(self) -> tuple[float, ...]:
        """(k1, k3, k5, ...) of g(x) = k1 x + k3 x^3 + ... (k1 = omega0^2, k3 = alpha)."""
        if self.restoring:
            return self.restoring
        assert self.omega0 is not None and self.alpha is not None
        return (self.omega0**2, self.alpha)

    @property
    def damping_law(self) -> tuple[float, ...]:
        """(d0, d2, ...) of the force (d0 + d2 x^2 + ...) x' (d0 = -c1, d2 = c2)."""
        if self.damping:
            return self.damping
        assert self.c1 is not None and self.c2 is not None
        return (-self.c1, self.c2)

    @property
    def velocity_law(self) -> tuple[float, ...]:
        """(e2, e4, ...) of the force (e2 x'^2 + e4 x'^4 + ...) x' (empty: none)."""
        return self.velocity_damping

    def paper_family_problem(self) -> str | None:
        """None when the system is in the family of the paper's averaged model (a cubic
        spring with k1 > 0, damping -c1 + c2 x^2, no velocity damping), else why not."""
        k = _trim(self.restoring_law)
        d = _trim(self.damping_law)
        if len(k) > 2:
            return (f"system.restoring has a x^{2 * len(k) - 1} term; the paper's model "
                    "covers only g = omega0^2 x + alpha x^3")
        if not k or k[0] <= 0.0 or (len(k) > 1 and k[1] < 0.0):
            return ("the paper's model needs omega0 > 0 and alpha >= 0 (k1 > 0, k3 >= 0); "
                    f"system.restoring = {list(self.restoring_law)}")
        if len(d) > 2:
            return (f"system.damping has a x^{2 * len(d) - 2} x' term; the paper's model "
                    "covers only (c2 x^2 - c1) x'")
        if len(d) > 1 and d[1] < 0.0:
            return "the paper's model needs c2 >= 0 (d2 >= 0)"
        if any(e != 0.0 for e in self.velocity_law):
            return "system.velocity_damping is set; the paper's model has no velocity damping"
        walls = self.walls_problem()
        if walls is not None:
            return f"{walls}: the paper's model has one wall at x = 0 with Newton's law"
        return None

    def to_dict(self) -> dict[str, Any]:
        """The keys as given: a law as a list, or by its paper names (never both)."""
        out: dict[str, Any] = {}
        for f in fields(self):
            v = getattr(self, f.name)
            if v is None or (isinstance(v, tuple) and not v):
                continue
            out[f.name] = (list(v) if isinstance(v, tuple) else
                           v.to_dict() if isinstance(v, Wall) else v)
        return out


def _trim(c: tuple[float, ...]) -> tuple[float, ...]:
    """Coefficients without trailing zeros."""
    n = len(c)
    while n and c[n - 1] == 0.0:
        n -= 1
    return tuple(c[:n])


def restoring_problem(k: tuple[float, ...]) -> str | None:
    """None when g(x) = k1 x + k3 x^3 + ... gives one well: U grows without bound (the last
    non-zero k > 0) and g(x) > 0 for every x > 0 (no other equilibrium, so every energy has
    one orbit around x = 0); else why not, in words. g(x) = x P(x^2) with P(y) = k1 + k3 y +
    ...: P's real roots y > 0 (numpy.roots, imaginary part below 1e-9 of the modulus) are the
    zeros of g."""
    import numpy as np

    t = _trim(k)
    if not t:
        return "all coefficients are 0 (no spring: no orbit to average over)"
    if t[-1] < 0.0:
        return (f"U(x) does not grow without bound (the x^{2 * len(t) - 1} coefficient "
                f"{t[-1]:g} < 0: a softening spring with no bound lets the mass escape); "
                "allowed: the last non-zero coefficient > 0")
    if t[0] < 0.0:
        return f"k1 = {t[0]:g} < 0 makes x = 0 unstable; allowed: k1 >= 0"
    roots = np.roots(list(reversed(t))) if len(t) > 1 else np.array([])
    y = [r.real for r in roots if abs(r.imag) <= 1e-9 * abs(r) and r.real > 0.0]
    if t[0] == 0.0:
        nz = next(c for c in t if c != 0.0)
        if nz < 0.0:
            return "the lowest non-zero coefficient is < 0: x = 0 is unstable"
    if y:
        x = math.sqrt(min(y))
        return (f"g(x) vanishes at x = {x:.4g} (a second equilibrium: the spring softens "
                "through its bound); allowed: g(x) > 0 for every x > 0")
    return None


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
    A^{3n+3}. A "johnson" wall loses (1 - e^2) -> 1 of the energy at high impact speed even
    with r = 1. Parametric noises (``parametric``: the scene's section) feed energy that
    grows with the amplitude (D_k <g(x)^2>, D_c <d(x)^2 x'^2>); they are counted as gains of
    their degree that never decide alone: at or above the top loss they make a ``tie`` (the
    averaged model decides), since a multiplicative noise also spreads the law without
    making its mean energy grow.
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
        if w.r < 1.0 or w.law == "johnson":
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


@dataclass(frozen=True, kw_only=True)
class Noise:
    """Excitation xi(t): OU ("real") noise with bandwidth alpha1, or Gaussian white noise."""

    kind: str = field(default="ou", metadata=_meta(_one_of(*NOISE_KINDS), "noise model"))
    D: float = field(default=0.01, metadata=_meta(_positive, "intensity: E[W W] = 2 D delta"))
    alpha1: float = field(default=2.0, metadata=_meta(_positive, "OU bandwidth"))


@dataclass(frozen=True, kw_only=True)
class AveragingSettings:
    """Numerical settings of the averaged models (closed form and exact orbit averages)."""

    points: int = field(default=801, metadata=_meta(_int_at_least(17), "grid points in A"))
    tail: float = field(default=1e-10, metadata=_meta(_tail, "mass allowed beyond A_max"))
    theta_nodes: int = field(default=64, metadata=_meta(_int_at_least(8), "GL nodes a quarter"))
    harmonics: int = field(default=24, metadata=_meta(_int_at_least(4), "orbit harmonics"))
    # at most 4001: memory grows as phase_points^2 (12.7 GB and 53 s measured at 20001)
    phase_points: int = field(default=201, metadata=_meta(_int_between(17, 4001),
                                                          "x1, x2 grids"))


@dataclass(frozen=True, kw_only=True)
class MonteCarloSettings:
    """Monte Carlo of the original system: the one set of defaults (montecarlo.Settings has
    none); the study behind them is in docs/montecarlo.md."""

    paths: int = field(default=1024, metadata=_meta(_int_at_least(2), "independent paths"))
    dt: float | str = field(default=0.01, metadata=_meta(
        _auto_or(_positive), 'time step, or "auto": from the target floor'))
    time: float = field(default=2000.0, metadata=_meta(_positive, "sampled time per path"))
    burn_in: float | str = field(default="auto", metadata=_meta(
        _auto_or(_nonneg), 'time before sampling, or "auto": 6 x the measured relaxation time'))
    sample_every: float = field(default=0.5, metadata=_meta(_positive, "sampling interval"))
    seed: int = field(default=20190101, metadata=_meta(_int_at_least(0), "root seed"))
    blocks: int = field(default=32, metadata=_meta(_int_at_least(2), "batches of paths"))
    # at most 100000: far past what a histogram of 1e9 samples resolves
    bins: int = field(default=100, metadata=_meta(_int_between(4, 100_000), "histogram bins"))
    threads: int = field(default=0, metadata=_meta(_int_at_least(0), "0: all cores"))
    floor: float = field(default=0.0, metadata=_meta(
        _floor, "target L1 noise floor of p(A); 0: sample exactly `time`"))
    budget: float = field(default=600.0, metadata=_meta(
        _nonneg, "wall seconds allowed to reach the floor; 0: no limit"))


@dataclass(frozen=True, kw_only=True)
class Observables:
    """What the Monte Carlo records (unrequested ones are not computed)."""

    A: bool = field(default=True, metadata=_meta(_bool, "histogram of the amplitude"))
    x1: bool = field(default=True, metadata=_meta(_bool, "histogram of displacement"))
    x2: bool = field(default=True, metadata=_meta(_bool, "histogram of velocity"))
    joint: bool = field(default=False, metadata=_meta(_bool, "2-D histogram of (x1, x2)"))
    moments: bool = field(default=True, metadata=_meta(_bool, "means and second moments"))
    events: bool = field(default=True, metadata=_meta(_bool, "impacts, sticking, chatter"))
    energy: bool = field(default=False, metadata=_meta(_bool, "stationary power balance"))

    def names(self) -> tuple[str, ...]:
        return tuple(f.name for f in fields(self) if getattr(self, f.name))


SECTIONS: dict[str, type] = {
    "system": System,
    "noise": Noise,
    "parametric": Parametric,
    "averaging": AveragingSettings,
    "montecarlo": MonteCarloSettings,
    "observables": Observables,
}
SWEEPABLE = {"system", "noise", "parametric"}
#: the system's wall tables (vifpk.core.walls): "system.lower_wall.at" and so on
WALL_TABLES = {"lower_wall": "lower", "upper_wall": "upper"}


@dataclass(frozen=True, kw_only=True)
class Sweep:
    """One parameter varied over a list of values (the paper's figures)."""

    section: str
    key: str
    values: tuple[float, ...]

    @property
    def path(self) -> str:
        return f"{self.section}.{self.key}"


@dataclass(frozen=True, kw_only=True)
class Scene:
    """One system, its noise, and solver settings. Immutable; use :meth:`with_values`."""

    name: str = "scene"
    description: str = ""
    system: System = field(default_factory=System)
    noise: Noise = field(default_factory=Noise)
    parametric: Parametric = field(default_factory=Parametric)
    averaging: AveragingSettings = field(default_factory=AveragingSettings)
    montecarlo: MonteCarloSettings = field(default_factory=MonteCarloSettings)
    observables: Observables = field(default_factory=Observables)
    sweep: Sweep | None = None
    source: str = ""
    #: "section.key" of every value the scene was given (its file, with_values, --set), as
    #: opposed to a default: e.g. whether a time step was asked for (harness.request.prepare)
    given: frozenset[str] = field(default=frozenset(), compare=False)

    # ---------------------------------------------------------------- sweeps
    def variants(self) -> list[Scene]:
        """The concrete scenes of a sweep (or ``[self]``), each with ``sweep = None``."""
        if self.sweep is None:
            return [self]
        out = []
        for v in self.sweep.values:
            s = self.with_values({self.sweep.path: v})
            out.append(replace(s, name=f"{self.name}[{self.sweep.key}={v:g}]", sweep=None))
        return out

    def with_values(self, values: Mapping[str, Any]) -> Scene:
        """A copy with ``{"section.key": value}`` overrides, validated like a file."""
        raw = self.to_dict()
        raw.pop("sweep", None)
        for path, value in values.items():
            section, _, key = path.partition(".")
            if section not in SECTIONS or not key:
                raise SceneError(f"{path}: unknown field; use section.key with a section in "
                                 f"{sorted(SECTIONS)}")
            if section == "system":
                _set_system(raw.setdefault("system", {}), path, key, value)
            else:
                raw.setdefault(section, {})[key] = value
        if self.sweep is not None and self.sweep.path not in values:
            raw[self.sweep.section][self.sweep.key] = list(self.sweep.values)
        new = scene_from_dict(raw, source=self.source or "<overrides>")
        return replace(new, given=self.given | {_field_of(p) for p in values})

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-ready dictionary (the ``scene`` entry of the solution JSON)."""
        d: dict[str, Any] = {"name": self.name, "description": self.description}
        for sec in SECTIONS:
            if sec == "parametric" and not self.parametric.on:
                continue  # off: the paper's scenes keep their dictionary (and hash)
            d[sec] = (self.system.to_dict() if sec == "system"
                      else dataclasses.asdict(getattr(self, sec)))
        if self.sweep is not None:
            d["sweep"] = {"field": self.sweep.path, "values": list(self.sweep.values)}
            d[self.sweep.section][self.sweep.key] = list(self.sweep.values)
        return d


def no_noise(system: Any) -> str | None:
    """The f = 0 rule, in its one wording (every workflow and solver says it so, adding what
    it means there): None when the system is driven by noise."""
    if system.f == 0.0:
        return ("f = 0: there is no noise, so no stationary density exists (the amplitude "
                "relaxes to a deterministic attractor)")
    return None


# --------------------------------------------------------------------------------------------
INDEXED = re.compile(r"(\w+)\[(\d+)\]")


def _field_of(path: str) -> str:
    """"section.key" of a dotted path, without a law index ("system.restoring[2]" ->
    "system.restoring")."""
    section, _, key = path.partition(".")
    m = INDEXED.fullmatch(key)
    return f"{section}.{m.group(1) if m else key}"


def law_term(key: str) -> tuple[str, int | None] | None:
    """The law and coefficient that ``system.NAME`` sets: ("damping", 1) for ``system.c2``
    and ``system.damping[1]``, ("restoring", None) for the whole ``system.restoring``; None
    for a key that sets no law."""
    section, _, name = key.strip().partition(".")
    if section != "system":
        return None
    m = INDEXED.fullmatch(name)
    if name in ALIASES:
        return ALIASES[name][0], ALIASES[name][1]
    if m:
        return m.group(1), int(m.group(2))
    laws = {law for law, _, _ in ALIASES.values()} | {"velocity_damping"}
    return (name, None) if name in laws else None


def shared_term(keys: Sequence[str]) -> tuple[str, str, str] | None:
    """The first two of ``keys`` that reach one coefficient of a law under different
    spellings (``system.c2`` and ``system.damping[1]``; a whole law and any of its terms):
    (the earlier key, the later key, the law), or None. The one rule for ``--set`` and for
    a sweep's [vary] and [set] (a scene file refuses both spellings the same way)."""
    reach: dict[tuple[str, int | None], str] = {}
    for key in keys:
        target = law_term(key)
        if target is None:
            continue
        law, index = target
        for (lw, ix), earlier in reach.items():
            if lw == law and (ix is None or index is None or ix == index):
                return earlier, key, law
        reach[target] = key
    return None


def _set_system(raw: dict[str, Any], path: str, key: str, value: Any) -> None:
    """Apply ``system.key = value`` to a raw system table. ``key`` may index a law
    ("restoring[2]": the k5 coefficient; the list grows with zeros) or be a paper name; either
    spelling works whichever one the scene was written in."""
    table, dot, sub = key.partition(".")
    if dot:
        if table not in WALL_TABLES:
            raise SceneError(f"{path}: unknown field; only {sorted(WALL_TABLES)} have "
                             "sub-keys (e.g. system.lower_wall.at)")
        if table not in raw and not any(t in raw for t in WALL_TABLES):
            # the paper's wall (r, barrier) becomes a table, so one spelling stays
            if raw.pop("barrier", True):
                raw["lower_wall"] = {"at": 0.0, "r": raw.pop("r", System.r)}
            raw.pop("r", None)
        wall = dict(raw.get(table) or {})
        wall[sub] = value
        raw[table] = wall
        return
    m = INDEXED.fullmatch(key)
    name, index = (m.group(1), int(m.group(2))) if m else (key, None)
    laws = {law for law, _, _ in ALIASES.values()} | {"velocity_damping"}
    if index is not None and name not in laws:
        raise SceneError(f"{path}: only {sorted(laws)} take an index")
    if name in ALIASES and ALIASES[name][0] in raw:
        law, index, to_coefficient = ALIASES[name]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SceneError(f"{path} = {value!r} must be a finite number")
        _coerce(path, System, name, float(value))
        name, value = law, to_coefficient(float(value))
    if name in laws:
        names = [a for a, (law, _, _) in ALIASES.items() if law == name]
        if any(a in raw for a in names):  # written with the paper's names: convert
            sys_ = scene_from_dict({"system": raw}, source=path).system
            raw[name] = list(sys_.restoring_law if name == "restoring" else sys_.damping_law)
            for a in names:
                raw.pop(a, None)
        if index is None:
            raw[name] = value
            return
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SceneError(f"{path} = {value!r} must be a finite number")
        coeffs = list(raw.get(name, []))
        if index >= MAX_TERMS:
            raise SceneError(f"{path}: index out of range; allowed: 0 to {MAX_TERMS - 1}")
        coeffs += [0.0] * (index + 1 - len(coeffs))
        coeffs[index] = float(value)
        raw[name] = coeffs
        return
    raw[name] = value


def _suggest(word: str, options: list[str]) -> str:
    close = difflib.get_close_matches(word, options, n=1, cutoff=0.5)
    if close:
        return f"did you mean '{close[0]}'?"
    return "allowed: " + ", ".join(options)


def _coerce(where: str, cls: type, name: str, value: Any) -> Any:
    """Validate one value; ``where`` is "file: section.key" (with [i] for list entries)."""
    f = next(f for f in fields(cls) if f.name == name)
    check: Check = f.metadata["check"]
    if isinstance(f.default, tuple):  # a polynomial law: a list of numbers
        if not isinstance(value, list | tuple):
            raise SceneError(f"{where} = {value!r} must be {check(None)}")
        for i, c in enumerate(value):
            if isinstance(c, bool) or not isinstance(c, int | float) or not math.isfinite(c):
                raise SceneError(f"{where}[{i}] = {c!r} must be a finite number")
        value = tuple(float(c) for c in value)
    elif isinstance(f.default, bool):
        pass
    elif f.metadata["check"].__name__ == "auto":  # a number or "auto"
        if isinstance(value, int | float) and not isinstance(value, bool):
            value = float(value)
    elif isinstance(f.default, float):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SceneError(f"{where} = {value!r} must be {check(float('nan'))}")
        value = float(value)
    elif (isinstance(f.default, int) and isinstance(value, float) and value.is_integer()
          and abs(value) < 2.0**63):
        value = int(value)  # 1e8 is a whole number: its size is for the range and the cost
    problem = check(value)
    if problem is not None:
        shown = list(value) if isinstance(value, tuple) else value
        raise SceneError(f"{where} = {shown!r} is out of range; allowed: {problem}")
    return value


def check_value(where: str, section: str, key: str, value: Any) -> Any:
    """One value of ``section.key`` validated as in a scene file (SceneError naming ``where``,
    e.g. a command-line option, with the allowed range); the value as the scene stores it."""
    return _coerce(where, SECTIONS[section], key, value)


def scene_from_dict(raw: Mapping[str, Any], *, source: str = "<dict>") -> Scene:
    """Build and validate a Scene from a parsed TOML document."""
    top = {"name", "description", *SECTIONS}
    for key in raw:
        if key == "sweep" and isinstance(raw[key], Mapping) and set(raw[key]) <= {"field",
                                                                                 "values"}:
            continue  # written by Scene.to_dict beside the varied list; the list rules
        if key not in top:
            raise SceneError(f"{source}: unknown key '{key}'; {_suggest(key, sorted(top))}")
    name = raw.get("name", Path(source).stem if source else "scene")
    if not isinstance(name, str) or not name:
        raise SceneError(f"{source}: name must be a non-empty string")
    description = raw.get("description", "")
    if not isinstance(description, str):
        raise SceneError(f"{source}: description must be a string")

    sweep: Sweep | None = None
    parts: dict[str, Any] = {}
    for sec, cls in SECTIONS.items():
        table = raw.get(sec, {})
        if not isinstance(table, Mapping):
            raise SceneError(f"{source}: [{sec}] must be a table")
        known = [f.name for f in fields(cls)]
        kwargs: dict[str, Any] = {}
        if cls is System:
            _check_wall_spelling(f"{source}: system", table)
        for key, value in table.items():
            where = f"{source}: {sec}"
            if key not in known:
                raise SceneError(f"{where}.{key}: unknown key; {_suggest(key, known)}")
            if cls is System and key in WALL_TABLES:
                try:
                    kwargs[key] = wall_from_table(f"{where}.{key}", WALL_TABLES[key], value)
                except SceneError:
                    raise
                except BadInput as e:
                    raise SceneError(str(e)) from None
                continue
            if isinstance(value, list) and not isinstance(
                    next(f for f in fields(cls) if f.name == key).default, tuple):
                if sec not in SWEEPABLE:
                    raise SceneError(f"{where}.{key}: a list is only allowed in "
                                     f"{sorted(SWEEPABLE)} (the varied parameter)")
                if sweep is not None:
                    raise SceneError(f"{where}.{key}: only one parameter may vary; "
                                     f"{sweep.path} already does")
                if not value:
                    raise SceneError(f"{where}.{key}: the list of values is empty")
                vals = tuple(_coerce(f"{where}.{key}[{i}]", cls, key, v)
                             for i, v in enumerate(value))
                if not all(isinstance(v, float) for v in vals):
                    raise SceneError(f"{where}.{key}: only numeric parameters can vary")
                sweep = Sweep(section=sec, key=key, values=vals)
                kwargs[key] = vals[0]
            else:
                kwargs[key] = _coerce(f"{where}.{key}", cls, key, value)
        if cls is System:
            _check_laws(f"{source}: system", table, kwargs)
            try:
                check_walls(f"{source}: system", kwargs.get("lower_wall"),
                            kwargs.get("upper_wall"))
            except BadInput as e:
                raise SceneError(str(e)) from None
        if cls is AveragingSettings:
            _check_harmonics(f"{source}: averaging", kwargs)
        parts[sec] = cls(**kwargs)
    given = frozenset(f"{sec}.{key}" for sec in SECTIONS
                      if isinstance(raw.get(sec), Mapping) for key in raw[sec])
    return Scene(name=name, description=description, sweep=sweep, source=source, given=given,
                 **parts)


def _check_wall_spelling(where: str, table: Mapping[str, Any]) -> None:
    """One spelling of the walls: the tables, or the paper's ``r`` and ``barrier``."""
    tables = [t for t in WALL_TABLES if t in table]
    old = [k for k in ("r", "barrier") if k in table]
    if tables and old:
        raise SceneError(f"{where}.{old[0]} and {where.split(': ')[-1]}.{tables[0]} both set "
                         f"the walls; give one spelling (a wall table has its own r; "
                         f"barrier = false is no table)")


def _check_laws(where: str, table: Mapping[str, Any], kwargs: Mapping[str, Any]) -> None:
    """One spelling per law; the restoring law gives one well (restoring_problem)."""
    for name, (law, index, _) in ALIASES.items():
        if name in table and law in table:
            raise SceneError(f"{where}.{name} and {where.split(': ')[-1]}.{law} both set the "
                             f"{law} law; give one (the paper's {name} is the coefficient "
                             f"{law}[{index}] = {_alias_formula(name)})")
    k = kwargs.get("restoring") or (kwargs.get("omega0", 1.0) ** 2, kwargs.get("alpha", 0.6))
    if isinstance(kwargs.get("alpha"), list | tuple) or isinstance(kwargs.get("omega0"),
                                                                   list | tuple):
        return  # a sweep: each value is checked by Scene.variants
    problem = restoring_problem(tuple(k))
    if problem is not None:
        key = "restoring" if "restoring" in table else "alpha"
        raise SceneError(f"{where}.{key} = {list(k) if key == 'restoring' else kwargs.get(key)}"
                         f": {problem}")


#: the most points x theta_nodes an averaging grid may have: the exact model's orbit averages
#: hold points x 2 theta_nodes numbers at once (100001 x 64: 3.1 GB peak, 76 s measured; the
#: shipped default is 801 x 64 = 5.1e4)
AVERAGING_SIZE = 6_500_000


def _check_harmonics(where: str, kwargs: Mapping[str, Any]) -> None:
    """The exact model's orbit harmonics are integrals over a quarter orbit by Gauss-Legendre
    with theta_nodes nodes; harmonic n = 2 * harmonics turns through harmonics * pi there.
    Measured (paper-base and a pure quintic spring, A = 1 and 2): up to 3/4 of the nodes
    sigma_E^2 keeps 1e-10 or better; at 1.5 x the nodes it is wrong by 1e-3 and the harmonic
    sum goes negative. So harmonics <= 3 theta_nodes / 4."""
    h = kwargs.get("harmonics", AveragingSettings.harmonics)
    t = kwargs.get("theta_nodes", AveragingSettings.theta_nodes)
    n = kwargs.get("points", AveragingSettings.points)
    if isinstance(n, int) and isinstance(t, int) and n * t > AVERAGING_SIZE:
        raise SceneError(f"{where}.points x theta_nodes = {n} x {t} = {n * t:.3g} is too "
                         f"large: the orbit averages hold points x 2 theta_nodes numbers at "
                         f"once (3.1 GB of memory measured at 100001 x 64); allowed: up to "
                         f"{AVERAGING_SIZE:.3g}")
    if isinstance(h, int) and isinstance(t, int) and 4 * h > 3 * t:
        raise SceneError(f"{where}.harmonics = {h} is more than theta_nodes = {t} resolve; "
                         f"allowed: at most 3/4 of theta_nodes ({3 * t // 4}); raise "
                         f"theta_nodes to {-(-4 * h // 3)} or more with it")


def _alias_formula(name: str) -> str:
    return {"omega0": "omega0^2", "alpha": "alpha", "c1": "-c1", "c2": "c2"}[name]


def shipped_scenes() -> Traversable:
    """The shipped scenes: package data ``vifpk.scenes`` (the repository's top-level
    ``scenes/``, mapped into the wheel by pyproject.toml), read with importlib.resources. In a
    source checkout on ``sys.path`` that is not installed, the repository's ``scenes/``."""
    try:
        return resources.files("vifpk.scenes")
    except ModuleNotFoundError:
        return Path(__file__).resolve().parents[2] / "scenes"


def shipped_name(text: str) -> bool:
    """True when ``text`` is the name of a shipped scene rather than a path: relative, no
    ``.toml`` suffix, no ``.``/``..``/``~`` parts ("paper-base", "hard/r-low"). A path is a
    path: one that does not exist is an error, never a shipped scene of the same name."""
    parts = text.split("/")
    return bool(text) and not text.endswith(".toml") and not text.startswith(("/", "~")) \
        and all(part and not part.startswith(".") for part in parts) and "\\" not in text


def shipped_names() -> list[str]:
    """The names of the shipped scenes (``hard/...`` included; sweeps excluded)."""
    root = shipped_scenes()
    out = []
    for entry in sorted(root.iterdir(), key=lambda e: e.name):
        if entry.is_file() and entry.name.endswith(".toml"):
            out.append(entry.name[:-5])
        elif entry.is_dir() and entry.name == "hard":
            out += [f"hard/{e.name[:-5]}" for e in sorted(entry.iterdir(), key=lambda e: e.name)
                    if e.name.endswith(".toml")]
    return out


def find_scene(path: str | Path | Traversable) -> Path | Traversable | None:
    """The file a scene path or name stands for, as :func:`load_scene` reads it: the path
    itself when it is a file, else the shipped scene of that bare name (:func:`shipped_name`,
    in :func:`shipped_scenes`); None when there is none."""
    p: Path | Traversable = path if isinstance(path, Traversable) else Path(path)
    if p.is_file():
        return p
    text = str(path)
    if isinstance(path, Traversable) and not isinstance(path, Path) or not shipped_name(text):
        return None
    where = shipped_scenes()
    for part in f"{text}.toml".split("/"):  # one part at a time: a namespace
        where = where / part                # package's MultiplexedPath takes one
    return where if where.is_file() else None


def load_scene(path: str | Path | Traversable) -> Scene:
    """Read a scene file, or a shipped scene by its bare name ("paper-base", "hard/r-low";
    see :func:`shipped_name`). A path (anything ending in ``.toml``, absolute, or starting
    with ``.``) must exist: a wrong path is an error, not another scene of that name. Raises
    :class:`SceneError` (one line) on any problem."""
    p: Path | Traversable = path if isinstance(path, Traversable) else Path(path)
    if not is_toml_file(p, SceneError, "scene"):
        found = find_scene(path)
        if found is None:
            text = str(path)
            if isinstance(path, Traversable) and not isinstance(path, Path) \
                    or not shipped_name(text):
                raise SceneError(f"{path}: no such scene file")
            names = shipped_names()
            close = difflib.get_close_matches(text, names, n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'?" if close else "shipped: " + ", ".join(names)
            raise SceneError(f"{path}: no such scene file or shipped scene; {hint}")
        p = found
    return scene_from_dict(read_toml(p)[1], source=p.name)


def is_toml_file(p: Path | Traversable, error: type[SceneError], what: str) -> bool:
    """Whether ``p`` is an existing file (False: not there, so maybe a shipped name);
    ``error`` (one line) when it is a folder or cannot even be looked at (e.g. a name longer
    than the file system allows). ``what``: "scene" or "sweep", for the message."""
    try:
        is_dir, is_file = p.is_dir(), p.is_file()
    except OSError as exc:
        raise error(f"{str(p)[:80]}: cannot read ({exc.strerror or exc})") from None
    if is_dir:
        raise error(f"{p}: is a folder; give a {what} file (.toml)")
    return is_file


def read_toml(p: Path | Traversable, error: type[SceneError] = SceneError
              ) -> tuple[str, dict[str, Any]]:
    """The text and the parsed TOML of a scene or sweep file (a UTF-8 BOM is fine); ``error``
    (one line naming the file) when it cannot be read or parsed, deep nesting included."""
    try:
        text = p.read_text(encoding="utf-8-sig")
        return text, tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{p.name}: not valid TOML: {exc}") from None
    except RecursionError:
        raise error(f"{p.name}: not valid TOML: arrays or tables nested too deeply") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{p.name}: cannot read: {exc}") from None
