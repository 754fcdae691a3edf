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
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

TWO_PI = 2.0 * math.pi


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
