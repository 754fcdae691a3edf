"""Noise kinds: declared objects (vifpk.core.protocols.NoiseKind), one module each (``ou.py``,
``white.py``), registered by entry point (``vifpk.noise_kinds``, vifpk.core.registry) as
another package's kind is; and the one check of a kind's pieces a solver needs.

A solver asks :func:`pieces` for a kind's pieces: the kind's ``averaging``
(vifpk.core.protocols.AveragingNoise) or ``montecarlo`` (MonteCarloNoise) record, checked at
first use for every piece that solver requires; a kind without them raises :class:`NoPiece`
(a BadInput: exit 2 on the command line) in one line naming the kind and the solver, before
any work. Nothing here looks a piece up by a name prefix or decides by a kind's name.

The parametric white noises (``parametric.py``) are no kind of the excitation: the averaged
models import that module directly.
"""

from __future__ import annotations

from dataclasses import MISSING, fields
from typing import Any

from vifpk.core import registry
from vifpk.core.protocols import AveragingNoise, FPK2DNoise, MonteCarloNoise
from vifpk.core.result import BadInput

#: the record each solver reads of a kind, and the pieces of it that solver cannot do without
SOLVERS: dict[str, tuple[str, type, tuple[str, ...]]] = {
    "averaging": ("averaging", AveragingNoise, ("spectral_density",)),
    "montecarlo": ("montecarlo", MonteCarloNoise,
                   tuple(f.name for f in fields(MonteCarloNoise) if f.default is MISSING)),
    "fpk2d": ("fpk2d", FPK2DNoise, ("velocity_diffusion",)),
}


class NoPiece(BadInput):
    """A noise kind without the pieces a solver needs (or not registered). One line."""


def kind(name: str) -> Any:
    """The registered noise kind ``name`` (NoPiece in one line when there is none)."""
    try:
        return registry.noise_kind(name)
    except registry.UnknownName as e:
        raise NoPiece(str(e)) from None


def _label(name: str) -> str:
    e = registry.physics_entry("noise kind", name)
    return f"noise kind {name!r}" + ("" if e.builtin else f" (from {e.distribution})")


def _pieces(name: str, solver: str) -> Any:
    attr, cls, required = SOLVERS[solver]
    got = getattr(kind(name), attr, None)
    if got is None:
        raise NoPiece(f"{_label(name)} has no {solver} pieces: the {solver} solver cannot "
                      "take it")
    missing = [p for p in required if not callable(getattr(got, p, None))]
    if missing:
        raise NoPiece(f"{_label(name)} lacks the {solver} piece {missing[0]!r} "
                      f"(vifpk.core.protocols.{cls.__name__}): the {solver} solver cannot "
                      "take it")
    return got


def pieces(name: str, solver: str) -> Any:
    """The kind's pieces for ``solver`` ("averaging", "montecarlo" or "fpk2d"), checked; NoPiece
    naming kind and solver when it has none or lacks a required one."""
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {tuple(SOLVERS)}, not {solver!r}")
    return _pieces(name, solver)


def kinds_with(solver: str, piece: str | None = None) -> tuple[str, ...]:
    """The registered kinds that have ``solver``'s pieces (and the optional ``piece``)."""
    out = []
    for name in registry.noise_kind_names():
        try:
            got = pieces(name, solver)
        except NoPiece:
            continue
        if piece is None or getattr(got, piece, None) is not None:
            out.append(name)
    return tuple(out)

