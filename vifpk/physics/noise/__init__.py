"""Noise kinds, one module each; :func:`piece` hands a solver what a kind declares for it.

A kind names a module here; each module declares the pieces each solver needs (for the
averaged models: ``spectral_density`` and, for a spectrum with the rational identity
w^2 S(w) = c - a2 S(w), ``rational_parts``; or ``flat_level`` for a white spectrum). A kind
without a module, or without the piece a solver asks for, raises ValueError in one line naming
the kind and the solver: no solver falls back to another kind.
"""

from __future__ import annotations

import importlib
from types import ModuleType
from typing import Any

#: kind -> module (the scene's noise kinds, vifpk.core.registry.NOISE_KINDS)
MODULES = {"ou": "vifpk.physics.noise.ou", "white": "vifpk.physics.noise.white"}
#: the parametric white noises ([parametric]): not a kind of the external excitation
PARAMETRIC = "vifpk.physics.noise.parametric"


def module(kind: str, *, solver: str) -> ModuleType:
    """The module of noise ``kind``; ValueError naming kind and solver if there is none."""
    name = MODULES.get(kind)
    if name is None:
        raise ValueError(f"noise kind {kind!r} is not available in the {solver} solver "
                         f"(kinds with a module: {', '.join(sorted(MODULES))})")
    return importlib.import_module(name)


def piece(kind: str, name: str, *, solver: str) -> Any:
    """The piece ``name`` that noise ``kind`` declares; ValueError naming kind, piece and
    solver if the kind's module has no such piece."""
    found = getattr(module(kind, solver=solver), name, None)
    if found is None:
        raise ValueError(f"noise kind {kind!r} has no {name} for the {solver} solver")
    return found


def has_piece(kind: str, name: str, *, solver: str) -> bool:
    """Whether noise ``kind`` declares ``name`` (an unknown kind raises as in :func:`module`)."""
    return getattr(module(kind, solver=solver), name, None) is not None
