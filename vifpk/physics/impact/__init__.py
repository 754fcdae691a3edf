"""Impact laws, one module each (``law = "newton" | "johnson"`` of a wall): the restitution
e(v) at impact speed v and the kinetic energy an impact takes, (1 - e(v)^2) v^2 / 2."""

from __future__ import annotations

import importlib
from types import ModuleType

#: law name -> module (vifpk.core.registry.IMPACT_LAW_NAMES)
MODULES = {"newton": "vifpk.physics.impact.newton", "johnson": "vifpk.physics.impact.johnson"}


def module(law: str, *, solver: str) -> ModuleType:
    """The module of impact law ``law``; ValueError naming law and solver if there is none."""
    name = MODULES.get(law)
    if name is None:
        raise ValueError(f"impact law {law!r} is not available in the {solver} solver "
                         f"(laws with a module: {', '.join(sorted(MODULES))})")
    return importlib.import_module(name)
