"""An elastic-plastic impact law (Johnson, Contact Mechanics, 1985, sec. 11.4): below the yield
speed the restitution is r, above it falls as v^(-1/4),

    e(v) = r                         for |v| <= v_yield,
    e(v) = r (v_yield / |v|)^(1/4)   above.

r = 1 is elastic below yield; v_yield -> inf is Newton's law. Energy an impact at speed v
takes: (1 - e(v)^2) v^2 / 2. Plain arithmetic on floats or numpy arrays (numba compiles it).
``LAW`` is the declared object (vifpk.core.protocols.ImpactLaw).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from vifpk.core.protocols import ImpactLawSpec, Param
from vifpk.physics.impact.newton import R


def restitution(v: Any, r: float, v_yield: float) -> Any:
    """e(v) = r min(1, (v_yield / |v|)^(1/4)) (r at v = 0)."""
    q = v_yield / np.maximum(np.abs(v), 1e-300)  # no division by 0 (numba's default model)
    return r * np.minimum(1.0, np.sqrt(np.sqrt(q)))


def energy_loss(v: Any, r: float, v_yield: float) -> Any:
    """(1 - e(v)^2) v^2 / 2: the kinetic energy lost in one impact at speed v."""
    e = restitution(v, r, v_yield)
    return (1.0 - e * e) * (0.5 * v * v)


def limit(r: float, v_yield: float) -> float:
    """e as |v| -> inf: 0 (impacts take energy at large amplitude even with r = 1)."""
    return 0.0


#: e depends on the impact speed above v_yield
LAW = ImpactLawSpec(
    name="johnson", summary="elastic-plastic: e = r min(1, (v_yield / |v|)^(1/4))",
    params=(R, Param(name="v_yield", low=0.0, doc="yield speed: e falls as v^(-1/4) above")),
    constant=False, restitution=restitution, energy_loss=energy_loss, limit=limit)
