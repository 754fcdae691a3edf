"""The scene's walls and parametric noise: data and validation (issue 37).

A system may have a lower wall at x = a <= 0 (the motion keeps x >= a) and an upper wall at
x = b >= 0 (x <= b), each with its own impact law::

    [system.lower_wall]   # x >= at; at <= 0 (the paper's wall: at = 0)
    at = -0.3
    r = 0.9               # 0 < r <= 1
    law = "newton"        # a registered impact law (vifpk.core.registry.impact_law_names)
    v_yield = 0.5         # the law's own parameters, as it declares them: "johnson"

A wall table's keys besides ``at`` and ``law`` are its law's declared parameters
(vifpk.core.protocols.ImpactLaw.params), validated from the declaration. vifpk's own laws
(their physics lives in ``vifpk.physics.impact``):

- ``newton``: x'(+) = -r x'(-) (Newton's restitution), the paper's law;
- ``johnson``: e(v) = r for |v| <= v_yield and r (v_yield / |v|)^(1/4) above: elastic-plastic
  impact, whose coefficient of restitution falls as v^(-1/4) above the yield speed (Johnson,
  *Contact Mechanics*, Cambridge 1985, sec. 11.4). With r = 1 it is elastic below yield;
  v_yield -> infinity is Newton's law.

The old keys keep their meaning: ``system.barrier = true`` (the default) with ``system.r`` is a
lower wall at 0 with Newton's law; a scene that gives a wall table and ``r`` or ``barrier`` is
refused (one spelling, as for the polynomial laws).

Parametric white noises (Stratonovich: the white limit of a physical noise), independent of
the external excitation and of each other::

    x'' + d(x) x' (1 + xi_c) + g(x) (1 + xi_k) + ... = f xi(t)
    E[xi_k(t) xi_k(t+s)] = 2 D_k delta(s),  E[xi_c(t) xi_c(t+s)] = 2 D_c delta(s)

    [parametric]
    stiffness = 0.004   # D_k
    damping = 0.0       # D_c
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from . import registry
from .protocols import show, suggest
from .result import BadInput

#: the sides a wall can be on, and the sign its position must have
SIDES = {"lower": ("<=", "x >= at"), "upper": (">=", "x <= at")}


def wall_keys() -> tuple[str, ...]:
    """Every key a wall table may have: ``at``, ``law``, then each registered law's declared
    parameters (a view of the registry: the laws declare them)."""
    out = ["at", "r", "law"]
    for params in registry.impact_law_params().values():
        out += [p for p in params if p not in out]
    return tuple(out)


@dataclass(frozen=True, kw_only=True)
class Wall:
    """One rigid wall: ``side`` "lower" (the motion keeps x >= at) or "upper" (x <= at), its
    position ``at``, impact ``law`` (a registered vifpk.core.protocols.ImpactLaw) and the
    law's parameter values ``params``, (name, value) in the law's declared order."""

    side: str
    at: float
    law: str = "newton"
    params: tuple[tuple[str, float], ...] = (("r", 1.0),)

    @classmethod
    def of(cls, side: str, at: float, law: str = "newton", **values: float) -> Wall:
        """A wall with its law's parameters by name (in the law's declared order; a missing
        one takes its default). Unvalidated: a scene validates its tables (wall_from_table)."""
        params = registry.impact_law(law).params
        extra = set(values) - {p.name for p in params}
        if extra:
            raise BadInput(f"impact law {law!r} has no parameter {sorted(extra)[0]!r}")
        return cls(side=side, at=at, law=law, params=tuple(
            (p.name, float(values.get(p.name, p.default))) for p in params))

    @property
    def values(self) -> dict[str, float]:
        """The law's parameters by name."""
        return dict(self.params)

    @property
    def r(self) -> float | None:
        """The law's ``r`` (None for a law that declares none)."""
        return self.values.get("r")

    @property
    def v_yield(self) -> float | None:
        """The law's ``v_yield`` (None for a law that declares none)."""
        return self.values.get("v_yield")

    def to_dict(self) -> dict[str, Any]:
        vals = self.values
        out: dict[str, Any] = {"at": self.at}
        if "r" in vals:
            out["r"] = vals.pop("r")
        out["law"] = self.law
        out.update(vals)
        return out


#: a number as the user wrote it (vifpk.core.protocols.show: 1.0000001 is not "1"; -0 is 0)
shown = show


def unknown_key(where: str, key: str, known: tuple[str, ...]) -> str:
    """The one line for an unknown key of a table: the nearest known key (case ignored:
    "AT" is "at"), else the list (vifpk.core.protocols.suggest)."""
    return f"{where}.{key}: unknown key; {suggest(key, known)}"


def _number(where: str, value: Any, allowed: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise BadInput(f"{where} = {value!r} must be a finite number; allowed: {allowed}")
    return float(value)


def wall_from_table(where: str, side: str, table: Any) -> Wall:
    """A validated Wall from a scene's ``[system.<side>_wall]`` table; ``where`` names it
    ("file: system.lower_wall") in the one-line error. The keys besides ``at`` and ``law``
    are the law's declared parameters (vifpk.core.protocols.Param), each checked against its
    declared range, so a plugin's law is validated exactly as vifpk's own."""
    if isinstance(table, Wall):
        if table.side != side:
            raise BadInput(f"{where}: a {table.side} wall given as the {side} wall")
        table = table.to_dict()
    if not isinstance(table, Mapping):
        raise BadInput(f"{where} must be a table with keys at, law and the law's parameters "
                       f"({', '.join(wall_keys())})")
    table = {k: v for k, v in table.items() if v is not None}  # None: not given
    name = table.get("law", "newton")
    try:
        law = registry.impact_law(name)
    except registry.UnknownName as e:
        raise BadInput(f"{where}.law = {name!r}: {e}") from None
    keys = ("at", "law", *(p.name for p in law.params))
    for key in table:
        if key in keys:
            continue
        takes = [n for n, ps in registry.impact_law_params().items() if key in ps]
        if takes:
            raise BadInput(f"{where}.{key} applies to law = "
                           f"{' | '.join(repr(t) for t in takes)} only, not {name!r}")
        raise BadInput(unknown_key(where, key, keys))
    if "at" not in table:
        raise BadInput(f"{where}.at is missing: the wall's position ({SIDES[side][1]})")
    sign, _ = SIDES[side]
    at = _number(f"{where}.at", table["at"], f"a number {sign} 0") + 0.0  # -0 is 0
    if (side == "lower" and at > 0.0) or (side == "upper" and at < 0.0):
        raise BadInput(f"{where}.at = {show(at)} is out of range; allowed: {sign} 0 (the "
                       f"{side} wall keeps {SIDES[side][1]} and the equilibrium x = 0 inside)")
    params = []
    for p in law.params:
        if p.name not in table:
            if p.default is None:
                raise BadInput(f"{where}.{p.name} is missing: the {name} law needs it "
                               f"({p.doc}); allowed: {p.allowed}")
            value = float(p.default)
        else:
            value = _number(f"{where}.{p.name}", table[p.name], p.allowed)
            if p.check(value) is not None:
                raise BadInput(f"{where}.{p.name} = {show(value)} is out of range; allowed: "
                               f"{p.allowed}")
        params.append((p.name, value))
    return Wall(side=side, at=at, law=name, params=tuple(params))


def check_walls(where: str, lower: Wall | None, upper: Wall | None) -> None:
    """Two walls leave room between them: a < b (a <= 0 <= b each)."""
    if lower is not None and upper is not None and not lower.at < upper.at:
        raise BadInput(f"{where}.lower_wall.at = {show(lower.at)} and upper_wall.at = "
                       f"{show(upper.at)} leave no room; allowed: lower at < upper at")


def _nonneg(v: float) -> str | None:
    return None if math.isfinite(v) and v >= 0.0 else "a finite number >= 0"


@dataclass(frozen=True, kw_only=True)
class Parametric:
    """Parametric (multiplicative) Stratonovich white noises on the restoring force and the
    damping: intensities D_k and D_c (0: off)."""

    stiffness: float = field(default=0.0, metadata={
        "check": _nonneg, "doc": "D_k: g(x) (1 + xi_k), E[xi_k xi_k] = 2 D_k delta"})
    damping: float = field(default=0.0, metadata={
        "check": _nonneg, "doc": "D_c: d(x) x' (1 + xi_c), E[xi_c xi_c] = 2 D_c delta"})

    @property
    def on(self) -> bool:
        """Whether any parametric noise is switched on."""
        return self.stiffness > 0.0 or self.damping > 0.0
