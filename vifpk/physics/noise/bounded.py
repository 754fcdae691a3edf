"""Bounded noise (a random-phase harmonic): xi(t) = a cos(Omega t + sigma W(t) + theta), theta
uniform on [0, 2 pi), W a standard Wiener process (Dimentberg, Statistical Dynamics of
Nonlinear and Time-Varying Systems, 1988; Wedig; Zhu & Huang's bounded-noise papers). Scene::

    [noise]
    kind = "bounded"
    amplitude = 0.3     # a
    frequency = 1.2     # Omega
    sigma = 1.0         # sigma

Its phase psi = Omega t + sigma W + theta is a Brownian motion with drift, so
E[cos(psi(t)) cos(psi(t + s))] = (1/2) E[cos(Omega s + sigma (W(t+s) - W(t)))]
= (1/2) cos(Omega s) exp(-sigma^2 |s| / 2) (the characteristic function of a normal of
variance sigma^2 |s|; the sum of the two phases averages out over theta), hence the
covariance and, with the convention of the other kinds, S(w) = (1/pi) int_0^inf R(t) cos(w t)
dt (two-sided: int_{-inf}^{inf} S dw = R(0)), with beta = sigma^2 / 2::

    R(s) = (a^2 / 2) cos(Omega s) exp(-beta |s|),
    S(w) = (a^2 / (4 pi)) [beta / (beta^2 + (w - Omega)^2) + beta / (beta^2 + (w + Omega)^2)].

Checks: int S dw = a^2 / 2 = R(0) = E[xi^2]; as sigma -> inf with a^2 / sigma^2 = D fixed,
S(w) -> a^2 / (2 pi beta) = D / pi at every fixed w: white noise of intensity D
(E[W W] = 2 D delta, white.py); as sigma -> 0 the spectrum concentrates at +-Omega (a pure
harmonic of random phase). The noise is bounded (|xi| <= a) and not Gaussian; the averaged
models need only its covariance (first-order averaging). Bandwidth: the envelope of R decays
at the rate beta = sigma^2 / 2, the kind's correlation rate (the narrow-band warning compares
it with the oscillation frequency, as for OU's alpha1). S is neither flat nor rational in the
OU sense (w^2 S = c - a2 S holds for no constants), so the averaged models take the general
harmonic sum (averaging/spectral_sum.py).

Monte Carlo: the state is the phase psi (one float), updated exactly after each step,
psi <- psi + Omega h + sigma sqrt(h) N (kept in [0, 2 pi): the law of cos(psi) is unchanged),
started uniform on [0, 2 pi) (the stationary law of the phase mod 2 pi, so xi is stationary
from t = 0). The force f a cos(psi) is held over the velocity stage with psi at the middle of
the step, as OU's xi (ou.py): B(h; F = -g + f a cos(psi)) in one piece. Energy bookkeeping:
the input f a cos(psi) v by the trapezoid over the stage, as OU's.

``KIND`` is the declared object (vifpk.core.protocols.NoiseKind), registered in vifpk's
pyproject.toml (``vifpk.noise_kinds``) as any other package's kind would be.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from vifpk.core.protocols import AveragingNoise, MonteCarloNoise, NoiseKindSpec, Param

TWO_PI = 2.0 * math.pi


# ------------------------------------------------------------------ Monte Carlo
class MCRecord(NamedTuple):
    bounded_a: float      # a
    bounded_drift: float  # Omega h: the phase's deterministic advance over a step
    bounded_diff: float   # sigma sqrt(h): its random one's standard deviation


def mc_record(p: Any, f: float, h: float) -> MCRecord:
    return MCRecord(float(p["amplitude"]), float(p["frequency"]) * h,
                    float(p["sigma"]) * math.sqrt(h))


def mc_start(p: Any, f: float, gen: Any, n: Any) -> np.ndarray:
    """The phase, uniform on [0, 2 pi) (its stationary law mod 2 pi)."""
    return gen.uniform(0.0, TWO_PI, n)


def mc_start_sd(p: Any) -> None:
    """None: the state (a phase) is not Gaussian; its start is :func:`mc_state_start`."""
    return None


def mc_state_start(normal: Any, uniform: Any) -> Any:
    """psi = 2 pi U, U uniform on (0, 1)."""
    def start(rec, s0, s1, s2, s3):
        u, s0, s1, s2, s3 = uniform(s0, s1, s2, s3)
        return TWO_PI * u, s0, s1, s2, s3
    return start


def mc_bridge(p: Any, f: float) -> None:
    """None: the force is bounded and continuous, the energy C^1 between impacts."""
    return None


def mc_input_power(p: Any, f: float) -> None:
    """None: the mean input power depends on the response."""
    return None


def mc_press(rec, xi):
    return -rec.f * rec.bounded_a * math.cos(xi)


def mc_velocity(flow: Any, normal: Any) -> Any:
    """B(h) with the force -g + f a cos(psi) held, psi at the middle of the step (one exact
    sub-flow: no random number), as OU's xi."""
    def stage(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):
        v, stuck = flow(v, h, -g + rec.f * rec.bounded_a * math.cos(xi), k, mu, at_wall)
        return v, stuck, v, v, v, s0, s1, s2, s3
    return stage


def mc_advance(normal: Any) -> Any:
    """psi <- psi + Omega h + sigma sqrt(h) N (exact: psi is a Brownian motion with drift),
    wrapped into [0, 2 pi) so that a long run keeps cos(psi) to full precision."""
    def advance(rec, xi, s0, s1, s2, s3):
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        psi = xi + rec.bounded_drift + rec.bounded_diff * z
        return psi - TWO_PI * math.floor(psi / TWO_PI), s0, s1, s2, s3
    return advance


def mc_energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi):
    """Trapezoid over B(h): input f a cos(psi) v, damping k v^2, friction mu |v|."""
    fric = 0.0
    if mu is not None:
        fric = mu * h * 0.5 * (abs(vb) + abs(ve))
    force = rec.f * rec.bounded_a * math.cos(xi)
    return force * h * 0.5 * (vb + ve), k * h * 0.5 * (vb * vb + ve * ve), fric


def mc_held_excess(p: Any, omega: float, h: float) -> float:
    """The held force's spectrum at omega against S(omega) (vifpk.core.protocols.
    MonteCarloNoise, ``held_excess``): psi sampled once a step, R(k h) cos(omega k h) =
    (a^2 / 4) r^|k| [cos((Omega - omega) k h) + cos((Omega + omega) k h)], r = e^{-beta h},
    so sum_k = (a^2 / 4) [P(r, (Omega - omega) h) + P(r, (Omega + omega) h)] (ou.poisson_kernel),
    times sinc^2(omega h / 2) h / (2 pi), over avg_spectral_density(omega), minus 1."""
    from vifpk.physics.noise.ou import poisson_kernel
    a, Om, sg = float(p["amplitude"]), float(p["frequency"]), float(p["sigma"])
    r = math.exp(-0.5 * sg * sg * h)
    x = 0.5 * omega * h
    sinc2 = (math.sin(x) / x) ** 2 if x != 0 else 1.0
    held = sinc2 * h / (2.0 * math.pi) * 0.25 * a * a * (
        poisson_kernel(r, (Om - omega) * h) + poisson_kernel(r, (Om + omega) * h))
    return held / float(avg_spectral_density(omega, amplitude=a, frequency=Om, sigma=sg)) - 1.0


# ------------------------------------------------------------------ averaged models
def avg_spectral_density(omega: Any, *, amplitude: float, frequency: float, sigma: float
                         ) -> np.ndarray:
    """S(w) = (a^2 / (4 pi)) [beta / (beta^2 + (w - Omega)^2) + beta / (beta^2 + (w + Omega)^2)],
    beta = sigma^2 / 2, elementwise (module docstring)."""
    w = np.asarray(omega, dtype=float)
    beta = 0.5 * sigma**2
    b2 = beta * beta
    return (amplitude**2 / (4.0 * math.pi)) * (beta / (b2 + (w - frequency) ** 2)
                                               + beta / (b2 + (w + frequency) ** 2))


def avg_correlation_rate(*, amplitude: float, frequency: float, sigma: float) -> float:
    """beta = sigma^2 / 2: the decay rate of the covariance's envelope (its bandwidth)."""
    return 0.5 * sigma**2


def covariance(s: Any, *, amplitude: float, frequency: float, sigma: float) -> np.ndarray:
    """R(s) = E[xi(t) xi(t + s)] = (a^2 / 2) cos(Omega s) exp(-sigma^2 |s| / 2)."""
    s = np.asarray(s, dtype=float)
    return 0.5 * amplitude**2 * np.cos(frequency * s) * np.exp(-0.5 * sigma**2 * np.abs(s))


KIND = NoiseKindSpec(
    name="bounded",
    summary="bounded noise: xi = a cos(Omega t + sigma W + theta), theta uniform, W Wiener",
    params=(Param(name="amplitude", default=None, low=0.0, doc="a: |xi| <= a, E[xi^2] = a^2/2"),
            Param(name="frequency", default=None, low=0.0, low_closed=True,
                  doc="Omega: the centre frequency (0: a random-walk phase)"),
            Param(name="sigma", default=None, low=0.0,
                  doc="sigma: the phase's diffusion, bandwidth sigma^2 / 2")),
    averaging=AveragingNoise(spectral_density=avg_spectral_density,
                             correlation_rate=avg_correlation_rate),
    montecarlo=MonteCarloNoise(Record=MCRecord, record=mc_record, start=mc_start,
                               start_sd=mc_start_sd, bridge=mc_bridge,
                               input_power=mc_input_power, press=mc_press,
                               velocity=mc_velocity, advance=mc_advance, energy=mc_energy,
                               state_start=mc_state_start, held_excess=mc_held_excess),
)
