"""First passage of the original system under Stratonovich parametric white noise (issue 37):
the bridge test with the energy's variance rate

    sigma_H^2 = v^2 (2 D f^2 [white external] + 2 D_k g(x)^2 + 2 D_c d(x)^2 v^2)

(montecarlo/passage.py's docstring, by Ito's formula). Truths: the variance against the formula
written here in plain Python; the MFPT's convergence in dt (the bridge-corrected estimate does
not move between dt and dt/2, the discretely monitored one is biased by O(dt^1/2)); intensity
0 is the additive code path, bit for bit.

Slow tier: one compilation of the passage kernel per record type (~10 s from a cold cache; the
discretely monitored run, bridge=False, runs the bridged run's kernel with its terms set to 0),
runs of ~1 s each; the parametric scene's runs are computed once for the module (_ou_parametric).
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from vifpk.montecarlo import PassageSettings, first_passage
from vifpk.montecarlo.passage_kernels import energy_variance
from vifpk.montecarlo.pieces import record
from vifpk.montecarlo.plan import physics

from vifpk.core.scene import scene_from_dict

pytestmark = pytest.mark.slow

# xdist_group: tests that run the same compiled kernel shape go to one worker (CI's --dist
# loadgroup), so it is compiled once rather than by both workers at the same time.
K, W = 0.2, 1.0


def _scene(kind: str, D: float, **system):
    noise = {"kind": kind, "D": D, **({"alpha1": 2.0} if kind == "ou" else {})}
    return scene_from_dict({"system": {"c1": -K, "c2": 0.0, "omega0": W, "alpha": 0.0,
                                       "mu": 0.0, "f": 1.0, "barrier": False, **system},
                            "noise": noise})


def _mfpt(sc, dt, par, bridge=True, paths=8000):
    st = PassageSettings(paths=paths, blocks=16, dt=dt, horizon=1e4, seed=3, threads=1,
                         progress=False)
    res = first_passage(sc.system, sc.noise, st, threshold=1.0, start=0.3, parametric=par,
                        bridge=bridge)
    t = res.data["fpt"]["time"]
    assert res.info["censored"] == 0
    return res, t.mean(), t.std(ddof=1) / math.sqrt(t.size)


_RUNS: dict[tuple[float, bool], tuple] = {}


def _ou_parametric(dt, bridge=True):
    """_mfpt of the parametric scene of the convergence test (OU external noise, D_k = 0.15,
    D_c = 0.1), once per (dt, bridge) for the module: the convergence test and the splitting
    test read the same run at dt = 0.05."""
    if (dt, bridge) not in _RUNS:
        _RUNS[dt, bridge] = _mfpt(_scene("ou", 0.1), dt,
                                  SimpleNamespace(stiffness=0.15, damping=0.1), bridge=bridge)
    return _RUNS[dt, bridge]


def test_variance_is_the_ito_quadratic_variation():
    """energy_variance against sigma_H^2 h written out: a Duffing spring and a quadratic damping
    (so g and d depend on x), white external noise, both parametric terms; each term alone;
    and with the parametric terms off the additive variance bridge v^2 h bit for bit (the
    old code path)."""
    sc = _scene("white", 0.03, alpha=0.7, c2=0.4)
    f, D, DK, DC, h = 1.0, 0.03, 0.02, 0.3, 0.01
    x, vc = 0.8, -1.3
    g = W ** 2 * x + 0.7 * x ** 3
    d = K + 0.4 * x * x  # d(x) = c2 x^2 - c1, c1 = -K
    P = record(physics(sc.system, sc.noise, SimpleNamespace(stiffness=DK, damping=DC)), h)
    want = vc ** 2 * (2 * D * f ** 2 + 2 * DK * g ** 2 + 2 * DC * d ** 2 * vc ** 2) * h
    assert energy_variance(P.bridge, P.pk, P.pc, x, vc, h, P) == pytest.approx(want, rel=1e-12)
    assert energy_variance(None, P.pk, None, x, vc, h, P) == pytest.approx(
        vc ** 2 * 2 * DK * g ** 2 * h, rel=1e-12)
    assert energy_variance(None, None, P.pc, x, vc, h, P) == pytest.approx(
        vc ** 4 * 2 * DC * d ** 2 * h, rel=1e-12)
    assert energy_variance(None, None, None, x, vc, h, P) == 0.0
    assert energy_variance(P.bridge, None, None, x, vc, h, P) == P.bridge * vc * vc * h


@pytest.mark.xdist_group("passage-parametric")
def test_bridge_with_parametric_noise_converges_in_dt():
    """A linear oscillator (k = 0.2, w = 1) under OU external noise (D = 0.1, alpha1 = 2: E is
    C^1 without the parametric noises, so the bridge has only their terms) and parametric noises
    D_k = 0.15, D_c = 0.1 (mean-square stable: k - 2 D_c k^2 - D_k w^2 = 0.042 > 0), from
    A0 = 0.3 to Ac = 1, 8000 paths. Measured (seed 3): with the bridge 33.01, 33.21 (+- 0.34) at
    dt = 0.1, 0.05 (33.30 at 0.025); discretely monitored 36.42, 35.44, 34.65 (+- 0.36): its
    bias halves as dt quarters, O(dt^1/2). Asserted: the corrected MFPT at dt and dt/2 within
    3 combined standard errors; the uncorrected one at dt above the corrected at dt/2 by more
    than 4 (measured 6.4)."""
    res, m1, e1 = _ou_parametric(0.1)
    assert "2 D_k g(x)^2" in res.info["crossing"]["method"]
    assert "2 D f^2" not in res.info["crossing"]["method"]  # OU: no additive term
    _, m2, e2 = _ou_parametric(0.05)
    off, u1, f1 = _ou_parametric(0.1, bridge=False)
    assert "Brownian-bridge" not in off.info["crossing"]["method"]
    assert abs(m1 - m2) < 3 * math.hypot(e1, e2), (m1, m2)
    assert u1 - m2 > 4 * math.hypot(f1, e2), (u1, m2)


@pytest.mark.xdist_group("passage-white")
def test_zero_intensity_is_the_additive_path_bit_for_bit():
    """Parametric intensities 0 reach the kernel as None: the same numbers as no parametric
    noise at all, with white external noise (the bridge's additive term on)."""
    sc = _scene("white", 0.05)
    a, _, _ = _mfpt(sc, 0.1, None, paths=400)
    b, _, _ = _mfpt(sc, 0.1, SimpleNamespace(stiffness=0.0, damping=0.0), paths=400)
    assert np.array_equal(a.data["fpt"]["time"], b.data["fpt"]["time"])
    assert a.info["crossing"] == b.info["crossing"]


@pytest.mark.xdist_group("passage-parametric")
def test_splitting_with_parametric_noise_meets_direct_simulation():
    """The cycle decomposition (splitting_kernels.cycles_orig, advance_orig) with the same bridge
    test at its boundaries, on the scene of the convergence test at dt = 0.05: its MFPT within
    3 combined standard errors of the direct simulation's (measured: 34.14 +- 0.85 against
    33.21 +- 0.34; at dt = 0.1 32.06 +- 0.95)."""
    from vifpk.montecarlo.splitting import SplittingSettings, passage_splitting

    sc = _scene("ou", 0.1)
    par = SimpleNamespace(stiffness=0.15, damping=0.1)
    _, m, e = _ou_parametric(0.05)
    ss = SplittingSettings(groups=40, particles=100, levels=50, dt=0.05, seed=5, cycles=10,
                           paths=10, threads=1)
    r = passage_splitting(sc.system, sc.noise, ss, threshold=1.0, start=0.3, low=0.4,
                          entry=0.6, parametric=par)
    s = r.data["mfpt"]
    assert abs(s["value"] - m) < 3 * math.hypot(s["stderr"], e), (s["value"], m)
