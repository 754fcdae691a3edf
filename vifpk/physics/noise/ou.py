"""Ornstein-Uhlenbeck ("real") noise: xi' = -alpha1 xi + W, E[W(t) W(t+s)] = 2 D delta(s).

Stationary law N(0, D / alpha1). Monte Carlo (montecarlo/kernels.py): xi is held over the
velocity stage, B(h; F = -g + f xi) in one piece, and updated exactly after the step,
xi <- a xi + sqrt(D / alpha1 (1 - a^2)) N, a = e^{-alpha1 h} (C(h/2) C(h/2) of consecutive
steps merged: xi lives at the middle of each step).

Averaged models: two-sided spectral density S(w) = (1/pi) int_0^inf R(t) cos(w t) dt
= D / (pi (w^2 + alpha1^2)) (Liu et al., Symmetry 2019, eq. 18), with the rational identity
w^2 S(w) = c - a2 S(w), c = D / pi, a2 = alpha1^2, that lets a harmonic sum of w^2 S be split
into a Parseval sum and a fast-decaying remainder (averaging/exact.py).

``KIND`` is the declared object (vifpk.core.protocols.NoiseKind), registered in vifpk's
pyproject.toml (``vifpk.noise_kinds``) as any other package's kind would be.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from vifpk.core.protocols import AveragingNoise, MonteCarloNoise, NoiseKindSpec, Param


class MCRecord(NamedTuple):
    ou_a: float  # e^{-alpha1 h}
    ou_s: float  # sqrt(D / alpha1 (1 - a^2))


def mc_record(p: Any, f: float, h: float) -> MCRecord:
    a = math.exp(-float(p["alpha1"]) * h)
    return MCRecord(a, math.sqrt(float(p["D"]) / float(p["alpha1"]) * (1.0 - a * a)))


def mc_start_sd(p: Any) -> float:
    return math.sqrt(float(p["D"]) / float(p["alpha1"]))


def mc_start(p: Any, f: float, gen: Any, n: Any) -> np.ndarray:
    """N(0, D / alpha1) draws (numpy's standard normal times the standard deviation)."""
    return gen.standard_normal(n) * mc_start_sd(p)


def mc_state_start(normal: Any, uniform: Any) -> Any:
    """xi = sqrt(D / alpha1) N (the record's ``xi_sd``)."""
    def start(rec, s0, s1, s2, s3):
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        return rec.xi_sd * z, s0, s1, s2, s3
    return start


def mc_bridge(p: Any, f: float) -> None:
    """None: the energy is C^1 in time between impacts (no bridge correction)."""
    return None


def mc_input_power(p: Any, f: float) -> None:
    """None: no exact mean input power in general (it depends on the response)."""
    return None


def mc_press(rec, xi):
    return -rec.f * xi


def mc_velocity(flow: Any, normal: Any) -> Any:
    """B(h) with the force -g + f xi held (one exact sub-flow: no random number)."""
    def stage(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):
        v, stuck = flow(v, h, -g + rec.f * xi, k, mu, at_wall)
        return v, stuck, v, v, v, s0, s1, s2, s3
    return stage


def mc_advance(normal: Any) -> Any:
    """xi <- a xi + s N (exact)."""
    def advance(rec, xi, s0, s1, s2, s3):
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        return rec.ou_a * xi + rec.ou_s * z, s0, s1, s2, s3
    return advance


def poisson_kernel(r: float, theta: float) -> float:
    """sum_k r^|k| cos(k theta) = (1 - r^2) / (1 - 2 r cos(theta) + r^2), 0 <= r < 1, written
    (1 - r^2) / ((1 - r)^2 + 4 r sin^2(theta / 2)) to keep its digits as r -> 1."""
    one_minus = -math.expm1(math.log(r)) if r > 0 else 1.0
    return (one_minus * (2.0 - one_minus)) / (one_minus**2 + 4.0 * r * math.sin(0.5 * theta) ** 2)


def mc_held_excess(p: Any, omega: float, h: float) -> float:
    """The held xi's spectrum at omega against S(omega) (vifpk.core.protocols.MonteCarloNoise,
    ``held_excess``): xi sampled once a step from its exact law is an AR(1) sequence,
    R(k h) = (D / alpha1) a^|k|, a = e^{-alpha1 h}, so sum_k R(k h) cos(omega k h) =
    (D / alpha1) P(a, omega h) (poisson_kernel), and with S = D / (pi (omega^2 + alpha1^2))
    the relative error is sinc^2(omega h / 2) h P(a, omega h) (omega^2 + alpha1^2) /
    (2 alpha1) - 1 = (alpha1 h)^2 / 12 + O(h^4) (the omega^2 parts cancel to that order)."""
    al = float(p["alpha1"])
    a = math.exp(-al * h)
    x = 0.5 * omega * h
    sinc2 = (math.sin(x) / x) ** 2 if x != 0 else 1.0
    return sinc2 * h * poisson_kernel(a, omega * h) * (omega**2 + al**2) / (2.0 * al) - 1.0


def mc_energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi):
    """Trapezoid over B(h): input f xi v, damping k v^2, friction mu |v|."""
    fric = 0.0
    if mu is not None:
        fric = mu * h * 0.5 * (abs(vb) + abs(ve))
    return rec.f * xi * h * 0.5 * (vb + ve), k * h * 0.5 * (vb * vb + ve * ve), fric


# ------------------------------------------------------------------ averaged models
def avg_spectral_density(omega: Any, *, D: float, alpha1: float) -> np.ndarray:
    """S(w) = D / (pi (w^2 + alpha1^2)), elementwise."""
    omega = np.asarray(omega, dtype=float)
    return D / (math.pi * (omega**2 + alpha1**2))


def avg_rational_parts(*, D: float, alpha1: float) -> tuple[float, float]:
    """(c, a2) = (D / pi, alpha1^2): w^2 S(w) = c - a2 S(w) for every w."""
    return D / math.pi, alpha1**2


def avg_correlation_rate(*, D: float, alpha1: float) -> float:
    """1 / (correlation time) = alpha1: R(t) = (D / alpha1) exp(-alpha1 |t|)."""
    return alpha1


KIND = NoiseKindSpec(
    name="ou",
    summary="Ornstein-Uhlenbeck (real) noise: xi' = -alpha1 xi + W, E[W W] = 2 D delta",
    params=(Param(name="D", default=0.01, low=0.0, doc="intensity: E[W W] = 2 D delta"),
            Param(name="alpha1", default=2.0, low=0.0, doc="OU bandwidth")),
    averaging=AveragingNoise(spectral_density=avg_spectral_density,
                             rational_parts=avg_rational_parts,
                             correlation_rate=avg_correlation_rate),
    montecarlo=MonteCarloNoise(Record=MCRecord, record=mc_record, start=mc_start,
                               start_sd=mc_start_sd, bridge=mc_bridge,
                               input_power=mc_input_power, press=mc_press,
                               velocity=mc_velocity, advance=mc_advance, energy=mc_energy,
                               state_start=mc_state_start, held_excess=mc_held_excess),
)
