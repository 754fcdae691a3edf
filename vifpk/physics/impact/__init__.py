"""Impact laws, one module each (a wall's ``law``: the names and the parameters each takes are
vifpk.core.registry.IMPACT_LAW_PARAMS): the restitution e(v) at impact speed v and the kinetic
energy an impact takes, (1 - e(v)^2) v^2 / 2."""

from __future__ import annotations

import importlib
from types import ModuleType

from vifpk.core.registry import IMPACT_LAW_NAMES

#: law name -> its module: one module a registered law (vifpk.core.registry.IMPACT_LAW_NAMES)
MODULES = {name: f"vifpk.physics.impact.{name}" for name in IMPACT_LAW_NAMES}


class NoLaw(ValueError):
    """An impact law without a module. One line."""


def module(law: str, *, solver: str) -> ModuleType:
    """The module of impact law ``law``; NoLaw naming law and solver if there is none."""
    name = MODULES.get(law)
    if name is None:
        raise NoLaw(f"impact law {law!r} is not available in the {solver} solver "
                    f"(laws with a module: {', '.join(sorted(MODULES))})")
    return importlib.import_module(name)


def law(name: str) -> ModuleType:
    """The module of impact law ``name``; NoLaw if there is none (the caller names itself)."""
    found = MODULES.get(name)
    if found is None:
        raise NoLaw(f"impact law {name!r} has no module (laws with a module: "
                    f"{', '.join(sorted(MODULES))})")
    return importlib.import_module(found)
