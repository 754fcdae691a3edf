"""The paper's averaged model (Liu et al., Symmetry 2019, section 5), rebuilt term by term.

Amplitude SDE dA = m(A) dt + sigma(A) dB with, for g(A) = omega0^2 A + alpha A^3::

    b0 = w1 (1 - eta^2/16),  b2 = w1 (eta/2 + 3 eta^3/64),  b4 = -w1 eta^2/16,  b6 = w1 k6 eta^3
    (k6 = 3/64 as printed; the Taylor coefficient of w1 sqrt(1 + eta cos 2 theta) is 1/64)
    omega(A) = b0,   d_i = d/dA [b_i A / g(A)],   S(w) two-sided spectral density of xi

    m = A^2/(8g) [c1 (4 w0^2 + 5 alpha A^2/2) - c2 A^2 (w0^2 + 3 alpha A^2/4)]      damping
      - A^2/(8g) (8/pi) (1-r) (w0^2 + alpha A^2/2) (b0 - b2 + b4 - b6)             impacts
      - A mu/(pi g) [2 b0 - 2 b2/3 - 2 b4/15 - 2 b6/35]                            friction
      + pi A f^2/(8g) sum_n (2 a_n)(2 e_n) S(n omega)                              noise (d/dA)
      + pi A f^2/(8g^2) sum_n n (2 a_n)(2 c_n) S(n omega)                          noise (phase)
    sigma^2 = pi A^2 f^2/(4 g^2) sum_n (2 a_n)^2 S(n omega),       n = 1, 3, 5, 7

    2a = (2b0 - b2, b2 - b4, b4 - b6, b6)    (nu sin theta = sum a_n sin n theta)
    2c = (2b0 + b2, b2 + b4, b4 + b6, b6)    (nu cos theta = sum c_n cos n theta)
    2e = the same combinations of d_i as 2a is of b_i.

The paper prints no f (f = 1 there); here both noise terms carry f^2. Each line is derived in
docs/averaging.md; the extraction of the paper lost the square roots, the minus sign of b4
and the 1/pi of the impact term, which are restored. The noise is sampled at the ODD
harmonics of omega: this is the additive-noise result, which drops the sgn(y) factor of the
transformed excitation f xi sgn(y). With alpha = 0 every line is exact for that model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vifpk.core.registry import one_of

from .geometry import Array, amplitudes, w1_eta
from .noise import Spectrum
from .noise import problem as noise_problem
from .walls import is_paper_wall, walls_of

B6_COEFFICIENTS = {"printed": 3.0 / 64.0, "taylor": 1.0 / 64.0}
HARMONICS = np.array([1.0, 3.0, 5.0, 7.0])


def _beta(eta: Array, k6: float) -> tuple[Array, Array]:
    """Coefficients b_i / w1 as functions of eta, and their eta-derivatives; shape (4, ...)."""
    one = np.ones_like(eta)
    beta = np.stack([1.0 - eta**2 / 16.0, eta / 2.0 + 3.0 * eta**3 / 64.0,
                     -(eta**2) / 16.0, k6 * eta**3])
    dbeta = np.stack([-eta / 8.0, 0.5 * one + 9.0 * eta**2 / 64.0, -eta / 8.0,
                      3.0 * k6 * eta**2])
    return beta, dbeta


@dataclass(frozen=True, kw_only=True)
class PaperModel:
    """Drift and diffusion of the paper's averaged amplitude equation.

    Keyword options: ``b6`` ("printed" 3/64 or "taylor" 1/64).
    The system and noise are passed in duck-typed (anything with the Scene's attributes).
    """

    c1: float
    c2: float
    omega0: float
    alpha: float
    mu: float
    r: float
    f: float
    barrier: bool
    spectrum: Any = field(repr=False)
    b6: str = "printed"
    name: str = "paper"

    def __post_init__(self) -> None:
        one_of("b6", self.b6, sorted(B6_COEFFICIENTS))

    @staticmethod
    def applies(scene: Any) -> str | None:
        """None for a system in the paper's family (a cubic spring with k1 > 0, damping
        -c1 + c2 x^2, no velocity damping: System.paper_family_problem), else why not
        (the averaged-model protocol, vifpk.core.protocols)."""
        pieces = noise_problem(scene)  # the kind's and laws' averaging pieces
        if pieces is not None:
            return pieces
        s = scene.system
        problem = s.paper_family_problem() if hasattr(s, "paper_family_problem") else None
        if problem is not None:
            return problem
        walls = walls_of(s)
        if walls and not is_paper_wall(walls):
            return ("walls other than one lower wall at x = 0 with Newton's law are outside "
                    "the paper's family")
        if scene.parametric.on:
            return "parametric noise is outside the paper's family"
        return None

    @classmethod
    def from_scene(cls, scene: Any, *, b6: str = "printed") -> PaperModel:
        one_of("b6", b6, sorted(B6_COEFFICIENTS))
        s = scene.system
        problem = cls.applies(scene)
        if problem is not None:
            raise ValueError(f"model 'paper' does not apply: {problem}")
        k, d = s.restoring_law, s.damping_law
        c1 = s.c1 if s.c1 is not None else -d[0]
        c2 = s.c2 if s.c2 is not None else (d[1] if len(d) > 1 else 0.0)
        omega0 = s.omega0 if s.omega0 is not None else float(np.sqrt(k[0]))
        alpha = s.alpha if s.alpha is not None else (k[1] if len(k) > 1 else 0.0)
        walls = walls_of(s)
        return cls(c1=c1, c2=c2, omega0=omega0, alpha=alpha, mu=s.mu,
                   r=walls[0].r if walls else 1.0, f=s.f, barrier=bool(walls),
                   spectrum=Spectrum.from_scene(scene), b6=b6)

    # ------------------------------------------------------------------ series
    def b(self, A: Array) -> Array:
        """b0, b2, b4, b6 (shape (4, ...)) of nu ~ b0 + b2 cos 2t + b4 cos 4t + b6 cos 6t."""
        w1, eta = w1_eta(A, self.omega0, self.alpha)
        beta, _ = _beta(eta, B6_COEFFICIENTS[self.b6])
        return w1 * beta

    def d(self, A: Array) -> Array:
        """d_i = d/dA [b_i(A) A / g(A)], analytic (A/g = 1/(w0^2 + alpha A^2))."""
        A = np.asarray(A, dtype=float)
        w0sq, a = self.omega0**2, self.alpha
        w1, eta = w1_eta(A, self.omega0, a)
        beta, dbeta = _beta(eta, B6_COEFFICIENTS[self.b6])
        dw1 = 0.75 * a * A / w1
        deta = 0.5 * a * A / w1**2 - 0.5 * a * A**2 * dw1 / w1**3
        db = dw1 * beta + w1 * dbeta * deta
        h = 1.0 / (w0sq + a * A**2)
        dh = -2.0 * a * A * h**2
        return db * h + w1 * beta * dh

    def frequency(self, A: Array) -> Array:
        """Mean frequency omega(A) = b0(A) (paper, after eq. 18)."""
        return self.b(A)[0]

    def period(self, A: Array) -> Array:
        """T(E) = 2 pi / b0(A) as the paper uses it for p(y, y')."""
        return 2.0 * math.pi / self.frequency(A)

    # ------------------------------------------------------------------ terms
    def terms(self, A: Array) -> dict[str, Array]:
        """Every term of m(A) separately, and sigma^2(A). A > 0."""
        A = np.asarray(A, dtype=float)
        w0sq, a = self.omega0**2, self.alpha
        h = 1.0 / (w0sq + a * A**2)  # A / g(A), regular at A = 0
        b0, b2, b4, b6 = self.b(A)
        d0, d2, d4, d6 = self.d(A)
        two_a = np.stack([2 * b0 - b2, b2 - b4, b4 - b6, b6])
        two_c = np.stack([2 * b0 + b2, b2 + b4, b4 + b6, b6])
        two_e = np.stack([2 * d0 - d2, d2 - d4, d4 - d6, d6])
        S = np.asarray(self.spectrum(HARMONICS[:, None] * b0[None, ...]), dtype=float)
        S = S.reshape(two_a.shape)
        pref = A * h / 8.0  # A^2 / (8 g)
        f2 = self.f**2
        n = HARMONICS.reshape((4,) + (1,) * A.ndim)
        out = {
            "damping": pref * (self.c1 * (4 * w0sq + 2.5 * a * A**2)
                               - self.c2 * A**2 * (w0sq + 0.75 * a * A**2)),
            "impact": (-pref * (8.0 / math.pi) * (1.0 - self.r) * (w0sq + 0.5 * a * A**2)
                       * (b0 - b2 + b4 - b6)) if self.barrier else np.zeros_like(A),
            "friction": -(h * self.mu / math.pi)
                        * (2 * b0 - 2 * b2 / 3 - 2 * b4 / 15 - 2 * b6 / 35),
            "noise_amplitude": math.pi * h * f2 / 8.0 * np.sum(two_a * two_e * S, axis=0),
            "noise_phase": math.pi * h**2 * f2 / (8.0 * A) * np.sum(n * two_a * two_c * S,
                                                                    axis=0),
            "sigma2": math.pi * h**2 * f2 / 4.0 * np.sum(two_a**2 * S, axis=0),
        }
        return out

    @amplitudes
    def drift(self, A: Array) -> Array:
        """m(A): the sum of the five drift terms of :meth:`terms`."""
        t = self.terms(A)
        return (t["damping"] + t["impact"] + t["friction"] + t["noise_amplitude"]
                + t["noise_phase"])

    @amplitudes
    def diffusion(self, A: Array) -> Array:
        """sigma^2(A)."""
        return self.terms(A)["sigma2"]

    # -------------------------------------------- pieces of the stationary density (eq. 14)
    def log_stationary_parts(self, A: Array) -> tuple[Array, Array, Array]:
        """(q, log_pre, log_phase_pre) with log p_A = log_pre + int_0^A q  (up to a constant).

        Eq. 14: p = N / sigma^2 exp(int_0^A 2 m / sigma^2). Near A = 0, 2m/sigma^2 ~ 1/A, so
        q = 2 m / sigma^2 - 1/A is regular and log_pre = log A - log sigma^2.
        log_phase_pre = log(p_A / (g T)) - int q, the log of p(y, y') = p_E / T (T = 2 pi/b0).
        """
        A = np.asarray(A, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = self.terms(A)
        m = (t["damping"] + t["impact"] + t["friction"] + t["noise_amplitude"]
             + t["noise_phase"])
        s2 = t["sigma2"]
        with np.errstate(divide="ignore", invalid="ignore"):
            q = 2.0 * m / s2 - 1.0 / A
            log_pre = np.log(A) - np.log(s2)
            b0 = self.frequency(A)
            log_phase = (-np.log(s2) - np.log(self.omega0**2 + self.alpha * A**2)
                         + np.log(b0) - math.log(2.0 * math.pi))
        return q, log_pre, log_phase
