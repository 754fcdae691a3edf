"""The walls as the averaged models see them (issue 37): position, restitution law, losses.

A lower wall at a <= 0 (x >= a) and/or an upper wall at b >= 0 (x <= b), each with its own
impact law (vifpk/physics/impact/: e(v), and the energy an impact at speed v takes,
(1 - e(v)^2) v^2 / 2). On the orbit of energy E (amplitude A, U(A) = E) a wall at ``at`` is
reached when A > |at|, and is then hit once per period T(E) of the truncated orbit at the
impact speed v = sqrt(2 (E - U(at))) (docs/averaging.md, "Walls anywhere").

The paper's wall (one lower wall at 0 with Newton's law) keeps its own path in the models
(the transformed coordinate y, x = |y|: averaging/exact.py), bit for bit as before.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from vifpk.core.registry import IMPACT_TREATMENTS, one_of
from vifpk.physics import impact, spring

SOLVER = "averaging"


@dataclass(frozen=True, kw_only=True)
class WallSpec:
    """One wall: ``side`` "lower" (x >= at, at <= 0) or "upper" (x <= at, at >= 0), its
    impact ``law`` (a registered vifpk.core.protocols.ImpactLaw) and the law's parameter
    values ``params`` in declared order."""

    side: str
    at: float
    law: str = "newton"
    params: tuple[float, ...] = (1.0,)

    def __post_init__(self) -> None:
        self.module()  # a law that is not registered: one line, now

    @classmethod
    def of(cls, side: str, at: float, law: str = "newton", **values: float) -> WallSpec:
        """A wall with its law's parameters by name (declared order; defaults for the
        others; a name the law does not declare raises ValueError)."""
        params = impact.law(law, solver=SOLVER).params
        extra = set(values) - {p.name for p in params}
        if extra:
            raise ValueError(f"impact law {law!r} has no parameter {sorted(extra)[0]!r}")
        return cls(side=side, at=at, law=law,
                   params=tuple(float(values.get(p.name, p.default)) for p in params))

    def module(self) -> Any:
        """The law (vifpk.physics.impact.law); NoLaw naming law and solver."""
        return impact.law(self.law, solver=SOLVER)

    @property
    def constant(self) -> bool:
        """Whether the law declares e constant (vifpk.core.protocols.ImpactLaw.constant)."""
        return bool(self.module().constant)

    @property
    def r(self) -> float:
        """e at impact speed 0 (a constant law's e; Newton's and Johnson's r)."""
        return float(self.module().restitution(0.0, *self.params))

    def energy_loss(self, v: Any) -> np.ndarray:
        """(1 - e(v)^2) v^2 / 2 at impact speeds v, elementwise (the law's scalar
        ``energy_loss``, the one the Monte Carlo's walls compile, over the array)."""
        f = np.vectorize(self.module().energy_loss, otypes=[float])
        return f(v, *self.params)

    def restitution(self, v: Any) -> np.ndarray:
        """e(v) at impact speeds v, elementwise (the law's scalar ``restitution``)."""
        f = np.vectorize(self.module().restitution, otypes=[float])
        return f(v, *self.params)


def walls_of(system: Any) -> tuple[WallSpec, ...]:
    """The scene's walls, lower first (``system.walls``, vifpk.core.scene: the wall tables of
    issue 37, or the paper's ``barrier`` with ``r``), each with its law's parameters."""
    return tuple(WallSpec(side=w.side, at=float(w.at), law=w.law,
                          params=tuple(float(v) for _, v in w.params))
                 for w in system.walls)


def is_paper_wall(walls: tuple[WallSpec, ...]) -> bool:
    """One lower wall at x = 0 whose law DECLARES a constant restitution
    (ImpactLaw.constant; Newton's): the paper's system, whose closed forms take e = r.
    Decided by the declaration, never by a parameter's value or the law's name: a law with
    a speed-dependent e and no yield speed is not Newton's."""
    return (len(walls) == 1 and walls[0].side == "lower" and walls[0].at == 0.0
            and walls[0].constant)


def phase_walls(system: Any) -> dict[str, Any]:
    """The keywords of averaging.phase.phase_densities for a scene's system: ``barrier`` (the
    paper's wall: the folded coordinate x = |y|), ``lower`` and ``upper`` (any other walls;
    -inf / +inf for none)."""
    walls = walls_of(system)
    paper = is_paper_wall(walls)
    lower, upper = span(() if paper else walls)
    return {"barrier": paper, "lower": lower, "upper": upper}


def span(walls: tuple[WallSpec, ...]) -> tuple[float, float]:
    """(a, b): the lower wall's position (-inf without one) and the upper's (+inf)."""
    lo = [w.at for w in walls if w.side == "lower"]
    hi = [w.at for w in walls if w.side == "upper"]
    return (lo[0] if lo else -math.inf), (hi[0] if hi else math.inf)


def reached(A: np.ndarray, wall: WallSpec) -> np.ndarray:
    """Whether the free orbit of amplitude A reaches the wall (A > |at|)."""
    return A > abs(wall.at)


def loss_rate(walls: tuple[WallSpec, ...], A: np.ndarray, E: np.ndarray, T: np.ndarray,
              k: tuple[float, ...], treatment: str) -> np.ndarray:
    """-(1/T) sum over the walls reached of the energy one impact takes at the impact speed
    v = sqrt(2 K), K = E - U(at) (each reached wall is hit once per period T of the truncated
    orbit), in the exact model's ``treatment`` (vifpk.core.registry.IMPACT_TREATMENTS): "exact" the
    law's (1 - e(v)^2) K; "transformed" 2 (1 - e(v)) K; "compounded" -ln(e(v)^2) K (the
    continuous limit of K -> e^2 K at each impact). A wall at 0 alone with Newton's law gives
    the paper's (2/T_y)(1 - r^2) E (T_y = 2 T: two impacts per period of y)."""
    loss = np.zeros_like(A)
    for w in walls:
        K = np.maximum(E - spring.potential(w.at, k), 0.0)
        v = np.sqrt(2.0 * K)
        if treatment == "exact":
            per = w.energy_loss(v)
        elif treatment == "transformed":
            per = 2.0 * (1.0 - w.restitution(v)) * K
        elif treatment == "compounded":
            per = -np.log(w.restitution(v) ** 2) * K
        else:
            one_of("impact", treatment, IMPACT_TREATMENTS)  # raises: a treatment without a branch
        loss = loss - np.where(reached(A, w), per / T, 0.0)
    return loss
