"""Gaussian white noise: xi = W, E[W(t) W(t+s)] = 2 D delta(s) (no state).

Monte Carlo (montecarlo/kernels.py): the velocity stage is B(h/2), the kick
v += f sqrt(2 D h) N, B(h/2) (Strang). The kick's mean power is exactly f^2 D.

Averaged models: the flat two-sided spectral density S(w) = D / pi for every w, so a harmonic
sum of |G_n|^2 S over an orbit is S times Parseval's sum (averaging/exact.py:
sigma_E^2 = 2 pi f^2 S <v^2> = 2 D f^2 <v^2>). No rational split (w^2 S grows without bound):
no ``avg_rational_parts``; no correlation time: no ``avg_correlation_rate``.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

KIND = "white"


class MCRecord(NamedTuple):
    kick: float  # f sqrt(2 D h)


def mc_record(noise: Any, f: float, h: float) -> MCRecord:
    return MCRecord(f * math.sqrt(2.0 * float(noise.D) * h))


def mc_start_sd(noise: Any) -> None:
    """None: no noise state."""
    return None


def mc_bridge(noise: Any, f: float) -> float:
    """2 D f^2: the energy's variance rate per v^2 at the kick."""
    return 2.0 * float(noise.D) * f ** 2


def mc_input_power(noise: Any, f: float) -> float:
    """f^2 D: the mean power of the kicks (Ito: E[d(v^2/2)] = f^2 D dt)."""
    return f ** 2 * float(noise.D)


def mc_press(rec, xi):
    return 0.0


def mc_velocity(flow: Any, normal: Any) -> Any:
    """B(h/2), kick, B(h/2)."""
    def stage(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):
        v, st1 = flow(v, half, -g, k, mu, at_wall)
        vc = v
        z, s0, s1, s2, s3 = normal(s0, s1, s2, s3)
        v += rec.kick * z
        vk = v
        v, st2 = flow(v, half, -g, k, mu, at_wall)
        return v, st1 + st2, vc, vk, v, s0, s1, s2, s3
    return stage


def mc_advance(normal: Any) -> Any:
    """No state: xi unchanged, no random number."""
    def advance(rec, xi, s0, s1, s2, s3):
        return xi, s0, s1, s2, s3
    return advance


def mc_energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi):
    """Input: the kick's exact change of v^2/2; damping and friction by the trapezoid over the
    two half stages."""
    fric = 0.0
    if mu is not None:
        fric = mu * half * 0.5 * (abs(vb) + abs(vc) + abs(vk) + abs(vd))
    return (0.5 * (vk * vk - vc * vc), k * half * 0.5 * (vb * vb + vc * vc + vk * vk + vd * vd),
            fric)


# --------------------------------------------------- the original system's FPK (fpk2d)
def fp_velocity_diffusion(noise: Any, f: float) -> float:
    """D f^2: the diffusion coefficient of the force f xi in v (the FPK term
    D f^2 d^2p/dv^2, E[xi(t) xi(t+s)] = 2 D delta(s))."""
    return float(noise.D) * f ** 2


# ------------------------------------------------------------------ averaged models
def avg_flat_level(*, D: float, alpha1: float) -> float:
    """S(w) = D / pi, the same at every frequency (``alpha1`` unused)."""
    return D / math.pi


def avg_spectral_density(omega: Any, *, D: float, alpha1: float) -> np.ndarray:
    """S(w) = D / pi, elementwise."""
    return np.full_like(np.asarray(omega, dtype=float), avg_flat_level(D=D, alpha1=alpha1))
