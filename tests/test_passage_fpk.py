"""fpk.passage: the MFPT quadrature and the time-stepped reliability against closed forms, their
convergence orders, the two routes against each other, mass bookkeeping. Each tolerance says
where it comes from."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.special import expi, hyp1f1
from vifpk.fpk.passage import QUAD_ORDER, mfpt, quad_order, reliability

from vifpk import fpk

# Rayleigh amplitude of a linear oscillator x'' + c x' + w^2 x = sqrt(K) xi (white, unit
# intensity): dA = (-c A / 2 + s / (2A)) dt + sqrt(s) dW, s = K / (2 w^2). It is exactly the
# radius of a 2-D Ornstein-Uhlenbeck process (drift -c/2, noise s), so a 1-D diffusion with
# p(A) = (A / v) exp(-A^2 / 2v), v = s / c, and (docs/passage.md, u = A^2 / 2v)
#   T(A0) = (1/c) [Ein(u_c) - Ein(u_0)],  Ein(u) = Ei(u) - ln u  (-> Euler's gamma at u = 0).
RC, RS = 0.2, 0.02
RV = RS / RC


def ray_m(A):
    return -0.5 * RC * A + RS / (2 * A)


def ray_s2(A):
    return RS + 0 * A


def ein(u):
    return expi(u) - math.log(u) if u > 0 else np.euler_gamma


def ray_T(a0, ac):
    return (ein(ac**2 / (2 * RV)) - ein(a0**2 / (2 * RV))) / RC


def ray_p(A):
    return A / RV * np.exp(-A**2 / (2 * RV))


def ray_decay(ac):
    """lambda_1 of the absorbed radial 2-D OU: the radial eigenfunctions are Kummer's
    M(-lambda/c, 1, u), so lambda_1 is c times the first root a of M(-a, 1, u_c) = 0."""
    uc = ac**2 / (2 * RV)
    a = np.linspace(1e-9, 2.0, 4001)
    f = hyp1f1(-a, 1.0, uc)
    i = int(np.argmax(np.sign(f[1:]) != np.sign(f[:-1])))
    return RC * brentq(lambda x: hyp1f1(-x, 1.0, uc), a[i], a[i + 1], xtol=1e-15)


# Brownian motion with a constant drift -mu toward a reflecting wall at 0, absorbed at L:
# Phi = -a y (a = mu / D), G(y) = (e^{a y} - 1) / mu, T(x) = [(e^{aL} - e^{ax}) / a - (L - x)] / mu
MU, DD, LL = 0.7, 0.25, 2.0


def bm_T(x, lo=0.0):
    a = MU / DD
    # with the wall at lo: shift the origin
    x, L = x - lo, LL - lo
    return ((math.exp(a * L) - math.exp(a * x)) / a - (L - x)) / MU


def fitted_order(ns, errs):
    return -np.polyfit(np.log(ns), np.log(errs), 1)[0]


def test_mfpt_matches_the_rayleigh_closed_form_to_rounding():
    for ac in (0.5, 1.0, 1.5):
        for a0 in (0.0, 0.1, 0.3):
            r = mfpt(ray_m, ray_s2, threshold=ac, start=a0)
            exact = ray_T(a0, ac)
            # default grids: 16 and 32 intervals of 8 Gauss points, order 16: the error is at
            # rounding (measured <= 6e-15); 1e-12 leaves room for other platforms' libm
            assert r["value"] == pytest.approx(exact, rel=1e-12), (ac, a0)
            assert r["error_estimate"] <= 1e-12 * exact


@pytest.mark.parametrize("nodes", [2, 3])
def test_quadrature_order_rayleigh(nodes):
    """The singular 1/A drift: the measured order must be the declared 2 nodes (measured 4.0
    and 6.0 over these grids)."""
    ns = [8, 16, 32]
    errs = [abs(mfpt(ray_m, ray_s2, threshold=1.0, start=0.3, intervals=n, nodes=nodes,
                     max_intervals=2 * n)["value_coarse"] / ray_T(0.3, 1.0) - 1) for n in ns]
    assert fitted_order(ns, errs) == pytest.approx(quad_order(nodes), abs=0.3), errs
    assert QUAD_ORDER == quad_order(fpk.passage.QUAD_NODES)


@pytest.mark.parametrize("lo", [0.0, 0.5])
def test_quadrature_order_drifted_brownian_motion(lo):
    ns = [4, 8, 16]
    exact = bm_T(1.0, lo)
    errs = [abs(mfpt(lambda A: -MU + 0 * A, lambda A: 2 * DD + 0 * A, threshold=LL, start=1.0,
                     lo=lo, intervals=n, nodes=2, max_intervals=2 * n)["value_coarse"] / exact
                - 1) for n in ns]
    assert fitted_order(ns, errs) == pytest.approx(4.0, abs=0.3), errs


def test_error_estimate_bounds_the_error():
    # Richardson between the two grids: for an O(h^p) rule the finer one's error is
    # |T_2N - T_N| / (2^p - 1), so the estimate must be at least the actual error
    for n in (4, 8):
        r = mfpt(ray_m, ray_s2, threshold=1.2, start=0.2, intervals=n, nodes=3,
                 max_intervals=2 * n)
        err = abs(r["value"] - ray_T(0.2, 1.2))
        assert err <= r["error_estimate"]


def test_a_start_density_integrates_t_against_it():
    ac = 1.2

    def p0(A):  # a bump on [0.2, 0.8] (not normalised: mfpt normalises it)
        return np.where((A > 0.2) & (A < 0.8), np.sin(np.pi * (A - 0.2) / 0.6) ** 2, 0.0)

    num = quad(lambda a: ray_T(a, ac) * p0(a), 0.2, 0.8, epsabs=0, epsrel=1e-13)[0]
    den = quad(p0, 0.2, 0.8, epsabs=0, epsrel=1e-13)[0]
    r = mfpt(ray_m, ray_s2, threshold=ac, start=p0, intervals=32, max_intervals=64)
    # the bump has a kink-free but non-analytic support edge inside intervals: the measured
    # error is 3e-10, the estimate says 4e-10; 1e-8 is well above both
    assert r["value"] == pytest.approx(num / den, rel=1e-8)
    st = mfpt(ray_m, ray_s2, threshold=ac, start="stationary")
    num = quad(lambda a: ray_T(a, ac) * ray_p(a), 0, ac, epsabs=0, epsrel=1e-13)[0]
    den = quad(ray_p, 0, ac, epsabs=0, epsrel=1e-13)[0]
    assert st["value"] == pytest.approx(num / den, rel=1e-11)


def test_bad_input_and_non_reflecting_zero():
    with pytest.raises(ValueError, match="start amplitude"):
        mfpt(ray_m, ray_s2, threshold=1.0, start=1.0)
    with pytest.raises(ValueError, match="threshold"):
        mfpt(ray_m, ray_s2, threshold=0.0, start=0.0)
    with pytest.raises(ValueError, match="start"):
        reliability(ray_m, ray_s2, threshold=1.0, start="somewhere")
    # 2m/sigma^2 = -1.5/A: p ~ A^-1.5 is not integrable at 0, the wall cannot reflect
    with pytest.raises(fpk.CoefficientError, match="not integrable"):
        mfpt(lambda A: -0.75 * RS / A, ray_s2, threshold=1.0, start=0.5)


def test_decay_rate_converges_to_the_kummer_root_at_order_2():
    exact = ray_decay(1.0)
    ns = [50, 100, 200, 400]
    errs = [abs(fpk.discretise(ray_m, ray_s2, lo=0.0, hi=1.0, cells=n,
                               right="absorbing").decay_rate() / exact - 1) for n in ns]
    # measured slope 1.98-1.99 (the scheme's declared order)
    assert fitted_order(ns, errs) == pytest.approx(fpk.ORDER, abs=0.1), errs


def test_reliability_of_brownian_motion_against_its_series_at_order_2():
    """m = 0, sigma^2 = 2D on [0, L], reflecting at 0, absorbed at L, from
    p0 ~ cos(k1 x) + 0.2 cos(k3 x), k_n = n pi / (2L) (positive: 0.4 cos + 0.8 cos^3):
    R(t) = sum_n c_n (2L (-1)^j / (n pi)) exp(-D k_n^2 t), n = 2j + 1, exactly."""
    L, D = 1.0, 0.5
    k1, k3 = math.pi / (2 * L), 3 * math.pi / (2 * L)

    def p0(x):
        return np.cos(k1 * x) + 0.2 * np.cos(k3 * x)

    masses = np.array([2 * L / math.pi, -0.2 * 2 * L / (3 * math.pi)])
    times = [0.05, 0.2, 0.5, 1.0]

    def R(t):
        return float(masses @ np.exp(-D * np.array([k1, k3]) ** 2 * t)) / masses.sum()

    ns, errs = [50, 100, 200], []
    for n in ns:
        res = reliability(lambda x: 0 * x, lambda x: 2 * D + 0 * x, threshold=L, p0=p0,
                          times=times, cells=n)
        t, Rn = res.data["R"]["t"], res.data["R"]["R"]
        errs.append(max(abs(Rn[i] - R(t[i])) for i in range(1, len(t))))
        d = res.info["diagnostics"]
        # inside + absorbed = 1: the stepper's check (1e-10) and the recorded worst value
        assert d["mass_balance"] < 1e-10 and d["worst_mass_drift"] < 1e-10
        assert res.info["decay_rate"] == pytest.approx(D * k1**2, rel=2 / n**2 * 10)
    assert fitted_order(ns, errs) == pytest.approx(fpk.ORDER, abs=0.15), errs


@pytest.mark.slow
def test_two_routes_agree_and_meet_the_closed_form():
    """Quadrature MFPT = int R dt of the time-stepped FPK (Rayleigh, A0 = 0.2, Ac = 1).
    Tolerance from the grids: the FPK is O(h^2), so the 400-cell value errs by about
    |I_200 - I_400| / 3; we allow |I_200 - I_400| (a factor 3 margin) plus the time-
    integration gap (int R dt against h 1^T (-M)^-1 p0 of the same grid) and the quadrature's
    own estimate. Measured: I_200 - T = 3.9e-5 T, I_400 - T = 8.9e-6 T, time gap 1.5e-7 T."""
    ac, a0 = 1.0, 0.2
    exact = ray_T(a0, ac)
    q = mfpt(ray_m, ray_s2, threshold=ac, start=a0)
    runs = {n: reliability(ray_m, ray_s2, threshold=ac, start=a0, cells=n) for n in (200, 400)}
    I = {n: r.info["mfpt_integral"] for n, r in runs.items()}
    gap = runs[400].info["diagnostics"]["time_integration_gap"]
    tol = abs(I[200] - I[400]) + gap + q["error_estimate"]
    assert abs(q["value"] - I[400]) <= tol
    assert abs(exact - I[400]) <= tol
    assert gap < 1e-6 * exact  # Hermite rule on tau/4 steps, BDF rtol 1e-9
    r = runs[400]
    # -dR/dt integrates to the mass absorbed (the sink's): the Hermite rule on the output times
    # resolves f's early rise (on (Ac - A0)^2 / s ~ 30 against steps of tau/4 = 45) to 6.5e-6
    # (measured); 2e-5 bounds it; R itself is smoother (gap above 1.5e-7 T)
    assert r.info["diagnostics"]["wall_flux_integral_gap"] < 2e-5
    assert r.info["decay_rate"] == pytest.approx(ray_decay(ac), rel=1e-4)  # O(h^2): 9e-6
    # the stationary start by both routes
    qs = mfpt(ray_m, ray_s2, threshold=ac, start="stationary")
    rs = [reliability(ray_m, ray_s2, threshold=ac, start="stationary", cells=n)
          for n in (200, 400)]
    Is = [x.info["mfpt_integral"] for x in rs]
    assert abs(qs["value"] - Is[1]) <= abs(Is[0] - Is[1]) + 1e-6 * qs["value"]


def test_high_thresholds_refine_until_converged_and_overflow_fails_cleanly():
    # Ac = 4: Phi changes by u_c = 80 across [0, Ac], T ~ 3e33; the grid doubles until the
    # two-grid estimate is below rtol (the estimate bounds the error, test above)
    r = mfpt(ray_m, ray_s2, threshold=4.0, start=0.5, rtol=1e-9)
    assert r["converged"] and r["intervals"] > 32
    assert r["value"] == pytest.approx(ray_T(0.5, 4.0), rel=1e-9)
    with pytest.raises(fpk.FPKFailure, match="overflows"):
        mfpt(ray_m, ray_s2, threshold=12.0, start=0.5)  # T ~ e^720


@pytest.mark.slow
def test_dense_curves_read_linearly_match_stepped_values():
    """The dense R(t) (quintic Hermite between the stepped times) read by linear interpolation,
    at times between its points, against a run stepped to exactly those times: measured 4e-5
    (the knots alone read linearly: 2.2e-3, the ~1% class at coarser steps)."""
    r = reliability(ray_m, ray_s2, threshold=1.0, start=0.2, cells=200)
    t, R = r.data["R"]["t"], r.data["R"]["R"]
    probe = 0.5 * (t[1:] + t[:-1])[::41][:14] + 0.013
    s = reliability(ray_m, ray_s2, threshold=1.0, start=0.2, cells=200, times=list(probe))
    assert np.max(np.abs(np.interp(probe, t, R) - s.data["R"]["R"][1:])) < 2e-4
    f = r.data["fpt_density"]["p"]
    fs = s.data["fpt_density"]["p"][1:]
    assert np.max(np.abs(np.interp(probe, t, f) - fs)) < 1e-2 * np.max(fs)


def test_decay_rate_and_discrete_mfpt_keep_precision_at_high_thresholds():
    """Far above the bulk R(t) is one exponential: lambda_1 T -> 1. The discrete operator's
    1 / lambda_1 and h 1^T (-M)^-1 delta_{A0} (the cancellation-free solve) against the
    closed-form T at Ac = 3 and 4 (T ~ 4e18, 4e33; lambda_1 / ||M|| ~ 1e-24, where a symmetric
    eigensolver's absolute error 1e-16 ||M|| swamps it: it returns -3e-14 at Ac = 3).
    Measured: 1 / lambda_1 = T(0) (1 + 7e-5 .. 1e-4), O(h^2) of 400 cells; 1e-3 is the bound."""
    for ac in (3.0, 4.0):
        d = fpk.discretise(ray_m, ray_s2, lo=0.0, hi=ac, cells=400, right="absorbing")
        assert 1 / d.decay_rate() == pytest.approx(ray_T(0.0, ac), rel=1e-3)
        i = int(0.5 / d.h)
        e = np.zeros(d.cells)
        e[i] = 1 / d.h
        assert np.sum(d.solve_absorbing(e)) * d.h == pytest.approx(ray_T(d.centres[i], ac),
                                                                   rel=1e-3)


@pytest.mark.slow
def test_a_tail_taken_before_one_mode_is_left_is_flagged():
    # Brownian motion from A0 = 0.9 next to the wall at L = 1, stopped at t = 0.02: many modes
    # are alive, R decays at ~4x lambda_1 there, so the tail R(t_end) / lambda_1 is not
    # trustworthy and says so; stepped to the default t_end it is not flagged
    kw = {"threshold": 1.0, "start": 0.9, "cells": 100}
    short = reliability(lambda x: 0 * x, lambda x: 1.0 + 0 * x, times=[0.01, 0.02], **kw)
    assert any("tail" in w for w in short.info["warnings"])
    full = reliability(lambda x: 0 * x, lambda x: 1.0 + 0 * x, **kw)
    assert full.info["warnings"] == []
    assert full.info["mfpt_integral"] == pytest.approx((1 - 0.9**2) / 1.0, rel=1e-3)


def test_stepping_that_records_no_output_time_fails_in_one_line(monkeypatch):
    """Issue 39 X14: `vifpk passage paper-base --threshold 2.0 --method direct --yes --model
    exact` died with IndexError at R[-2] when the time stepper (fpk.stepper.run) handed back
    no snapshot, R(t) at t = 0 alone. That stepping takes minutes (it was not reproduced
    here): the stepper's answer is emptied of its snapshots on the Rayleigh closed form, and
    reliability must raise the solver's one-line failure (FPKFailure: exit 3), not crash."""
    import vifpk.fpk.passage as FP

    real = FP.run

    def empty(*a, **k):
        out = real(*a, **k)
        return dict(out, snapshots={}, absorbed_snapshots={})

    monkeypatch.setattr(FP, "run", empty)
    with pytest.raises(fpk.FPKFailure) as e:
        reliability(ray_m, ray_s2, threshold=1.5, start=1.0, cells=20, times=[0.5, 1.0])
    assert "none of its 2 output times" in str(e.value) and "\n" not in str(e.value)
