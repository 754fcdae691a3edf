"""The held noise force's bias in the step rule (issue 44; montecarlo/tuning.py, "Held noise").

A kind whose velocity stage holds its force over a step declares the relative error of the
held force's spectrum at an orbit frequency (MonteCarloNoise.held_excess, a closed form per
kind). Checked here against an independent computation from the kind's declared spectral
density alone: the zero-order hold of a sequence sampled every h has the spectrum
sinc^2(w h / 2) sum_k S(w + 2 pi k / h) (the sampling theorem's aliases), summed directly to
|k| <= 20000 with the tail's c / w^2 remainder (c = lim w^2 S); and the rule reads it from
the declaration, not from a kind's name: white (no hold) adds nothing, a fast OU shortens
the step to where (alpha1 dt)^2 / 12 = BIAS_FRACTION x F, the shipped noises keep theirs.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from vifpk.montecarlo import tuning
from vifpk.montecarlo.plan import physics

from vifpk.core.scene import load_scene
from vifpk.physics.noise import bounded, ou, white


def _aliases(S, omega: float, h: float, tail_c: float, K: int = 20000) -> float:
    """sinc^2(omega h / 2) sum_k S(omega + 2 pi k / h) / S(omega) - 1, by brute force."""
    k = np.arange(-K, K + 1)
    total = float(np.sum(S(omega + 2 * math.pi * k / h)))
    total += 2 * tail_c * (h / (2 * math.pi)) ** 2 / K  # sum_{|k| > K} c / (2 pi k / h)^2
    x = 0.5 * omega * h
    return (math.sin(x) / x) ** 2 * total / float(S(np.array([omega]))[0]) - 1.0


@pytest.mark.parametrize("alpha1, omega, h", [(2.0, 1.14, 0.025), (20.0, 1.0, 0.05),
                                             (5.0, 2.0, 0.2)])
def test_ou_held_excess_is_the_sum_of_its_aliases(alpha1, omega, h):
    p = {"D": 0.3, "alpha1": alpha1}

    def S(w):
        return ou.avg_spectral_density(w, **p)

    want = _aliases(S, omega, h, tail_c=0.3 / math.pi)
    assert ou.mc_held_excess(p, omega, h) == pytest.approx(want, rel=1e-4, abs=1e-9)
    # and its leading term, (alpha1 h)^2 / 12 (the omega^2 parts cancel)
    if alpha1 * h < 0.2:
        assert ou.mc_held_excess(p, omega, h) == pytest.approx((alpha1 * h) ** 2 / 12, rel=0.01)


@pytest.mark.parametrize("freq, sigma, omega, h", [(1.2, 2.0, 1.4, 0.025), (1.2, 2.0, 0.5, 0.1),
                                                   (6.0, 0.5, 1.0, 0.4)])
def test_bounded_held_excess_is_the_sum_of_its_aliases(freq, sigma, omega, h):
    p = {"amplitude": 0.1, "frequency": freq, "sigma": sigma}

    def S(w):
        return bounded.avg_spectral_density(w, **p)

    beta = sigma**2 / 2
    want = _aliases(S, omega, h, tail_c=0.1**2 / (4 * math.pi) * 2 * beta)
    assert bounded.mc_held_excess(p, omega, h) == pytest.approx(want, rel=1e-4, abs=1e-9)


def _phys(name: str, **noise: float):
    sc = load_scene(name)
    nz = sc.noise
    if noise:
        nz = dataclasses.replace(nz, params=tuple((k, noise.get(k, v)) for k, v in nz.params))
    return physics(sc.system, nz, getattr(sc, "parametric", None))


def test_the_rule_reads_the_declaration():
    """White declares no hold (exact in law over a step); OU at alpha1 = 2 (the envelope's
    own noise) keeps the envelope's steps, the shipped bounded scene (sigma = 2) within 1%; OU at
    alpha1 = 40 is shortened until the envelope plus (40^2 - 2^2) dt^2 / 12 is F / 2."""
    assert white.KIND.montecarlo.held_excess is None
    base = _phys("paper-base")
    omegas = tuning.orbit_omegas(base, 0.8)
    assert 1e-4 < tuning.hold_bias(base, omegas, 0.025) < 3e-4
    env_only = dict(base, noise=None)
    for F in (0.005, 0.01, 0.02):
        assert tuning.auto_dt(F, base, 0.8) == tuning.auto_dt(F, env_only, 0.8)
    bnd = _phys("systems/bilateral-duffing-bounded")
    assert tuning.auto_dt(0.005, bnd, 0.8) == pytest.approx(  # 1.06 x OU's (2 dt)^2 / 12
        tuning.auto_dt(0.005, dict(bnd, noise=None), 0.8), rel=0.01)
    fast = _phys("paper-base", alpha1=40.0)
    dt = tuning.auto_dt(0.005, fast, 0.8)
    assert dt < 0.5 * tuning.auto_dt(0.005, base, 0.8)
    env = tuning.BIAS_C * (tuning.scene_rate(fast, 0.8) * dt / tuning.OMEGA_REF) ** 1.5
    assert env + ((40.0 * dt) ** 2 - (2.0 * dt) ** 2) / 12 == pytest.approx(
        tuning.BIAS_FRACTION * 0.005, rel=0.01)
    assert tuning.predicted_bias(fast, 0.8, dt) == pytest.approx(
        tuning.BIAS_FRACTION * 0.005, rel=1e-4)
