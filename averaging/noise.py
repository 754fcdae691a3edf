"""The excitation's spectral density as the averaged models see it (each kind's module in
vifpk/physics/noise/ declares it; this class reads it).

Two-sided spectral density of xi, S(w) = (1/pi) int_0^inf R(t) cos(w t) dt, for the two kinds
of noise the scene may name (Liu et al., Symmetry 2019, eq. 18 for the OU case)::

    "ou":     xi' + alpha1 xi = W,  E[W(t) W(t+s)] = 2 D delta(s):  S(w) = D / (pi (w^2 + alpha1^2))
    "white":  xi = W:                                               S(w) = D / pi

The models read plain numbers (kind, D, alpha1) from the scene and build a :class:`Spectrum`;
each kind's spectrum comes from its own module (vifpk/physics/noise/<kind>.py); an unknown
kind, or a kind without the piece asked for, raises ``ValueError`` in one line naming the kind
and the solver, so no model can fall back silently to another one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from vifpk.core.registry import NOISE_KINDS, one_of
from vifpk.physics import noise as noise_kinds

SOLVER = "averaging"


@dataclass(frozen=True, kw_only=True)
class Spectrum:
    """S(w) of the excitation; ``kind`` in NOISE_KINDS, intensity ``D``, OU bandwidth
    ``alpha1`` (unused for white noise)."""

    kind: str
    D: float
    alpha1: float

    def __post_init__(self) -> None:
        one_of("noise kind", self.kind, NOISE_KINDS)
        noise_kinds.piece(self.kind, SOLVER, "spectral_density")  # one line if it has none

    def _has(self, name: str) -> bool:
        """Whether the kind declares the averaging piece ``name``."""
        return self.kind in noise_kinds.kinds_with(SOLVER, name)

    @classmethod
    def from_scene(cls, scene: Any) -> Spectrum:
        n = scene.noise
        return cls(kind=n.kind, D=float(n.D), alpha1=float(n.alpha1))

    def __call__(self, omega: Any) -> np.ndarray:
        """S(omega), elementwise (the kind's ``spectral_density``)."""
        S = noise_kinds.piece(self.kind, SOLVER, "spectral_density")
        return S(omega, D=self.D, alpha1=self.alpha1)

    @property
    def flat(self) -> bool:
        """Whether S is the same at every frequency (the kind declares ``flat_level``)."""
        return self._has("flat_level")

    @property
    def rational(self) -> bool:
        """Whether the kind declares the rational split of :meth:`rational_parts` (OU)."""
        return self._has("rational_parts")

    def correlation_rate(self) -> float | None:
        """The kind's correlation rate (1 / correlation time; OU: alpha1), or None for a kind
        that declares none (white noise: no correlation time)."""
        if not self._has("correlation_rate"):
            return None
        return float(noise_kinds.piece(self.kind, SOLVER, "correlation_rate")(
            D=self.D, alpha1=self.alpha1))

    def level(self) -> float:
        """The flat spectrum's S (ValueError naming the kind for a kind that is not flat)."""
        return float(noise_kinds.piece(self.kind, SOLVER, "flat_level")(
            D=self.D, alpha1=self.alpha1))

    def rational_parts(self) -> tuple[float, float]:
        """(c, a2) with w^2 S(w) = c - a2 S(w) for every w (the OU spectrum's identity,
        c = D / pi, a2 = alpha1^2), which lets a harmonic sum of w^2 S(w) be split into a
        Parseval sum and a remainder decaying like S. A kind that declares no such split
        (white noise: w^2 S grows without bound) raises ValueError naming it."""
        return noise_kinds.piece(self.kind, SOLVER, "rational_parts")(
            D=self.D, alpha1=self.alpha1)
