"""The few lines of oscillator geometry the Monte Carlo needs, kept apart from ``averaging``
so that a bug there cannot hide here too.

    E = v^2/2 + omega0^2 x^2/2 + alpha x^4/4
    A = U^{-1}(E):  A^2 = 4E / (w0^2 + sqrt(w0^4 + 4 alpha E))
"""

from __future__ import annotations

import math

from ._jit import jit


@jit
def amplitude(x: float, v: float, w0sq: float, alpha: float) -> float:
    """Amplitude of the conservative orbit through (x, v): U(A) = v^2/2 + U(x)."""
    E = 0.5 * v * v + 0.5 * w0sq * x * x + 0.25 * alpha * x * x * x * x
    return math.sqrt(4.0 * E / (w0sq + math.sqrt(w0sq * w0sq + 4.0 * alpha * E)))
