"""Gaussian white noise: xi = W, E[W(t) W(t+s)] = 2 D delta(s).

Averaged models: the flat two-sided spectral density S(w) = D / pi for every w, so a harmonic
sum of |G_n|^2 S over an orbit is S times Parseval's sum (averaging/exact.py:
sigma_E^2 = 2 pi f^2 S <v^2> = 2 D f^2 <v^2>). No rational split (w^2 S grows without bound):
this module declares no ``rational_parts``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def flat_level(*, D: float, alpha1: float) -> float:
    """S(w) = D / pi, the same at every frequency (``alpha1`` unused)."""
    return D / math.pi


def spectral_density(omega: Any, *, D: float, alpha1: float) -> np.ndarray:
    """S(w) = D / pi, elementwise."""
    return np.full_like(np.asarray(omega, dtype=float), flat_level(D=D, alpha1=alpha1))
