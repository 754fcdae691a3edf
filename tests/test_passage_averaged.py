"""The door's averaged time-domain routes (harness.door.timedomain.passage_averaged,
transient_averaged): a model object with a closed-form first passage and transient law, the shipped
models' two routes against each other, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import i0e
from vifpk.harness.door.solvers import SolverFailure
from vifpk.harness.door.timedomain import passage_averaged, transient_averaged

import vifpk
from tests.test_passage_fpk import RC, RV, ray_decay, ray_m, ray_s2, ray_T
from vifpk.core.result import BadInput


class Rayleigh:
    """A plugin-style model object: the Rayleigh amplitude (tests/test_passage_fpk.py)."""

    def drift(self, A):
        return ray_m(A)

    def diffusion(self, A):
        return ray_s2(A)


def rice(A, a0, t):
    """The exact law at time t of the radius of the 2-D OU process started at radius a0:
    centre a0 e^{-ct/2}, variance v (1 - e^{-ct}) per coordinate (Rice's distribution)."""
    mu, s2 = a0 * math.exp(-0.5 * RC * t), RV * (1 - math.exp(-RC * t))
    return A / s2 * np.exp(-((A - mu) ** 2) / (2 * s2)) * i0e(A * mu / s2)


@pytest.fixture(scope="module")
def scene():
    return vifpk.scene("paper-base")


@pytest.mark.slow
def test_passage_of_a_model_object_meets_the_closed_form(scene):
    r = passage_averaged(scene, Rayleigh(), threshold=0.8, start=0.2, cells=200)
    exact = ray_T(0.2, 0.8)
    assert r.info["mfpt"] == pytest.approx(exact, rel=1e-12)  # quadrature: at rounding
    # int R dt and lambda_1 on 200 cells: O(h^2), measured 2.3e-5 and -3.0e-5 relative on this
    # grid; 2e-4 is above the 100-cell error (4x larger at order 2)
    assert r.info["mfpt_integral"] == pytest.approx(exact, rel=2e-4)
    assert r.info["decay_rate"] == pytest.approx(ray_decay(0.8), rel=2e-4)
    assert r.info["model"] == "Rayleigh" and r.info["status"]["ok"]
    R = r.data["R"]["R"]
    assert R[0] == 1.0 and np.all(np.diff(R) <= 1e-15) and r.data["mfpt_curve"]["T"][-1] == 0


@pytest.mark.slow
def test_transient_of_a_model_object_meets_the_rice_law(scene):
    times = [2.0, 5.0, 20.0]
    errs = []
    for cells in (200, 400):
        r = transient_averaged(scene, Rayleigh(), start=0.3, times=times, cells=cells,
                               phase=False)
        s = r.data["snapshots"]
        h = r.info["grid"]["h"]
        assert np.allclose(s["p"].sum(axis=1) * h, 1.0, atol=1e-9)
        errs.append([float(np.sum(np.abs(p - rice(s["x"], 0.3, t))) * h)
                     for t, p in zip(s["t"], s["p"], strict=True)])
        # the slowest rate of the radial 2-D OU is c (eigenvalues -c k): tau = 1 / c
        assert r.info["relaxation_time"] == pytest.approx(1 / RC, rel=1e-3)
    errs = np.array(errs)
    # O(h^2) from the scheme and from the start's width h: halving h divides the L1 by 4
    # (measured 3.996-3.999 for 200 -> 400 -> 800 cells; L1 at 400 cells 1.2e-4, 4.2e-5,
    # 1.3e-5 at t = 2, 5, 20); asked: a ratio within 0.2 of 4 and the 400-cell L1 < 3e-4
    assert np.allclose(errs[0] / errs[1], 4.0, atol=0.2), errs
    assert np.all(errs[1] < 3e-4), errs


def test_bad_input_and_no_noise(scene):
    with pytest.raises(BadInput, match="start amplitude"):
        passage_averaged(scene, "paper", threshold=0.5, start=0.6)
    with pytest.raises(BadInput, match="threshold"):
        passage_averaged(scene, "paper", threshold=-1.0, start=0.0)
    with pytest.raises(BadInput, match="times"):
        transient_averaged(scene, "paper", start=0.5, times=[-1.0])
    with pytest.raises(SolverFailure, match="no noise"):
        passage_averaged(scene.with_values({"system.f": 0.0}), "paper", threshold=0.5,
                         start=0.2)


@pytest.mark.slow
@pytest.mark.parametrize("model", ["paper", "exact"])
def test_shipped_models_two_routes_agree(scene, model):
    """Quadrature MFPT = int R dt on paper-base, stationary start below Ac = 0.8 (MFPT of order
    10^2-10^3). Tolerance from the grids: |I_200 - I_400| (3x the O(h^2) error of I_400)
    plus the time-integration gap and the quadrature's estimate."""
    runs = [passage_averaged(scene, model, threshold=0.8, start="stationary", cells=n)
            for n in (200, 400)]
    q = runs[1].info["mfpt"]
    i200, i400 = (r.info["mfpt_integral"] for r in runs)
    d = runs[1].info["diagnostics"]
    assert abs(q - i400) <= abs(i200 - i400) + d["time_integration_gap"] + runs[1].info[
        "mfpt_error"]
    assert d["mass_balance"] < 1e-10
    assert math.isfinite(runs[1].info["decay_rate"]) and runs[1].info["decay_rate"] > 0
