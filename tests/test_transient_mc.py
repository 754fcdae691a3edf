"""Transient snapshots of the original system's Monte Carlo (montecarlo/transient.py).

Truth: a linear oscillator under white noise, x'' + c x' + x = f W (no barrier, no friction),
is Gaussian given its start: mean e^{Mt} (x0, v0), M = [[0, 1], [-1, -c]], covariance from the
Lyapunov equation S' = M S + S M^T + diag(0, 2 D f^2), S(0) = 0 (solve_ivp, rtol 1e-10).
Started on the orbit of amplitude A0 at a phase uniform in time (a uniform angle, for a linear
spring), the law of x (and of v) at t is the mixture over that phase: 720 phases by the
midpoint rule. Statistical tolerance: chi-square z-score with block errors, |z| < 4.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm
from scipy.stats import norm
from vifpk.montecarlo import PassageSettings
from vifpk.montecarlo.transient import snapshots

from tests.conftest import vary
from vifpk.core.result import BadInput

C, F, D, A0 = 0.2, 1.0, 0.05, 1.5
EDGES = {"edges_A": np.linspace(0, 3, 31), "edges_x": np.linspace(-3, 3, 41),
         "edges_v": np.linspace(-3, 3, 41)}


def linear(base):
    sc = vary(base, c1=-C, c2=0.0, alpha=0.0, mu=0.0, barrier=False, f=F, kind="white", D=D)
    assert sc.system.restoring_law[0] == 1.0
    return sc


def exact_bins(t: float, edges: np.ndarray, which: int) -> np.ndarray:
    M = np.array([[0.0, 1.0], [-1.0, -C]])
    Q = np.diag([0.0, 2 * D * F**2])

    def rhs(_, s):
        S = s.reshape(2, 2)
        return (M @ S + S @ M.T + Q).ravel()

    S = solve_ivp(rhs, (0, t), np.zeros(4), rtol=1e-10, atol=1e-12).y[:, -1].reshape(2, 2)
    th = (np.arange(720) + 0.5) * 2 * math.pi / 720
    mean = expm(M * t) @ np.vstack([A0 * np.cos(th), -A0 * np.sin(th)])
    sd = math.sqrt(S[which, which])
    cdf = norm.cdf((edges[:, None] - mean[which][None, :]) / sd).mean(axis=1)
    return np.diff(cdf) / np.diff(edges)


@pytest.mark.slow
def test_linear_white_noise_snapshots_against_gaussian_mixture(base):
    sc = linear(base)
    times = [0.0, 0.5, 3.0, 10.0]
    st = PassageSettings(paths=20000, blocks=40, dt=0.01, horizon=1.0, seed=4, progress=False)
    res = snapshots(sc.system, sc.noise, st, start=A0, times=times, edges=EDGES)
    sn = res.data["snapshots"]
    np.testing.assert_allclose(sn["t"], times)
    # at t = 0 every path is on the orbit of amplitude A0 = 1.5, a bin edge (round-off of
    # A(x, v) puts it on either side)
    assert (sn["A"]["p"][0][14] + sn["A"]["p"][0][15]) * 0.1 == pytest.approx(1.0)
    for j, t in enumerate(times[1:], start=1):
        for name, which, key in (("x1", 0, "edges_x"), ("x2", 1, "edges_v")):
            ref = exact_bins(t, EDGES[key], which)
            p, err = sn[name]["p"][j], sn[name]["err"][j]
            ok = err > 0
            chi = float(np.sum(((p - ref)[ok] / err[ok]) ** 2))
            z = (chi - ok.sum()) / math.sqrt(2 * ok.sum())
            assert abs(z) < 4, (name, t, z)
    assert res.info["status"]["code"] == "snapshots"


def test_snapshots_input_and_reproducibility(base):
    """Bad times or edges: one line (BadInput); the same seed gives the same histograms."""
    st = PassageSettings(paths=16, blocks=4, dt=0.01, horizon=1.0, seed=2, progress=False)
    kw = dict(start=0.5, times=[0.0, 1.0], edges=EDGES)
    one = snapshots(base.system, base.noise, st, **kw)
    two = snapshots(base.system, base.noise, st, **kw)
    for name in ("A", "x1", "x2"):
        np.testing.assert_array_equal(one.data["snapshots"][name]["p"],
                                      two.data["snapshots"][name]["p"])
    assert one.data["snapshots"]["A"]["p"].shape == (2, 30)
    for bad in (dict(times=[1.0, 0.5]), dict(times=[-1.0]), dict(edges={"edges_A": [0, 1]}),
                dict(start=-1.0)):
        with pytest.raises(BadInput) as err:
            snapshots(base.system, base.noise, st, **dict(kw, **bad))
        assert "\n" not in str(err.value)
