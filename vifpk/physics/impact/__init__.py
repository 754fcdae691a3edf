"""Impact laws: declared objects (vifpk.core.protocols.ImpactLaw), one module each
(``newton.py``, ``johnson.py``), registered by entry point (``vifpk.impact_laws``,
vifpk.core.registry) as another package's law is: the restitution e(v; params) at impact
speed v, the kinetic energy an impact takes, (1 - e(v)^2) v^2 / 2, its limit at large speed
and whether e is constant.

:func:`law` returns a registered law, checked at first use for what every solver needs
for what the asking solver calls (REQUIRED; ``constant`` a bool); a law that is not
registered or lacks one raises :class:`NoLaw` (a BadInput: exit 2) in one line naming it and
the solver."""

from __future__ import annotations

from typing import Any

from vifpk.core import registry
from vifpk.core.result import BadInput

#: what each solver calls of a law (``limit``: the scene's energy balance, every run)
REQUIRED = {"montecarlo": ("restitution", "limit"),
            "averaging": ("restitution", "energy_loss", "limit"),
            "fpk2d": ("restitution", "limit")}


class NoLaw(BadInput):
    """An impact law that is not registered or lacks a piece. One line."""


def _law(name: str, solver: str | None) -> Any:
    try:
        obj = registry.impact_law(name)
    except registry.UnknownName as e:
        raise NoLaw(str(e)) from None
    e = registry.physics_entry("impact law", name)
    label = f"impact law {name!r}" + ("" if e.builtin else f" (from {e.distribution})")
    need = REQUIRED.get(solver, ("limit",))
    missing = [p for p in need if not callable(getattr(obj, p, None))]
    if missing:
        raise NoLaw(f"{label} lacks the piece {missing[0]!r} (vifpk.core.protocols.ImpactLaw)")
    if not isinstance(obj.constant, bool):
        raise NoLaw(f"{label}: its 'constant' must be True or False, not {obj.constant!r}")
    return obj


def law(name: str, *, solver: str | None = None) -> Any:
    """The registered impact law ``name``, checked once; NoLaw in one line (naming
    ``solver``, when given, as the one that cannot take it)."""
    try:
        return _law(name, solver)
    except NoLaw as e:
        if solver is None:
            raise
        raise NoLaw(f"{e}: the {solver} solver cannot take it") from None

