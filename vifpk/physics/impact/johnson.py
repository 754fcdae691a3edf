"""Elastic-plastic impact (Johnson, Contact Mechanics, Cambridge 1985, sec. 11.4): above the
yield speed the coefficient of restitution falls as v^(-1/4),

    e(v) = r                          for |v| <= v_yield,
    e(v) = r (v_yield / |v|)^(1/4)    above.

With r = 1 it is elastic below yield; v_yield -> infinity is Newton's law.
"""

from __future__ import annotations

import math

NAME = "johnson"


def restitution(speed, r, v_yield):
    """e(|v|) of the module docstring."""
    if speed <= v_yield:
        return r
    return r * math.sqrt(math.sqrt(v_yield / speed))


def energy_loss(speed, r, v_yield):
    """(1 - e^2) v^2 / 2."""
    e = r if speed <= v_yield else r * math.sqrt(math.sqrt(v_yield / speed))  # restitution
    return 0.5 * (1.0 - e * e) * speed * speed
