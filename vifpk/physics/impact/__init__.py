"""Impact laws: one module each (``newton.py``, ``johnson.py``), names in
``vifpk.core.registry.IMPACT_LAW_NAMES``.

A law's module declares:

- ``restitution(speed, r, v_yield)``: the coefficient of restitution e at impact speed
  |v| = ``speed`` (plain Python on floats: numba compiles it in the Monte Carlo);
- ``energy_loss(speed, r, v_yield)``: the kinetic energy one impact at that speed removes,
  (1 - e^2) v^2 / 2.

``law(name)`` returns the module or raises ``NoLaw`` in one line.
"""

from __future__ import annotations

from importlib import import_module
from types import ModuleType

from vifpk.core.registry import IMPACT_LAW_NAMES


class NoLaw(ValueError):
    """An impact law without a module. One line."""


def law(name: str) -> ModuleType:
    """The module of impact law ``name`` (vifpk.physics.impact.<name>)."""
    if name not in IMPACT_LAW_NAMES:
        raise NoLaw(f"impact law {name!r} is not registered (known: "
                    f"{', '.join(IMPACT_LAW_NAMES)})")
    try:
        return import_module(f"vifpk.physics.impact.{name}")
    except ModuleNotFoundError:
        raise NoLaw(f"impact law {name!r} has no module vifpk.physics.impact.{name}") from None
