"""A noise kind and an impact law written outside vifpk (docs/plugins.md): each one declared
object, registered by entry point in this package's pyproject.toml.

``telegraph``: symmetric dichotomous (telegraph) noise, xi = +-a switching sign at rate lam
each way (Horsthemke & Lefever, *Noise-Induced Transitions*, 1984, ch. 9): a two-state Markov
chain, stationary law +-a with probability 1/2 each, correlation

    R(s) = a^2 exp(-2 lam |s|),   S(w) = (1/pi) int_0^inf R cos(w t) dt
                                       = (a^2 / pi) 2 lam / (4 lam^2 + w^2),

so w^2 S = c - a2 S with c = 2 lam a^2 / pi, a2 = 4 lam^2 (its second-order twin is OU noise
with D = 2 lam a^2, alpha1 = 2 lam; the Monte Carlo sees the non-Gaussian noise). Over a step
h the sign flips with the chain's exact probability p = (1 - exp(-2 lam h)) / 2 (one normal
number N: flip when N < Phi^{-1}(p)); xi is held over the velocity stage like OU's.

``linear``: e(v) = max(r_min, r0 - c |v|): the restitution falls linearly with the impact
speed to a floor (a law with three parameters and no yield speed; not constant, so the
averaged models never take it for Newton's).
"""

from __future__ import annotations

import math
from statistics import NormalDist
from typing import Any, NamedTuple

import numpy as np

from vifpk.core.protocols import (
    AveragingNoise,
    ImpactLawSpec,
    MonteCarloNoise,
    NoiseKindSpec,
    Param,
)


# ------------------------------------------------------------------ the telegraph noise
class Record(NamedTuple):
    tg_q: float  # Phi^{-1}(p): the sign flips over the step when N < tg_q
    tg_a: float  # the amplitude a


def record(p: Any, f: float, h: float) -> Record:
    flip = 0.5 * -math.expm1(-2.0 * p["rate"] * h)
    q = NormalDist().inv_cdf(flip) if flip > 0.0 else -math.inf
    return Record(q, float(p["amplitude"]))


def start(p: Any, f: float, gen: Any, shape: Any) -> np.ndarray:
    """+-a with probability 1/2 each (the chain's stationary law)."""
    return p["amplitude"] * np.where(gen.random(shape) < 0.5, 1.0, -1.0)


def start_sd(p: Any) -> None:
    """None: the state is not Gaussian (the orbit starts draw it with ``state_start``)."""
    return None


def none(p: Any, f: float) -> None:
    """No bridge correction (E is C^1 in time), no exact mean input power."""
    return None


def press(rec, xi):
    return -rec.f * xi


def velocity(flow: Any, normal: Any) -> Any:
    """B(h) with the force -g + f xi held (as OU's)."""
    def stage(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):
        v, stuck = flow(v, h, -g + rec.f * xi, k, mu, at_wall)
        return v, stuck, v, v, v, s0, s1, s2, s3
    return stage


def advance(normal: Any) -> Any:
    """The sign flips with probability p over the step (N < Phi^{-1}(p))."""
    def step(rec, xi, s0, s1, s2, s3):
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        if z < rec.tg_q:
            xi = -xi
        return xi, s0, s1, s2, s3
    return step


def energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi):
    """Trapezoid over B(h): input f xi v, damping k v^2, friction mu |v| (as OU's)."""
    fric = 0.0
    if mu is not None:
        fric = mu * h * 0.5 * (abs(vb) + abs(ve))
    return rec.f * xi * h * 0.5 * (vb + ve), k * h * 0.5 * (vb * vb + ve * ve), fric


def state_start(normal: Any, uniform: Any) -> Any:
    """+-a with probability 1/2 each (one uniform number)."""
    def draw(rec, s0, s1, s2, s3):
        u, s0, s1, s2, s3 = uniform(s0, s1, s2, s3)
        return (rec.tg_a if u < 0.5 else -rec.tg_a), s0, s1, s2, s3
    return draw


def spectral_density(omega: Any, *, amplitude: float, rate: float) -> np.ndarray:
    """S(w) = (a^2 / pi) 2 lam / (4 lam^2 + w^2), elementwise."""
    omega = np.asarray(omega, dtype=float)
    return amplitude**2 / math.pi * 2.0 * rate / (4.0 * rate**2 + omega**2)


def rational_parts(*, amplitude: float, rate: float) -> tuple[float, float]:
    """(c, a2) = (2 lam a^2 / pi, 4 lam^2): w^2 S(w) = c - a2 S(w) for every w."""
    return 2.0 * rate * amplitude**2 / math.pi, 4.0 * rate**2


def correlation_rate(*, amplitude: float, rate: float) -> float:
    """1 / correlation time: 2 lam (R(s) = a^2 e^{-2 lam |s|})."""
    return 2.0 * rate


TELEGRAPH = NoiseKindSpec(
    name="telegraph",
    summary="dichotomous noise: xi = +-a, switching sign at rate lam each way",
    params=(Param(name="amplitude", default=0.07, low=0.0, doc="a: xi = +-a"),
            Param(name="rate", default=1.0, low=0.0, doc="lam: switching rate each way")),
    averaging=AveragingNoise(spectral_density=spectral_density,
                             rational_parts=rational_parts,
                             correlation_rate=correlation_rate),
    montecarlo=MonteCarloNoise(Record=Record, record=record, start=start, start_sd=start_sd,
                               bridge=none, input_power=none, press=press, velocity=velocity,
                               advance=advance, energy=energy, state_start=state_start),
)


# ------------------------------------------------------------------ the linear law
def restitution(v: Any, r0: float, c: float, r_min: float) -> Any:
    """e(v) = max(r_min, r0 - c |v|)."""
    return np.maximum(r_min, r0 - c * np.abs(v))


def energy_loss(v: Any, r0: float, c: float, r_min: float) -> Any:
    """(1 - e(v)^2) v^2 / 2: the kinetic energy one impact at speed v takes."""
    e = restitution(v, r0, c, r_min)
    return (1.0 - e * e) * (0.5 * v * v)


def limit(r0: float, c: float, r_min: float) -> float:
    """e as |v| -> inf: r_min (c > 0), else max(r_min, r0)."""
    return r_min if c > 0.0 else max(r_min, r0)


LINEAR = ImpactLawSpec(
    name="linear", summary="e = max(r_min, r0 - c |v|)", constant=False,
    params=(Param(name="r0", default=0.96, low=0.0, high=1.0, doc="e at impact speed 0"),
            Param(name="c", low=0.0, low_closed=True, doc="fall of e per unit impact speed"),
            Param(name="r_min", default=0.3, low=0.0, high=1.0, doc="e at high speed")),
    restitution=restitution, energy_loss=energy_loss, limit=limit)
