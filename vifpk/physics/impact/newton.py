"""Newton's restitution: x'(+) = -r x'(-), e(v) = r for every impact speed (the paper's law)."""

from __future__ import annotations

NAME = "newton"


def restitution(speed, r, v_yield):
    """e = r (``v_yield`` unused)."""
    return r


def energy_loss(speed, r, v_yield):
    """(1 - r^2) v^2 / 2."""
    return 0.5 * (1.0 - r * r) * speed * speed
