"""The original system's coefficients in (x, v), read from a scene's plain numbers (duck-typed:
``system.restoring_law``, ``noise.kind``, ...; no scene class is imported)::

    x' = v,
    v' = -d(x) v (1 + xi_c) - e(v) v - g(x) (1 + xi_k) - mu sgn(v) + f xi,

xi, xi_k, xi_c independent white noises of intensities D, D_k, D_c (E[xi xi] = 2 D delta),
the parametric ones in Stratonovich's sense (vifpk/physics/noise/parametric.py). The
Fokker-Planck flux in v (Stratonovich: the Ito drift gains + D_c d^2 v, and B's own slope
dB/dv = 2 D_c d^2 v is taken out of the diffusive flux, Risken 1989, eq. 4.45)::

    J_v = (a(x, v) - D_c d(x)^2 v) p - B(x, v) dp/dv,
    a = -d(x) v - e(v) v - g(x) - mu sgn(v),   B = D f^2 + D_k g(x)^2 + D_c d(x)^2 v^2.

The excitation's part of B comes from the noise kind's ``fp_velocity_diffusion`` piece
(vifpk/physics/noise/): a kind without it (OU: its FPK is 3-D in (x, v, xi)) is refused in one
line naming it, before any work. The impact laws come from vifpk/physics/impact/.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from vifpk.core.result import BadInput
from vifpk.physics import impact
from vifpk.physics import noise as noise_kinds
from vifpk.physics.spring import amplitude_of_energy, potential, restoring

#: this solver's name: the words of its refusals, and ``vifpk solve --solver``
SOLVER = "original-fpk"


class Unsupported(BadInput):
    """A scene this solver has no generator for (a noise kind, an impact law); one line
    (exit 2: bad input, found before any work)."""


@dataclass(frozen=True)
class WallMap:
    """One wall as the FPK sees it: position, side (-1 lower: impacts at v < 0; +1 upper),
    and the rebound speed e(s) s of an impact at speed s (vectorised)."""

    at: float
    side: int
    law: str
    r: float
    v_yield: float | None
    rebound: Any

    def loss(self, s: np.ndarray) -> np.ndarray:
        """(1 - e(s)^2) s^2 / 2: the kinetic energy one impact at speed s takes."""
        w = self.rebound(s)
        return 0.5 * (s * s - w * w)


@dataclass(frozen=True)
class Coefficients:
    """Everything the scheme needs of a scene, as numbers and vectorised functions."""

    k: tuple[float, ...]        # restoring law (k1, k3, ...)
    d: tuple[float, ...]        # position damping (d0, d2, ...)
    e: tuple[float, ...]        # velocity damping (e2, e4, ...)
    mu: float
    B0: float                   # the excitation's velocity diffusion (white: D f^2)
    Dk: float
    Dc: float
    walls: tuple[WallMap, ...]

    def g(self, x: Any) -> Any:
        return restoring(x, self.k)

    def U(self, x: Any) -> Any:
        return potential(x, self.k)

    def amplitude(self, E: Any) -> np.ndarray:
        return amplitude_of_energy(E, self.k)

    def damping(self, x: Any) -> Any:
        """d(x) = d0 + d2 x^2 + ... ."""
        return _even_poly(self.d, x)

    def velocity_damping(self, v: Any) -> Any:
        """e(v) = e2 v^2 + e4 v^4 + ... (the force is e(v) v)."""
        return _even_poly((0.0, *self.e), v)

    def smooth_drift(self, x: Any, v: Any) -> Any:
        """The drift of J_v without friction: -d v - e(v) v - g - D_c d^2 v."""
        d = self.damping(x)
        return -d * v - self.velocity_damping(v) * v - self.g(x) - self.Dc * d * d * v

    def diffusion(self, x: Any, v: Any) -> Any:
        """B = D f^2 + D_k g^2 + D_c d^2 v^2."""
        g, d = self.g(x), self.damping(x)
        return self.B0 + self.Dk * g * g + self.Dc * d * d * v * v

    def input_power(self, x: Any, v: Any) -> Any:
        """The Ito drift of H = v^2/2 + U by the noises, pointwise:
        D f^2 + D_k g^2 + 2 D_c d^2 v^2 (vifpk/physics/noise/parametric.py)."""
        g, d = self.g(x), self.damping(x)
        return self.B0 + self.Dk * g * g + 2.0 * self.Dc * d * d * v * v

    def loss_power(self, x: Any, v: Any) -> Any:
        """The power the damping and the friction take, pointwise: d v^2 + e(v) v^2 + mu |v|."""
        return (self.damping(x) + self.velocity_damping(v)) * v * v + self.mu * np.abs(v)


def _even_poly(c: tuple[float, ...], x: Any) -> Any:
    x2 = x * x
    out = 0.0 * x2
    for ci in reversed(c):
        out = out * x2 + ci
    return out


def coefficients(system: Any, noise: Any, parametric: Any = None) -> Coefficients:
    """The scene's coefficients; Unsupported in one line for a noise kind or impact law this
    solver has no generator for, or a scene with no noise in v at rest."""
    try:
        piece = noise_kinds.piece(noise.kind, "fpk2d", "velocity_diffusion")
    except noise_kinds.NoPiece:
        raise Unsupported(f"noise kind {noise.kind!r}: the {SOLVER} solver has no generator "
                          "for it (white noise only: a coloured noise adds its own state, a "
                          "3-D FPK)") from None
    B0 = float(piece(noise, float(system.f)))
    Dk = float(getattr(parametric, "stiffness", 0.0) or 0.0)
    Dc = float(getattr(parametric, "damping", 0.0) or 0.0)
    if not B0 > 0.0:
        raise Unsupported(f"the {SOLVER} solver needs the external noise on (f^2 D > 0): "
                          "the velocity diffusion vanishes at rest otherwise")
    walls = []
    for w in system.walls:
        try:
            law = impact.module(w.law, solver=SOLVER)
        except impact.NoLaw as exc:
            raise Unsupported(str(exc)) from None
        walls.append(WallMap(at=float(w.at), side=-1 if w.side == "lower" else 1, law=w.law,
                             r=float(w.r), v_yield=w.v_yield,
                             rebound=_rebound(law, float(w.r), w.v_yield)))
    return Coefficients(k=tuple(float(c) for c in system.restoring_law),
                        d=tuple(float(c) for c in system.damping_law),
                        e=tuple(float(c) for c in system.velocity_law), mu=float(system.mu),
                        B0=B0, Dk=Dk, Dc=Dc, walls=tuple(walls))


def _rebound(law: Any, r: float, v_yield: float | None) -> Any:
    vy = 0.0 if v_yield is None else float(v_yield)

    def rebound(s: Any) -> Any:
        """e(s) s for impact speed s >= 0."""
        s = np.asarray(s, dtype=float)
        return law.restitution(s, r, vy) * s

    return rebound
