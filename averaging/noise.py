"""The excitation's spectral density: the one home of S(omega) in the averaged models.

Two-sided spectral density of xi, S(w) = (1/pi) int_0^inf R(t) cos(w t) dt, for the two kinds
of noise the scene may name (Liu et al., Symmetry 2019, eq. 18 for the OU case)::

    "ou":     xi' + alpha1 xi = W,  E[W(t) W(t+s)] = 2 D delta(s):  S(w) = D / (pi (w^2 + alpha1^2))
    "white":  xi = W:                                               S(w) = D / pi

The models read plain numbers (kind, D, alpha1) from the scene and build a :class:`Spectrum`;
an unknown kind raises ``ValueError`` here, so no model can fall back silently to another one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from vifpk.core.registry import NOISE_KINDS, one_of


@dataclass(frozen=True, kw_only=True)
class Spectrum:
    """S(w) of the excitation; ``kind`` in NOISE_KINDS, intensity ``D``, OU bandwidth
    ``alpha1`` (unused for white noise)."""

    kind: str
    D: float
    alpha1: float

    def __post_init__(self) -> None:
        one_of("noise kind", self.kind, NOISE_KINDS)

    @classmethod
    def from_scene(cls, scene: Any) -> Spectrum:
        n = scene.noise
        return cls(kind=n.kind, D=float(n.D), alpha1=float(n.alpha1))

    def __call__(self, omega: Any) -> np.ndarray:
        """S(omega), elementwise."""
        omega = np.asarray(omega, dtype=float)
        if self.kind == "white":
            return np.full_like(omega, self.D / math.pi)
        return self.D / (math.pi * (omega**2 + self.alpha1**2))

    def rational_parts(self) -> tuple[float, float]:
        """(c, a2) with w^2 S(w) = c - a2 S(w) for every w: the OU spectrum's identity
        (c = D / pi, a2 = alpha1^2), which lets a harmonic sum of w^2 S(w) be split into a
        Parseval sum and a remainder decaying like S. White noise has no such split (w^2 S
        grows without bound): raises ValueError."""
        if self.kind != "ou":
            raise ValueError(f"{self.kind!r} noise has no rational split of w^2 S(w)")
        return self.D / math.pi, self.alpha1**2
