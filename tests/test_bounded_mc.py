"""Bounded noise in the Monte Carlo (issue 43 item 5), on the lightly damped linear oscillator
whose stationary second moments are integrals of the spectrum (no vifpk code in the truth but
the closed form of S, itself checked against the covariance in test_bounded_averaging.py):

    x'' + 2 zeta x' + x = f xi,   xi = a cos(Omega t + sigma W + theta),
    E[x^2] = int_{-inf}^{inf} |H(w)|^2 S(w) f^2 dw,   E[v^2] = int w^2 |H(w)|^2 S(w) f^2 dw,
    H(w) = 1 / (1 - w^2 + 2 i zeta w),

S two-sided (int S dw = E[xi^2] = a^2 / 2). At stationarity the power put in equals the
damping's, 2 zeta E[v^2] (the counted input of the kernel's energy bookkeeping).

Slow tier: one kernel shape (bounded noise, no wall; ~20 s cold), runs of a few seconds.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from vifpk.montecarlo.simulate import Settings, simulate

from vifpk.core.scene import scene_from_dict
from vifpk.physics.noise import bounded

pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("bounded-linear")]

ZETA, F = 0.05, 1.0
NOISE = {"amplitude": 0.3, "frequency": 1.2, "sigma": 1.0}
SCENE = scene_from_dict({"system": {"restoring": [1.0], "damping": [2 * ZETA], "mu": 0.0,
                                    "f": F, "barrier": False},
                         "noise": {"kind": "bounded", **NOISE}})
EDGES = {"edges_A": np.linspace(0, 5, 21), "edges_x": np.linspace(-5, 5, 21),
         "edges_v": np.linspace(-5, 5, 21)}


def _response(power: int) -> float:
    """int w^power |H(w)|^2 S(w) f^2 dw over the real line (S even: twice the half line)."""
    def g(w: float) -> float:
        H2 = 1.0 / ((1.0 - w * w) ** 2 + (2.0 * ZETA * w) ** 2)
        return w**power * H2 * float(bounded.avg_spectral_density(w, **NOISE)) * F**2
    half, _ = quad(g, 0.0, np.inf, points=None, epsabs=0, epsrel=1e-11, limit=500)
    return 2.0 * half


XX, VV = _response(0), _response(2)


def _run(h: float, *, seed: int = 7, time: float = 2000.0):
    st = Settings(paths=512, blocks=16, dt=h, time=time, burn_in=120.0, seed=seed, bins=20,
                  threads=1, floor=0.0, budget=0.0, sample_every=0.4, progress=False,
                  certificate=False, observables=("moments", "energy"), edges=EDGES)
    return simulate(SCENE.system, SCENE.noise, st)


def test_the_linear_oscillators_variances_and_power_balance() -> None:
    """E[x^2] and E[v^2] within 3 block standard errors of the spectral integrals (a two-sided
    S taken one-sided, or a phase started at 0, or Omega h dropped from the update, is off by
    tens of standard errors), and the counted input power within 3 standard errors of
    2 zeta E[v^2] (the power the damping takes)."""
    res = _run(0.05)
    m = res.info["moments"]
    for key, truth in (("x1", XX), ("x2", VV)):
        got = m[key]["second"]
        assert abs(got["value"] - truth) < 3 * got["err"], (key, got, truth)
        assert got["err"] < 0.03 * truth  # the run resolves a 10% error
    en = res.info["energy"]
    assert abs(en["input"]["value"] - 2 * ZETA * VV) < 3 * en["input"]["err"], en["input"]
