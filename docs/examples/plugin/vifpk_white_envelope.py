"""An averaged model from outside vifpk: the white-noise energy envelope (docs/plugins.md).

The standard energy-envelope averaging of the vibro-impact Duffing oscillator with the sgn(y)
factor dropped ("additive" noise, the paper's assumption), exact for white noise, written in a
few lines of numpy as a user would. Registered under the entry-point group ``vifpk.models``
(pyproject.toml beside this file), it works everywhere a built-in model does.

The averaged-model protocol (docs/plugins.md): a callable taking the scene and returning an
object with ``drift(A)`` and ``diffusion(A)``; ``period(A)`` is optional (this model gives
none: vifpk maps p(A) to phase space with the exact orbit's period) and so is a closed form
(``log_stationary_parts``: without one, vifpk gets p(A) from the FPK direct solve).

It reads the scene's laws as coefficient lists (``system.restoring_law`` k = (k1, k3),
``system.damping_law`` d = (d0, d2)), which every scene has however it was written (the
paper's names omega0, alpha, c1, c2 are None in a scene written with law lists), and says
with ``applies`` where it holds: a spring k1 x + k3 x^3, damping (d0 + d2 x^2) x', no
velocity-dependent damping. Elsewhere vifpk refuses it in one line (exit 2) when named, and
skips it with that line in a report when it is a default.
"""

from __future__ import annotations

import math

import numpy as np


class WhiteNoiseEnvelope:
    """dA = m dt + sigma dB for the Duffing oscillator under WHITE noise (exact for it):
    the energy drift c1 <v^2> - c2 <x^2 v^2> - impact and friction losses, plus D f^2;
    sigma_E^2 = 2 D f^2 <v^2>; in amplitude form by Ito's rule (A = U^{-1}(E))."""

    @staticmethod
    def applies(scene):
        """None where the model holds, else one line saying why not (vifpk asks first)."""
        s = scene.system
        k, d, e = (list(s.restoring_law), list(s.damping_law), list(s.velocity_law))
        while len(k) > 2 and k[-1] == 0:
            k.pop()
        while len(d) > 2 and d[-1] == 0:
            d.pop()
        if len(k) > 2:
            return f"white-envelope covers springs k1 x + k3 x^3 only, not restoring = {k}"
        if len(d) > 2:
            return f"white-envelope covers damping (d0 + d2 x^2) x' only, not damping = {d}"
        if any(e):
            return "white-envelope has no velocity-dependent damping (velocity_damping)"
        walls = s.walls_problem()  # vifpk.core.system.System: None for the paper's wall
        if walls is not None:
            return f"white-envelope covers the paper's wall only, not {walls}"
        if scene.parametric.on:
            return "white-envelope has no parametric noise (parametric.stiffness, .damping)"
        return None

    def __init__(self, scene):
        s, n = scene.system, scene.noise
        why = self.applies(scene)
        if why is not None:  # called directly, without asking applies first
            raise ValueError(why)
        k = list(s.restoring_law) + [0.0, 0.0]
        d = list(s.damping_law) + [0.0, 0.0]
        self.k1, self.k3 = float(k[0]), float(k[1])
        self.c1, self.c2 = -float(d[0]), float(d[1])  # force (d0 + d2 x^2) x'
        self.mu, self.r, self.f = s.mu, s.r, s.f
        self.D = n.D

    def _orbit(self, A):
        th = np.arange(64) * math.pi / 64
        w0sq, a = self.k1, self.k3
        nu = np.sqrt(w0sq + 0.5 * a * A[:, None] ** 2 * (1 + np.cos(th) ** 2))
        T = 2 * math.pi * np.mean(1 / nu, axis=1)
        v2 = A**2 * 2 * math.pi * np.mean(nu * np.sin(th) ** 2, axis=1) / T
        x2v2 = A**4 * 2 * math.pi * np.mean(nu * np.sin(th) ** 2 * np.cos(th) ** 2, axis=1) / T
        return T, v2, x2v2

    def drift(self, A):
        A = np.asarray(A, float)
        T, v2, x2v2 = self._orbit(A)
        E = 0.5 * self.k1 * A**2 + 0.25 * self.k3 * A**4
        mE = (self.c1 * v2 - self.c2 * x2v2 - self.mu * 4 * A / T
              - 2 / T * (1 - self.r**2) * E + self.D * self.f**2)
        g = self.k1 * A + self.k3 * A**3
        gp = self.k1 + 3 * self.k3 * A**2
        s2E = 2 * self.D * self.f**2 * v2
        return mE / g - gp * s2E / (2 * g**3)

    def diffusion(self, A):
        A = np.asarray(A, float)
        _, v2, _ = self._orbit(A)
        g = self.k1 * A + self.k3 * A**3
        return 2 * self.D * self.f**2 * v2 / g**2
