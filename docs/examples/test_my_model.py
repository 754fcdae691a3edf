"""How a researcher pins the accuracy of their own averaged model (run by vifpk's own tests).

We re-implement, as a user would, the standard energy-envelope averaging of the vibro-impact
Duffing oscillator with the sgn(y) factor dropped ("additive" noise, the paper's assumption),
in a few lines of numpy, and check it against the Monte Carlo of the original system.

    pytest docs/examples/test_my_model.py --vifpk-cache .vifpk-cache

The first run pays for the Monte Carlo reference; later runs load it from the cache.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from harness.testing import assert_averaging_error

# a small, fast reference for the example (the default scene settings are bigger)
MC = {"paths": 256, "time": 1000.0}


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


def test_my_model_is_accurate_under_white_noise(vifpk_scene):
    """Under white noise the sgn(y) factor does not matter: the model is good (L1 0.021)."""
    scene = vifpk_scene("paper-base", **{"noise.kind": "white"})
    assert_averaging_error(scene, WhiteNoiseEnvelope(scene), below=0.08, **MC)


def test_the_same_model_fails_under_real_noise(vifpk_scene):
    """Under OU noise the white-noise model is wrong (L1 1.165); what the failure looks like."""
    scene = vifpk_scene("paper-base")
    with pytest.raises(AssertionError) as failure:
        assert_averaging_error(scene, WhiteNoiseEnvelope(scene), below=0.08, **MC)
    message = str(failure.value)
    print(message)
    assert "averaging error of WhiteNoiseEnvelope on p(A): L1 =" in message
    assert "reproduce: vifpk solve" in message
