"""Newton's impact law: the rebound speed is r times the impact speed, e(v) = r (0 < r <= 1).

Energy an impact at speed v takes: (1 - r^2) v^2 / 2. The functions are plain arithmetic on a
float or a numpy array (numba compiles them on scalars). ``LAW`` is the declared object
(vifpk.core.protocols.ImpactLaw), registered in vifpk's pyproject.toml (``vifpk.impact_laws``).
"""

from __future__ import annotations

from typing import Any

from vifpk.core.protocols import ImpactLawSpec, Param

#: the coefficient of restitution every law with an ``r`` declares so (the paper's wall)
R = Param(name="r", default=1.0, low=0.0, high=1.0, physical=False,
          doc="coefficient of restitution: rebound speed / impact speed")


def restitution(v: Any, r: float) -> Any:
    """e(v) = r for every impact speed."""
    return r + 0.0 * v


def energy_loss(v: Any, r: float) -> Any:
    """(1 - r^2) v^2 / 2: the kinetic energy lost in one impact at speed v."""
    return (1.0 - r * r) * (0.5 * v * v)


def limit(r: float) -> float:
    """e as |v| -> inf: r."""
    return r


#: e does not depend on the impact speed (the paper's law: its models' closed forms use it)
LAW = ImpactLawSpec(name="newton", summary="Newton's restitution: e(v) = r", params=(R,),
                    constant=True, restitution=restitution, energy_loss=energy_loss,
                    limit=limit)
