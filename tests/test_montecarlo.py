"""Monte Carlo of the original system against exact results.

Statistical tolerances use the batch error bars: under the null hypothesis the chi-square
z-score z = (chi2 - n) / sqrt(2 n) is about N(0, 1), and we fail beyond |z| = 4 (a false
alarm once in ~16000 runs; the seeds are fixed, so a run either passes or fails for good).
"""

from __future__ import annotations

import math
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats
from scipy.integrate import quad

import montecarlo as mc
from montecarlo import kernels as K
from montecarlo.averaged_sde import simulate_sde
from montecarlo.rng import fill_normals, states_from_seed

from .conftest import vary

FIXED = {"edges_A": np.linspace(0, 2, 41), "edges_x": np.linspace(-2, 2, 41),
         "edges_v": np.linspace(-2, 2, 41)}


def chi_z(est, err, ref):
    ok = err > 0
    chi = float(np.sum(((est - ref)[ok] / err[ok]) ** 2))
    n = int(ok.sum())
    return (chi - n) / math.sqrt(2 * n)


def bin_average(f, edges):
    pairs = zip(edges[:-1], edges[1:], strict=True)
    return np.array([quad(f, a, b)[0] / (b - a) for a, b in pairs])


# ------------------------------------------------------------------------------- rng
def test_normals_quality():
    st = states_from_seed(123, 1)[0].copy()
    x = np.empty(2_000_000)
    fill_normals(st, x)
    n = x.size
    assert abs(x.mean()) < 5 / math.sqrt(n)
    assert abs(x.var() - 1) < 5 * math.sqrt(2 / n)
    assert abs(stats.kurtosis(x)) < 5 * math.sqrt(24 / n)
    assert stats.kstest(x, "norm").pvalue > 1e-4
    tail = np.mean(np.abs(x) > 3.5)
    expect = 2 * stats.norm.sf(3.5)
    assert abs(tail - expect) < 5 * math.sqrt(expect / n)
    assert abs(np.corrcoef(x[:-1], x[1:])[0, 1]) < 5 / math.sqrt(n)


def test_block_states_are_distinct_and_reproducible():
    a, b = states_from_seed(7, 16), states_from_seed(7, 16)
    assert np.array_equal(a, b) and len({tuple(r) for r in a}) == 16


# ------------------------------------------------------------------------------- flows
def test_velocity_flow_without_friction_is_the_linear_solution():
    v, F, k, tau = 0.3, -0.7, 0.2, 0.05
    got, stuck = K.velocity_flow(v, tau, F, k, None, False)
    assert got == pytest.approx(v * math.exp(-k * tau) + F / k * (1 - math.exp(-k * tau)),
                                rel=1e-12)
    assert stuck == 0.0


def test_stick_slip_rules():
    mu = 0.1
    # at rest under |F| <= mu: stays stuck for the whole sub-step
    assert K.velocity_flow(0.0, 0.05, 0.05, 0.0, mu, False) == (0.0, 0.05)
    # sliding to rest under friction alone (F = 0, k = 0): t* = v / mu, then stuck
    v, st = K.velocity_flow(0.002, 0.05, 0.0, 0.0, mu, False)
    assert v == 0.0 and st == pytest.approx(0.05 - 0.002 / mu, rel=1e-12)
    # crossing under a strong force: slip the other way with F + mu
    v0, F, tau = 0.002, -0.5, 0.05
    t_star = v0 / (mu - F)
    v, st = K.velocity_flow(v0, tau, F, 0.0, mu, False)
    assert st == 0.0 and v == pytest.approx((F + mu) * (tau - t_star), rel=1e-12)
    # crossing with damping (k != 0): root of v e^{-kt} + F'(1-e^{-kt})/k = 0
    k = 0.3
    v, _ = K.velocity_flow(v0, tau, F, k, mu, False)
    Fp = F - mu
    t_star = math.log1p(-k * v0 / Fp) / k
    assert v0 * math.exp(-k * t_star) + Fp * (1 - math.exp(-k * t_star)) / k == pytest.approx(
        0, abs=1e-15)
    rest = tau - t_star
    assert v == pytest.approx((F + mu) * (1 - math.exp(-k * rest)) / k, rel=1e-10)
    # at the wall the wall holds any pressing force; only a pull > mu frees the mass
    assert K.velocity_flow(0.0, 0.05, -5.0, 0.0, mu, True) == (0.0, 0.05)
    assert K.velocity_flow(0.0, 0.05, 0.5, 0.0, mu, True)[0] > 0


def test_impact_energy_loss_is_one_minus_r_squared():
    for r in (1.0, 0.96, 0.5):
        x0, v0, tau = 0.01, -1.0, 0.05
        x, v, imp, chatter = K.drift(x0, v0, tau, r, 0.0, tau)
        assert imp == 1 and chatter == 0
        # at the wall U(0) = 0: E = v^2/2 before and after
        assert 0.5 * v * v == pytest.approx(r * r * 0.5 * v0 * v0, rel=1e-14)
        assert x == pytest.approx(r * abs(v0) * (tau - x0 / abs(v0)), rel=1e-14)


def test_chatter_guard_rests_the_mass():
    x, v, imp, chatter = K.drift(1e-7, -1e-4, 0.005, 0.5, 1.0, 0.01)
    assert (x, v, imp, chatter) == (0.0, 0.0, 1, 1)
    x, v, imp, chatter = K.drift(1e-7, -1e-4, 0.005, 0.5, -1.0, 0.01)  # pulled away: bounce
    assert chatter == 0 and v > 0


# ------------------------------------------------------------------------------- exact densities
@pytest.mark.parametrize("barrier", [False, True])
def test_gibbs_density_white_noise_linear_damping(base, barrier):
    """c2 = 0, c1 = -g < 0, mu = 0, white noise: p(x, v) ~ exp(-g H / (D f^2)); with an elastic
    barrier (r = 1) the same density folded onto x > 0."""
    g, D = 0.2, 0.02
    sc = vary(base, c1=-g, c2=0.0, mu=0.0, r=1.0, barrier=barrier, kind="white", D=D)
    res = mc.simulate(sc.system, sc.noise, paths=512, blocks=32, dt=0.02, time=2000,
                      burn_in=50, sample_every=1.0, progress=False,
                      observables=("x1", "x2", "events"))
    T = D / g
    fold = 2.0 if barrier else 1.0

    def U(x):
        return 0.5 * x * x + 0.15 * x**4

    Z = quad(lambda x: math.exp(-U(x) / T), -np.inf, np.inf)[0]
    refs = {"x1": lambda x: fold * math.exp(-U(x) / T) / Z,
            "x2": lambda v: math.exp(-v * v / (2 * T)) / math.sqrt(2 * math.pi * T)}
    for name, f in refs.items():
        d = res.data[name]
        assert abs(chi_z(d["p"], d["err"], bin_average(f, d["edges"]))) < 4
    rate = res.info["events"]["impacts_per_time"]["value"]
    assert (rate > 0.3) if barrier else (rate == 0.0)


def test_friction_gives_a_measurable_stuck_fraction(base):
    common = dict(paths=64, blocks=16, time=500, burn_in=100, progress=False, edges=FIXED,
                  observables=("events",))
    sc = vary(base, mu=0.1)
    ev = mc.simulate(sc.system, sc.noise, **common).info["events"]["stuck_fraction"]
    assert ev["value"] > 0.01 and ev["value"] > 10 * ev["err"]
    sc0 = vary(base, mu=0.0)
    assert mc.simulate(sc0.system, sc0.noise, **common).info["events"]["stuck_fraction"][
        "value"] == 0.0


def test_switched_off_effects_are_not_compiled(tmp_path):
    """With mu = None numba prunes the friction branches: the machine code of that
    specialisation has no root finder for the velocity zero (log1p) and no stick test.
    Compiled fresh in a subprocess (numba cannot inspect code loaded from its cache)."""
    code = """
import montecarlo.kernels as K
K.velocity_flow(0.1, 0.01, 0.0, 0.2, None, False)
K.velocity_flow(0.1, 0.01, 0.0, 0.2, 0.1, False)
for sig in K.velocity_flow.signatures:
    print(str(sig[4]), "log1p" in K.velocity_flow.inspect_asm(sig))
"""
    env = dict(__import__("os").environ, NUMBA_CACHE_DIR=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                         check=True).stdout.split()
    assert out == ["none", "False", "float64", "True"], out


def test_same_seed_same_histograms_for_any_thread_count(base):
    kw = dict(paths=32, blocks=8, time=100, burn_in=20, progress=False, edges=FIXED, seed=99)
    one = mc.simulate(base.system, base.noise, threads=1, **kw)
    two = mc.simulate(base.system, base.noise, threads=2, **kw)
    for key in ("A", "x1", "x2"):
        assert np.array_equal(one.data[key]["p"], two.data[key]["p"])
    assert one.info["events"] == two.info["events"]
    other = mc.simulate(base.system, base.noise, threads=2, **dict(kw, seed=100))
    assert not np.array_equal(one.data["A"]["p"], other.data["A"]["p"])


def test_weak_order_on_the_smooth_subsystem(base):
    """Linear oscillator (alpha = 0, c2 = 0, no barrier, no friction) under OU noise:
    E[v^2] = f^2 int w^2 |H|^2 S dw exactly. The bias of the splitting must fall at the
    declared weak order 2 (measured bias 7.8%, 4.0%, 2.0%, 0.9% at dt = 0.4 ... 0.141; the
    batch error is ~0.08%)."""
    g, D, a1 = 0.5, 0.05, 1.0
    sc = vary(base, c1=-g, c2=0.0, alpha=0.0, mu=0.0, barrier=False, D=D, alpha1=a1)
    exact = quad(lambda w: w * w / ((1 - w * w) ** 2 + (g * w) ** 2) * D
                 / (math.pi * (w * w + a1 * a1)), -np.inf, np.inf, epsabs=1e-14)[0]
    dts = np.array([0.4, 0.2828, 0.2, 0.1414])
    bias = []
    for dt in dts:
        r = mc.simulate(sc.system, sc.noise, paths=256, blocks=64, dt=float(dt), time=40000,
                        burn_in=50, sample_every=2.0, progress=False, observables=("moments",),
                        edges=FIXED)
        v2 = r.info["moments"]["x2"]["second"]
        assert v2["err"] < 0.1 * abs(v2["value"] - exact)  # bias resolved above noise
        bias.append(abs(v2["value"] - exact))
    slope = np.polyfit(np.log(dts), np.log(bias), 1)[0]
    assert slope == pytest.approx(2.0, abs=0.35), bias


@pytest.mark.parametrize("params", [dict(r=0.5), dict(mu=0.1), dict(D=1e-5), dict(alpha1=50.0),
                                    dict(r=0.3, mu=0.2), dict(kind="white", r=0.5)])
def test_hard_cases_finish_finite_normalised(base, params):
    sc = vary(base, **params)
    res = mc.simulate(sc.system, sc.noise, paths=64, blocks=16, time=200, burn_in=100,
                      progress=False)
    out = res.info["events"]["outside_fraction"]
    for key in ("A", "x1", "x2"):
        d = res.data[key]
        assert np.all(np.isfinite(d["p"])) and np.min(d["p"]) >= 0
        mass = float(np.sum(d["p"] * np.diff(d["edges"])))
        assert mass == pytest.approx(1.0 - out[key], abs=1e-9)
    assert res.info["status"]["ok"]


def test_chatter_is_reported(base):
    sc = vary(base, r=0.3, mu=0.2)
    res = mc.simulate(sc.system, sc.noise, paths=32, blocks=16, time=200, burn_in=50,
                      progress=False, edges=FIXED, observables=("events",))
    assert res.info["events"]["chatter_entries"] > 0


# ------------------------------------------------------------------------------- averaged SDE
def test_averaged_sde_rayleigh():
    """m = -aA + s/(2A), sigma^2 = s: p = (2a/s) A exp(-a A^2/s). Euler-Maruyama on Z = A^2
    is weak order 1; at dt = 0.01 its bias is far below the batch error."""
    a, s = 0.1, 0.02
    edges = np.linspace(0, 1.6, 41)
    res = simulate_sde(lambda A: -a * A + s / (2 * A), lambda A: s + 0 * A, edges=edges,
                       paths=256, blocks=32, time_=2000, burn_in=100)
    d = res.data["A"]
    ref = bin_average(lambda x: (2 * a / s) * x * math.exp(-a * x * x / s), edges)
    assert abs(chi_z(d["p"], d["err"], ref)) < 4


def test_montecarlo_imports_no_other_vifpk_package():
    code = ("import sys, montecarlo, montecarlo.averaged_sde; bad = [m for m in sys.modules "
            "if m.split('.')[0] in ('averaging', 'fpk', 'harness')]; sys.exit(bool(bad))")
    assert subprocess.run([sys.executable, "-c", code]).returncode == 0


def test_settings_are_frozen():
    s = mc.Settings()
    with pytest.raises(AttributeError):
        s.dt = 0.1  # type: ignore[misc]
    assert replace(s, dt=0.02).dt == 0.02


def test_numpy_reference_is_the_same_scheme(base):
    """The benchmark's NumPy implementation must simulate the same scheme: stuck fraction and
    impact rate agree within 4 combined batch standard errors (friction-heavy scene)."""
    from montecarlo.reference import simulate_numpy
    from montecarlo.simulate import _params

    sc = vary(base, mu=0.1)
    r = mc.simulate(sc.system, sc.noise, paths=256, blocks=16, dt=0.01, time=200, burn_in=50,
                    progress=False, edges=FIXED, observables=("events",))
    ev = r.info["events"]
    runs = [simulate_numpy(_params(sc.system, sc.noise), paths=256, steps=15000, burn=5000,
                           stride=50, h=0.01, edges_A=FIXED["edges_A"], seed=s) for s in range(4)]
    for key, num in (("stuck_fraction", "stuck_time"), ("impacts_per_time", "impacts")):
        vals = np.array([o[num] / o["time"] for o in runs])
        se = math.hypot(ev[key]["err"], vals.std(ddof=1) / 2)
        assert abs(ev[key]["value"] - vals.mean()) < 4 * se
