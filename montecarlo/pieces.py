"""The compiled pieces of the physics (vifpk.physics), chosen when a kernel is specialised.

Each noise kind's module (vifpk/physics/noise/<kind>.py) declares its Monte Carlo pieces as
plain Python; here they become numba overloads of four generic functions keyed by the class of
the kind's record (``MCRecord``), so a kernel written once calls ``noise_velocity(rec, ...)`` and
numba compiles the kind the record belongs to (and nothing of the others). A record class
without pieces fails to compile naming it; ``make_record`` raises before any compilation for a
kind without Monte Carlo pieces (physics.noise.NoPiece, one line naming kind and solver).
"""

from __future__ import annotations

from collections import namedtuple
from typing import Any

from numba.extending import overload

from vifpk.physics import noise as noise_kinds

SOLVER = "montecarlo"

#: The kernels' physics record, flat (numba's parallel loops take no tuple nested in a tuple):
#: these fields, then the noise kind's own (its MCRecord's). A switched-off effect is None
#: (mu, r, khi, dhi, ev, bridge): numba compiles a specialisation per record type and, where
#: a helper takes the field as an argument, prunes the effect's code.
BASE_FIELDS = ("c1", "c2", "w0sq", "alpha", "f", "mu", "r", "khi", "dhi", "ev",
               "bridge",  # first passage's bridge correction (mc_bridge; None: none)
               "xi_sd")  # the noise state's stationary standard deviation (0: no state)

_CLASSES: dict[str, type] = {}  # noise kind -> its record class
_PIECES: dict[type, Any] = {}  # record class -> the kind's module


def record_class(kind: str) -> type:
    """The record class of a noise kind: BASE_FIELDS + the kind's MCRecord fields (a module
    global ``Record_<kind>``, so numba's cache can name it). NoPiece for a kind without
    Monte Carlo pieces."""
    if kind not in _CLASSES:
        fields = noise_kinds.piece(kind, SOLVER, "MCRecord")._fields
        cls = namedtuple(f"Record_{kind}", BASE_FIELDS + tuple(fields))  # noqa: PYI024
        cls.__module__ = __name__
        globals()[cls.__name__] = cls
        _CLASSES[kind] = cls
        _PIECES[cls] = noise_kinds.module(kind)
    return _CLASSES[kind]


def make_record(noise: Any, base: tuple[Any, ...], h: float) -> Any:
    """The record: ``base`` (BASE_FIELDS' values) and the kind's coefficients for step h."""
    return record_class(noise.kind)(*base, *noise_kinds.piece(noise.kind, SOLVER, "record")(
        noise, base[BASE_FIELDS.index("f")], h))


for _kind in noise_kinds.kinds_with(SOLVER, "record"):
    record_class(_kind)


def _module_of(rec_type: Any) -> Any:
    cls = getattr(rec_type, "instance_class", None)
    if cls not in _PIECES:
        raise TypeError(f"no Monte Carlo noise pieces for a record of type {rec_type}")
    return _PIECES[cls]


# the generic functions (their bodies are never run by Python: numba uses the overloads)
def noise_press(rec, xi):  # pragma: no cover
    raise NotImplementedError


def noise_velocity(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):  # pragma: no cover
    raise NotImplementedError


def noise_advance(rec, xi, s0, s1, s2, s3):  # pragma: no cover
    raise NotImplementedError


def noise_energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi):  # pragma: no cover
    raise NotImplementedError


@overload(noise_press)
def _ol_press(rec, xi):
    return _module_of(rec).mc_press


@overload(noise_velocity)
def _ol_velocity(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):
    from .kernels import velocity_flow
    from .rng import normal
    return _module_of(rec).mc_velocity(velocity_flow, normal)


@overload(noise_advance)
def _ol_advance(rec, xi, s0, s1, s2, s3):
    from .rng import normal
    return _module_of(rec).mc_advance(normal)


@overload(noise_energy)
def _ol_energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi):
    return _module_of(rec).mc_energy
