"""The scene's walls and parametric noise: data and validation only (issue 37).

A system may have a lower wall at x = a <= 0 (the motion keeps x >= a) and an upper wall at
x = b >= 0 (x <= b), each with its own impact law::

    [system.lower_wall]   # x >= at; at <= 0 (the paper's wall: at = 0)
    at = -0.3
    r = 0.9               # 0 < r <= 1
    law = "newton"        # IMPACT_LAW_NAMES
    v_yield = 0.5         # the laws that take it (registry.IMPACT_LAW_PARAMS): "johnson"

The impact laws (their physics lives in ``vifpk.physics``; here only their names and
parameters):

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

import difflib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .registry import IMPACT_LAW_NAMES, IMPACT_LAW_PARAMS
from .result import BadInput

#: the sides a wall can be on, and the sign its position must have
SIDES = {"lower": ("<=", "x >= at"), "upper": (">=", "x <= at")}
WALL_KEYS = ("at", "r", "law", "v_yield")


@dataclass(frozen=True, kw_only=True)
class Wall:
    """One rigid wall: ``side`` "lower" (the motion keeps x >= at) or "upper" (x <= at), its
    position ``at``, restitution ``r`` and impact ``law`` (``v_yield``: the speed parameter
    of a law that takes one, registry.IMPACT_LAW_PARAMS; None for "newton")."""

    side: str
    at: float
    r: float = 1.0
    law: str = "newton"
    v_yield: float | None = None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"at": self.at, "r": self.r, "law": self.law}
        if self.v_yield is not None:
            out["v_yield"] = self.v_yield
        return out


def shown(v: float) -> str:
    """A number as the user wrote it: %g where that reads back as the same float and is no
    longer than Python's shortest round-trip text, else that text (1.0000001 is not "1",
    5e-324 not "4.94066e-324"); -0 is 0."""
    if v == 0.0:
        return "0"
    g, r = f"{v:g}", repr(float(v))
    return g if float(g) == v and len(g) <= len(r) else r


def unknown_key(where: str, key: str, known: tuple[str, ...]) -> str:
    """The one line for an unknown key of a table: the nearest known key (case ignored:
    "AT" is "at"), else the list."""
    lower = {k.lower(): k for k in known}
    close = difflib.get_close_matches(str(key).lower(), list(lower), n=1, cutoff=0.5)
    hint = f"did you mean '{lower[close[0]]}'?" if close else "allowed: " + ", ".join(known)
    return f"{where}.{key}: unknown key; {hint}"


def _number(where: str, value: Any, allowed: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise BadInput(f"{where} = {value!r} must be a finite number; allowed: {allowed}")
    return float(value)


def wall_from_table(where: str, side: str, table: Any) -> Wall:
    """A validated Wall from a scene's ``[system.<side>_wall]`` table; ``where`` names it
    ("file: system.lower_wall") in the one-line error."""
    if isinstance(table, Wall):
        if table.side != side:
            raise BadInput(f"{where}: a {table.side} wall given as the {side} wall")
        table = table.to_dict()
    if not isinstance(table, Mapping):
        raise BadInput(f"{where} must be a table with keys {', '.join(WALL_KEYS)}")
    for key in table:
        if key not in WALL_KEYS:
            raise BadInput(unknown_key(where, key, WALL_KEYS))
    if "at" not in table:
        raise BadInput(f"{where}.at is missing: the wall's position ({SIDES[side][1]})")
    sign, _ = SIDES[side]
    at = _number(f"{where}.at", table["at"], f"a number {sign} 0") + 0.0  # -0 is 0
    if (side == "lower" and at > 0.0) or (side == "upper" and at < 0.0):
        raise BadInput(f"{where}.at = {shown(at)} is out of range; allowed: {sign} 0 (the {side} "
                       f"wall keeps {SIDES[side][1]} and the equilibrium x = 0 inside)")
    r = _number(f"{where}.r", table.get("r", 1.0), "0 < r <= 1")
    if not 0.0 < r <= 1.0:
        raise BadInput(f"{where}.r = {shown(r)} is out of range; allowed: 0 < r <= 1")
    law = table.get("law", "newton")
    if law not in IMPACT_LAW_NAMES:
        raise BadInput(f"{where}.law = {law!r}: impact law must be one of "
                       f"{IMPACT_LAW_NAMES}")
    v_yield = table.get("v_yield")
    if "v_yield" in IMPACT_LAW_PARAMS[law]:
        if v_yield is None:
            raise BadInput(f"{where}.v_yield is missing: the {law} law needs a yield "
                           "speed > 0")
        v_yield = _number(f"{where}.v_yield", v_yield, "> 0")
        if v_yield <= 0.0:
            raise BadInput(f"{where}.v_yield = {shown(v_yield)} is out of range; allowed: > 0")
    elif v_yield is not None:
        takes = " | ".join(f'"{n}"' for n, p in IMPACT_LAW_PARAMS.items() if "v_yield" in p)
        raise BadInput(f"{where}.v_yield applies to law = {takes} only, not {law!r}")
    return Wall(side=side, at=at, r=r, law=law, v_yield=v_yield)


def check_walls(where: str, lower: Wall | None, upper: Wall | None) -> None:
    """Two walls leave room between them: a < b (a <= 0 <= b each)."""
    if lower is not None and upper is not None and not lower.at < upper.at:
        raise BadInput(f"{where}.lower_wall.at = {shown(lower.at)} and upper_wall.at = "
                       f"{shown(upper.at)} leave no room; allowed: lower at < upper at")


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
