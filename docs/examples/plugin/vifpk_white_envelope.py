"""An averaged model from outside vifpk: the white-noise energy envelope (docs/plugins.md).

The standard energy-envelope averaging of the vibro-impact Duffing oscillator with the sgn(y)
factor dropped ("additive" noise, the paper's assumption), exact for white noise, written in a
few lines of numpy as a user would. Registered under the entry-point group ``vifpk.models``
(pyproject.toml beside this file), it works everywhere a built-in model does.

The averaged-model protocol (docs/testing.md): a callable taking the scene and returning an
object with ``drift(A)`` and ``diffusion(A)``; ``period(A)`` is optional (this model gives
none: vifpk maps p(A) to phase space with the exact orbit's period) and so is a closed form
(``log_stationary_parts``: without one, vifpk gets p(A) from the FPK direct solve).
"""

from __future__ import annotations

import math

import numpy as np


class WhiteNoiseEnvelope:
    """dA = m dt + sigma dB for the Duffing oscillator under WHITE noise (exact for it):
    the energy drift c1 <v^2> - c2 <x^2 v^2> - impact and friction losses, plus D f^2;
    sigma_E^2 = 2 D f^2 <v^2>; in amplitude form by Ito's rule (A = U^{-1}(E))."""

    def __init__(self, scene):
        s, n = scene.system, scene.noise
        self.s, self.D = s, n.D

    def _orbit(self, A):
        th = np.arange(64) * math.pi / 64
        w0sq, a = self.s.omega0 ** 2, self.s.alpha
        nu = np.sqrt(w0sq + 0.5 * a * A[:, None] ** 2 * (1 + np.cos(th) ** 2))
        T = 2 * math.pi * np.mean(1 / nu, axis=1)
        v2 = A**2 * 2 * math.pi * np.mean(nu * np.sin(th) ** 2, axis=1) / T
        x2v2 = A**4 * 2 * math.pi * np.mean(nu * np.sin(th) ** 2 * np.cos(th) ** 2, axis=1) / T
        return T, v2, x2v2

    def drift(self, A):
        A = np.asarray(A, float)
        s = self.s
        T, v2, x2v2 = self._orbit(A)
        E = 0.5 * s.omega0**2 * A**2 + 0.25 * s.alpha * A**4
        mE = (s.c1 * v2 - s.c2 * x2v2 - s.mu * 4 * A / T - 2 / T * (1 - s.r**2) * E
              + self.D * s.f**2)
        g = s.omega0**2 * A + s.alpha * A**3
        gp = s.omega0**2 + 3 * s.alpha * A**2
        s2E = 2 * self.D * s.f**2 * v2
        return mE / g - gp * s2E / (2 * g**3)

    def diffusion(self, A):
        A = np.asarray(A, float)
        _, v2, _ = self._orbit(A)
        g = self.s.omega0**2 * A + self.s.alpha * A**3
        return 2 * self.D * self.s.f**2 * v2 / g**2
