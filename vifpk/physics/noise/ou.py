"""Ornstein-Uhlenbeck noise: xi' + alpha1 xi = W, E[W(t) W(t+s)] = 2 D delta(s).

Averaged models: two-sided spectral density S(w) = (1/pi) int_0^inf R(t) cos(w t) dt
= D / (pi (w^2 + alpha1^2)) (Liu et al., Symmetry 2019, eq. 18), with the rational identity
w^2 S(w) = c - a2 S(w), c = D / pi, a2 = alpha1^2, that lets a harmonic sum of w^2 S be split
into a Parseval sum and a fast-decaying remainder (averaging/exact.py).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def spectral_density(omega: Any, *, D: float, alpha1: float) -> np.ndarray:
    """S(w) = D / (pi (w^2 + alpha1^2)), elementwise."""
    omega = np.asarray(omega, dtype=float)
    return D / (math.pi * (omega**2 + alpha1**2))


def rational_parts(*, D: float, alpha1: float) -> tuple[float, float]:
    """(c, a2) = (D / pi, alpha1^2): w^2 S(w) = c - a2 S(w) for every w."""
    return D / math.pi, alpha1**2


def correlation_rate(*, D: float, alpha1: float) -> float:
    """1 / (correlation time) = alpha1: R(t) = (D / alpha1) exp(-alpha1 |t|)."""
    return alpha1
