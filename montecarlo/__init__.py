"""numba Monte Carlo of the original non-smooth vibro-impact system (impacts, stick-slip,
OU or white noise), and of an averaged 1-D amplitude SDE. Imports no other vifpk package.

The first-passage, transient and averaged-SDE drivers load on first use (PEP 562), so a
stationary run neither imports them nor declares their kernels. (``plan`` and ``simulate``
are imported here: they share their names with their modules, which a lazy attribute would
let the submodules shadow.)
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

from .plan import Plan, physics, plan, sampling_plan, step_size
from .simulate import (
                       OBSERVABLES,
                       BudgetExhausted,
                       Settings,
                       SimulationDiverged,
                       block_seeds,
                       effects,
                       simulate,
)

_LAZY = {
    "PassageSettings": "passage", "StartRejected": "passage", "first_passage": "passage",
    "sample_starts": "passage",
    "sde_first_passage": "sde_time", "sde_snapshots": "sde_time",
    "snapshots": "transient",
}

__all__ = ["OBSERVABLES", "BudgetExhausted", "PassageSettings", "Plan", "Settings",
           "SimulationDiverged", "StartRejected", "block_seeds", "effects", "first_passage",
           "physics", "plan", "sample_starts", "sampling_plan", "sde_first_passage",
           "sde_snapshots", "simulate", "snapshots", "step_size"]


def __getattr__(name: str) -> Any:
    home = _LAZY.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f"{__name__}.{home}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
