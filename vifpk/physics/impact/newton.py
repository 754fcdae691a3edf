"""Newton's impact law: the rebound speed is r times the impact speed, e(v) = r (0 < r <= 1).

Energy an impact at speed v takes: (1 - r^2) v^2 / 2. The functions are plain arithmetic on a
float or a numpy array (numba compiles them on scalars)."""

from __future__ import annotations

from typing import Any

#: e does not depend on the impact speed (the paper's law: its models' closed forms use it)
CONSTANT_RESTITUTION = True


def restitution(v: Any, r: float, v_yield: float) -> Any:
    """e(v) = r for every impact speed (``v_yield`` unused)."""
    return r + 0.0 * v


def energy_loss(v: Any, r: float, v_yield: float) -> Any:
    """(1 - r^2) v^2 / 2: the kinetic energy lost in one impact at speed v."""
    return (1.0 - r * r) * (0.5 * v * v)
