"""The excitation's spectral density as the averaged models see it (each noise kind declares
it: vifpk.core.protocols.AveragingNoise; this class reads it).

Two-sided spectral density of xi, S(w) = (1/pi) int_0^inf R(t) cos(w t) dt, of the scene's
noise kind, e.g. (Liu et al., Symmetry 2019, eq. 18 for the OU case)::

    "ou":     xi' + alpha1 xi = W,  E[W(t) W(t+s)] = 2 D delta(s):  S(w) = D / (pi (w^2 + alpha1^2))
    "white":  xi = W:                                               S(w) = D / pi

The models read the kind and its parameter values from the scene and build a
:class:`Spectrum`; S comes from the kind's declared ``spectral_density`` (required), the fast
paths from its optional ``flat_level``, ``rational_parts`` and ``correlation_rate``. A kind
that is not registered, or has no averaging pieces, raises NoPiece (a BadInput) in one line
naming the kind and the solver, so no model can fall back silently to another kind.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from vifpk.core.protocols import ParamsByName
from vifpk.physics import impact
from vifpk.physics import noise as noise_kinds

SOLVER = "averaging"


def problem(scene: Any) -> str | None:
    """None when the scene's noise kind and its walls' impact laws have every piece the
    averaged models need (vifpk.physics: the kind's AveragingNoise, the laws' restitution and
    energy_loss), else the one line naming the kind or law and this solver: what a built-in
    model's ``applies`` says, so a scene is refused (or a default model skipped) before any
    work, never an internal error."""
    try:
        noise_kinds.pieces(scene.noise.kind, SOLVER)
        for w in scene.system.walls:
            impact.law(w.law, solver=SOLVER)
    except (noise_kinds.NoPiece, impact.NoLaw) as e:
        return str(e)
    return None


@dataclass(frozen=True, kw_only=True)
class Spectrum(ParamsByName):
    """S(w) of the excitation: a registered noise ``kind`` and its parameter values
    ``params`` ((name, value) in declared order; a parameter reads as an attribute:
    ``spectrum.D``)."""

    kind: str
    params: tuple[tuple[str, float], ...]

    def __post_init__(self) -> None:
        self._pieces()  # a kind without averaging pieces: one line, now

    def _pieces(self) -> Any:
        return noise_kinds.pieces(self.kind, SOLVER)

    @classmethod
    def of(cls, kind: str, **values: float) -> Spectrum:
        """The spectrum of ``kind`` with the given parameter values (the kind's defaults for
        the others; a name the kind does not declare raises ValueError)."""
        declared = noise_kinds.kind(kind).params
        extra = set(values) - {p.name for p in declared}
        if extra:
            raise ValueError(f"noise kind {kind!r} has no parameter {sorted(extra)[0]!r}")
        return cls(kind=kind, params=tuple(
            (p.name, float(values.get(p.name, p.default))) for p in declared))

    @classmethod
    def from_scene(cls, scene: Any) -> Spectrum:
        n = scene.noise
        return cls(kind=n.kind, params=tuple((k, float(v)) for k, v in n.params))

    def __call__(self, omega: Any) -> np.ndarray:
        """S(omega), elementwise (the kind's ``spectral_density``)."""
        return self._pieces().spectral_density(omega, **self.values)

    @property
    def flat(self) -> bool:
        """Whether S is the same at every frequency (the kind declares ``flat_level``)."""
        return self._pieces().flat_level is not None

    @property
    def rational(self) -> bool:
        """Whether the kind declares the rational split of :meth:`rational_parts` (OU)."""
        return self._pieces().rational_parts is not None

    def correlation_rate(self) -> float | None:
        """The kind's correlation rate (1 / correlation time; OU: alpha1), or None for a kind
        that declares none (white noise: no correlation time)."""
        fn = self._pieces().correlation_rate
        return None if fn is None else float(fn(**self.values))

    def level(self) -> float:
        """The flat spectrum's S (ValueError naming the kind for a kind that is not flat)."""
        fn = self._pieces().flat_level
        if fn is None:
            raise ValueError(f"noise kind {self.kind!r} declares no flat_level: its spectrum "
                             "is not flat")
        return float(fn(**self.values))

    def ou_parameters(self) -> tuple[float, float]:
        """(D, alpha1) of the OU noise with this rational spectrum: S = c / (w^2 + a2) (the
        split w^2 S = c - a2 S) is D / (pi (w^2 + alpha1^2)) with D = pi c, alpha1 =
        sqrt(a2), the covariance (D / alpha1) e^{-alpha1 |s|} to second order (what the
        corrected model's wall offset is derived with, docs/averaging.md 10.3). Where the kind
        declares parameters named D and alpha1 AND its split is theirs (pi c = D, sqrt(a2) =
        alpha1 to 1e-12: OU), they are given as declared, bit for bit; a kind that only names
        its parameters so (another spectrum) gets the values of its own split."""
        c, a2 = self.rational_parts()
        D, alpha1 = math.pi * c, math.sqrt(a2)
        values = self.values
        if ("D" in values and "alpha1" in values
                and math.isclose(D, values["D"], rel_tol=1e-12)
                and math.isclose(alpha1, values["alpha1"], rel_tol=1e-12)):
            return values["D"], values["alpha1"]
        return D, alpha1

    def rational_parts(self) -> tuple[float, float]:
        """(c, a2) with w^2 S(w) = c - a2 S(w) for every w (the OU spectrum's identity,
        c = D / pi, a2 = alpha1^2), which lets a harmonic sum of w^2 S(w) be split into a
        Parseval sum and a remainder decaying like S. A kind that declares no such split
        (white noise: w^2 S grows without bound) raises ValueError naming it."""
        fn = self._pieces().rational_parts
        if fn is None:
            raise ValueError(f"noise kind {self.kind!r} declares no rational_parts: "
                             "w^2 S(w) = c - a2 S(w) does not hold for it")
        return fn(**self.values)
