"""Noise kinds: one module each (``ou.py``, ``white.py``), and the registry.

A kind's module declares, for the Monte Carlo (solver "montecarlo"), names prefixed ``mc_``:

- ``MCRecord``: the NamedTuple of the step's coefficients (montecarlo appends its fields, named
  with the kind's prefix, to the kernels' physics record, whose class then selects the kind's
  compiled pieces when a kernel is specialised; the pieces' ``rec`` is that whole record, so
  they may read its ``f``);
- ``mc_record(noise, f, h)``: the coefficients for excitation amplitude f and step h (written
  once);
- ``mc_start_sd(noise)``: the standard deviation of the noise state's stationary law (None: no
  state);
- ``mc_bridge(noise, f)``: None, or the variance rate per v^2 of the energy at the kick (the
  Brownian-bridge crossing correction of first passage: white noise's 2 D f^2);
- ``mc_input_power(noise, f)``: None, or the exact mean power the noise puts in (white: f^2 D);
- (the compiled pieces take no annotations: numba matches their parameters to the generic
  functions of montecarlo/pieces.py by name)
- ``mc_press(rec, xi)``: the noise force pressing the mass onto a wall over the step (minus the
  force held on it);
- ``mc_velocity(flow, normal)`` -> the velocity stage B of the step (see montecarlo/kernels.py);
- ``mc_advance(normal)`` -> the noise state's update after the step;
- ``mc_energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi)``: (work of the noise, damping loss,
  friction loss) over the stage B.

For the averaged models (solver "averaging"), names prefixed ``avg_`` (averaging/noise.py):
``avg_spectral_density(omega, D=, alpha1=)`` (two-sided S(w)); either ``avg_flat_level`` (a
white spectrum: S the same at every w) or ``avg_rational_parts`` (c, a2 with
w^2 S = c - a2 S, the OU identity); ``avg_correlation_rate`` (1 / correlation time), if any.
For the original system's Fokker-Planck solver (solver "fpk2d", issue 46), names prefixed
``fp_``: ``fp_velocity_diffusion(noise, f)``, the constant B0 of the diffusion B0 d^2p/dv^2
the excitation adds (white: D f^2); a kind with a state of its own (OU) has none.
The parametric white noises (``parametric.py``) are no kind of the excitation: the averaged
models import that module directly.

``piece(kind, solver, name)`` returns one of them or raises ``NoPiece`` in one line.
"""

from __future__ import annotations

from importlib import import_module
from types import ModuleType
from typing import Any

from vifpk.core.registry import NOISE_KINDS

SOLVER_PREFIX = {"montecarlo": "mc_", "averaging": "avg_", "fpk2d": "fp_"}


class NoPiece(ValueError):
    """A noise kind without the piece a solver needs. One line."""


def module(kind: str) -> ModuleType:
    """The module of a registered noise kind (vifpk.physics.noise.<kind>)."""
    if kind not in NOISE_KINDS:
        raise NoPiece(f"noise kind {kind!r} is not registered (known: {', '.join(NOISE_KINDS)})")
    try:
        return import_module(f"vifpk.physics.noise.{kind}")
    except ModuleNotFoundError:
        raise NoPiece(f"noise kind {kind!r} has no module vifpk.physics.noise.{kind}") from None


def piece(kind: str, solver: str, name: str) -> Any:
    """The piece ``name`` (e.g. "record") of noise kind ``kind`` for ``solver``."""
    attr = SOLVER_PREFIX.get(solver, "") + name if name != "MCRecord" else name
    try:
        got = getattr(module(kind), attr, None)
    except NoPiece as e:
        raise NoPiece(f"{e}: the {solver} solver cannot take it") from None
    if got is None:
        raise NoPiece(f"noise kind {kind!r} has no {solver} piece {attr!r}: the {solver} "
                      "solver cannot take it")
    return got


def kinds_with(solver: str, name: str) -> tuple[str, ...]:
    """The registered kinds that have the piece (the Monte Carlo registers their kernels)."""
    attr = SOLVER_PREFIX.get(solver, "") + name if name != "MCRecord" else name
    out = []
    for kind in NOISE_KINDS:
        try:
            if getattr(module(kind), attr, None) is not None:
                out.append(kind)
        except NoPiece:
            continue
    return tuple(out)
