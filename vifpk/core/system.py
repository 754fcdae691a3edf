"""The oscillator of a scene (``[system]``): its polynomial laws, friction, noise gain and
walls, and the single-well rule of its spring (data and validation only).

The general system (issue 21; the paper's eq. 17 is d = -c1 + c2 x^2, g = omega0^2 x + alpha x^3)::

    x'' + (d0 + d2 x^2 + ...) x' + (e2 x'^2 + ...) x' + k1 x + k3 x^3 + ... + mu sgn(x') = f xi(t)

with the walls of vifpk.core.walls (the paper's: one at x = 0, restitution r).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import Any

from .checks import (
    _bool,
    _coefficients,
    _finite,
    _meta,
    _nonneg,
    _positive,
    _restitution,
    _wall,
)
from .walls import Wall

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
            if not self.barrier:
                return ()
            return (Wall(side="lower", at=0.0, params=(("r", self.r),)),)
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


def _alias_formula(name: str) -> str:
    return {"omega0": "omega0^2", "alpha": "alpha", "c1": "-c1", "c2": "c2"}[name]
