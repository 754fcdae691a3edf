"""Walls anywhere in the exact model (issue 37): the orbit truncated at each energy.

Independent truths: the paper's wall computed by the transformed coordinate y (x = |y|, the
old path) against the truncated orbit on [0, A]; the Gibbs law of elastic walls (the period
by scipy quadrature of dx / sqrt(2 (E - U))); walls out of reach; a wall at 0- tending to the
paper's; each impact law's loss per impact written out here from its definition."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import quad
from vifpk.averaging.exact import ExactModel
from vifpk.averaging.noise import Spectrum
from vifpk.averaging.phase import phase_densities
from vifpk.averaging.stationary import amplitude_density
from vifpk.averaging.walls import WallSpec

K = (1.0, 0.6)
D0, D, F = 0.1, 0.02, 1.3
LO, HI = -0.4, 0.7


def U(x):
    return 0.5 * K[0] * x * x + 0.25 * K[1] * x**4


def model(kind="white", walls=(), **kw):
    bandwidth = {"alpha1": 2.0} if kind == "ou" else {}  # white noise has none
    return ExactModel(restoring=K, damping=(D0,), mu=kw.pop("mu", 0.0), r=1.0, f=F,
                      barrier=False, spectrum=Spectrum.of(kind, D=D, **bandwidth),
                      noise="additive", walls=walls, **kw)


def both(r_lo=1.0, r_hi=1.0, **kw):
    return (WallSpec.of("lower", LO, r=r_lo, **kw), WallSpec.of("upper", HI, r=r_hi))


@pytest.fixture(scope="module")
def paper_pair():
    from vifpk.core.scene import load_scene

    mp = ExactModel.from_scene(load_scene("paper-base"))  # OU noise, the paper's wall
    mw = dataclasses.replace(mp, barrier=False, noise="additive", r=1.0,
                             walls=(WallSpec.of("lower", 0.0, r=mp.r),))
    return mp, mw


def test_a_wall_at_zero_on_the_truncated_orbit_is_the_papers_wall(paper_pair):
    # two computations: y = A cos(theta) over the whole free orbit with the kink tails of
    # |y|'s harmonics (old path) and Gauss-Legendre over [0, A] with x(t)'s own harmonics
    mp, mw = paper_pair
    A = np.array([0.01, 0.1, 0.5, 1.0, 2.0, 4.0])
    a, b = mp.energy_terms(A), mw.energy_terms(A)
    np.testing.assert_allclose(a["T"], 2.0 * b["T"], rtol=1e-14)  # x = |y|: half the period
    for key in ("damping", "impact", "friction", "E"):
        np.testing.assert_allclose(b[key], a[key], rtol=2e-14)
    # measured 7.7e-10: the truncated sum (48 harmonics, remainder ~ n^-5) against the tails
    np.testing.assert_allclose(b["sigma2"], a["sigma2"], rtol=5e-9)
    for treatment in ("transformed", "compounded"):  # the other treatments of the loss
        a = dataclasses.replace(mp, impact=treatment).energy_terms(A)["impact"]
        b = dataclasses.replace(mw, impact=treatment).energy_terms(A)["impact"]
        np.testing.assert_allclose(b, a, rtol=2e-14)


def test_walls_out_of_reach_are_bit_for_bit_the_wall_free_model():
    free = model("ou")
    far = model("ou", walls=(WallSpec.of("lower", -50.0, r=0.8),
                             WallSpec.of("upper", 50.0, r=0.7, law="johnson",
                                      v_yield=0.1)))
    A = np.linspace(0.0, 3.0, 13)
    for key, value in free.energy_terms(A).items():
        assert np.array_equal(far.energy_terms(A)[key], value, equal_nan=True), key
    for x, y in zip(free.log_stationary_parts(A), far.log_stationary_parts(A), strict=True):
        assert np.array_equal(x, y, equal_nan=True)  # q is NaN at A = 0 in both
    assert np.array_equal(free.terms(A[1:])["noise"], far.terms(A[1:])["noise"])


@pytest.fixture(scope="module")
def gibbs():
    m = model("white", walls=both())
    return m, amplitude_density(m, points=801, tail_mass=False)


def test_elastic_walls_give_the_gibbs_energy_law(gibbs):
    # r = 1 both sides, linear damping d0, white noise: p(E) = C T(E) exp(-d0 E / (D f^2)),
    # T(E) of the truncated orbit by scipy quadrature (x = A cos th removes the turning-point
    # singularity), so p_A = C T(E(A)) g(A) exp(-d0 U(A) / (D f^2))
    m, amp = gibbs
    beta = D0 / (D * F**2)

    def period(A):
        E = U(A)
        lo, hi = max(LO, -A), min(HI, A)
        return 2 * quad(lambda th: A * math.sin(th) / math.sqrt(2 * (E - U(A * math.cos(th)))),
                        math.acos(hi / A), math.acos(lo / A), epsabs=0, epsrel=1e-13,
                        limit=200)[0]

    idx = np.linspace(5, amp.A.size - 6, 25).astype(int)
    A = amp.A[idx]
    ref = np.array([period(a) for a in A]) * (K[0] * A + K[1] * A**3) * np.exp(-beta * U(A))
    ratio = amp.p[idx] / ref
    assert ratio.max() / ratio.min() - 1.0 < 1e-6  # measured 4e-14
    assert A[0] < HI < A[-1] and A[0] < -LO  # the grid spans free, one-wall and two-wall orbits


def test_elastic_walls_phase_marginals_are_gibbs_on_the_interval(gibbs):
    m, amp = gibbs
    beta = D0 / (D * F**2)
    ph = phase_densities(amp.A, amp.log_h, np.log(m.period(amp.A)), restoring=K,
                         barrier=False, lower=LO, upper=HI)
    assert ph.x1[0] == LO and ph.x1[-1] == HI
    z = quad(lambda x: math.exp(-beta * U(x)), LO, HI, epsrel=1e-12)[0]
    # the marginals are renormalised by their trapezoid mass on 201 points (measured 6e-6)
    np.testing.assert_allclose(ph.p_x1, np.exp(-beta * U(ph.x1)) / z, rtol=2e-5)
    gauss = np.exp(-beta * ph.x2**2 / 2) / math.sqrt(2 * math.pi / beta)
    np.testing.assert_allclose(ph.p_x2, gauss, rtol=0, atol=1e-8 * gauss.max())


@pytest.mark.parametrize("treatment", ["exact", "transformed", "compounded"])
def test_loss_per_impact_is_the_laws(treatment):
    r, vy = 0.9, 0.5
    walls = (WallSpec.of("lower", LO, r=0.8),
             WallSpec.of("upper", HI, r=r, law="johnson", v_yield=vy))
    m = model("white", walls=walls, impact=treatment)
    A = np.array([0.3, 0.5, 0.8, 1.2, 2.0])
    E = U(A)
    T = m.orbit(A)["T"]
    got = -m.energy_terms(A)["impact"] * T  # energy taken per period

    def per(K_, e):
        return {"exact": (1 - e * e) * K_, "transformed": 2 * (1 - e) * K_,
                "compounded": -np.log(e * e) * K_}[treatment]

    want = np.zeros_like(A)
    for a_, at, e_of in ((A, LO, lambda v: 0.8 + 0 * v),
                         (A, HI, lambda v: r * np.minimum(1.0, (vy / v) ** 0.25))):
        K_ = np.maximum(E - U(at), 0.0)
        v = np.sqrt(2 * K_)
        with np.errstate(divide="ignore"):
            want += np.where(a_ > abs(at), per(K_, e_of(v)), 0.0)
    np.testing.assert_allclose(got, want, rtol=1e-14, atol=0)
    assert got[0] == 0.0 and got[1] > 0.0  # 0.3 reaches no wall; 0.5 the lower one


def test_an_unknown_impact_law_is_refused_in_one_line():
    with pytest.raises(ValueError, match="impact law must be one of .*, not 'plastic'.*: the "
                                         "averaging solver cannot take it"):
        WallSpec(side="upper", at=1.0, law="plastic", params=(0.9,))


@pytest.mark.slow
def test_a_lower_wall_at_zero_minus_tends_to_the_papers(paper_pair):
    mp, mw = paper_pair
    ref = amplitude_density(mp, points=401, tail_mass=False)
    l1 = []
    for eps in (1e-3, 1e-4):
        m = dataclasses.replace(mw, walls=(WallSpec.of("lower", -eps, r=mp.r),))
        d = amplitude_density(m, points=401, tail_mass=False)
        p = np.interp(ref.A, d.A, d.p, left=0.0, right=0.0)
        l1.append(float(np.trapezoid(np.abs(p - ref.p), ref.A)))
    # measured 6.9e-3, 6.9e-4: first order in the offset
    assert l1[1] < 1e-3 and l1[0] / l1[1] == pytest.approx(10.0, rel=0.05), l1


@pytest.mark.slow
def test_fpk_on_the_walled_drift_and_diffusion_meets_the_closed_form():
    from scipy.interpolate import CubicSpline

    from vifpk import fpk

    m = model("white", walls=(WallSpec.of("lower", LO, r=0.85),
                              WallSpec.of("upper", HI, r=0.9, law="johnson",
                                       v_yield=0.5)), mu=0.02)
    cf = amplitude_density(m, points=3201, tail_mass=False)
    res = fpk.stationary(m.drift, m.diffusion, cells=400, method="direct")
    x, p = res.data["A_cells"]["x"], res.data["A_cells"]["p"]
    ref = np.where(x <= cf.A[-1], CubicSpline(cf.A, cf.p)(np.minimum(x, cf.A[-1])), 0.0)
    # the FPK's usual bound at its default 400 cells (tests/test_fpk.py); measured 1.0e-5
    assert np.sum(np.abs(p - ref)) * res.info["grid"]["h"] <= 1e-4


def test_ou_noise_power_on_a_truncated_orbit_against_an_fft_of_the_integrated_orbit():
    # independent: the elastic orbit integrated by scipy (DOP853, an event at the wall or at
    # the free turning point), v(t) sampled on 2^15 points of a period, G = f v by FFT, and
    # sigma_E^2 = 2 pi sum_n |G_n|^2 S(n Omega). The FFT's own error falls as 1/N^2 (v jumps
    # at a wall): 5.0e-6, 3.1e-7, 2.0e-8 at N = 2^12, 2^14, 2^16 for A = 2 (two walls),
    # so ~8e-8 at 2^15
    from scipy.integrate import solve_ivp

    m = model("ou", walls=both(0.8, 0.9))

    def fft_sigma2(A, N=2**15):
        E = U(A)
        xp, xm = min(HI, A), max(LO, -A)
        v0 = -math.sqrt(max(2 * (E - U(xp)), 0.0)) or -1e-300

        def event(t, y):
            return y[0] - LO if xm == LO else y[1]

        event.terminal, event.direction = True, (-1 if xm == LO else 1)
        sol = solve_ivp(lambda t, y: [y[1], -(K[0] * y[0] + K[1] * y[0] ** 3)], (0, 100),
                        [xp, v0], method="DOP853", rtol=1e-13, atol=1e-14, events=event,
                        dense_output=True)
        half = sol.t_events[0][0]
        t = np.arange(N) * (2 * half / N)
        v = sol.sol(np.where(t <= half, t, 2 * half - t))[1] * np.where(t <= half, 1.0, -1.0)
        G = np.fft.fft(F * v) / N
        n = np.fft.fftfreq(N, d=1.0 / N)
        return 2 * np.pi * np.sum(np.abs(G) ** 2 * m.spectrum(np.pi / half * n)), 2 * half

    for A in (0.55, 2.0):  # one wall (the lower), both walls
        ref, T = fft_sigma2(A)
        assert m.orbit(np.array([A]))["T"][0] == pytest.approx(T, rel=1e-12)
        assert m.sigma2_energy(np.array([A]))[0] == pytest.approx(ref, rel=3e-7)


TWO = {"system": {"restoring": [1.0, 0.6], "damping": [0.1], "mu": 0.0,
                      "lower_wall": {"at": LO, "r": 0.8},
                      "upper_wall": {"at": HI, "r": 0.9, "law": "johnson", "v_yield": 0.5}},
           "parametric": {"stiffness": 0.004, "damping": 0.01}}


def test_scene_keys_reach_the_models_and_the_refusals_are_one_line():
    from vifpk import averaging
    from vifpk.core.registry import model_applies
    from vifpk.core.scene import scene_from_dict

    sc = scene_from_dict({**TWO, "noise": {"kind": "white", "D": D}})
    m = averaging.build_model(sc, "exact")
    assert m.walls == (WallSpec.of("lower", LO, r=0.8),
                       WallSpec.of("upper", HI, r=0.9, law="johnson", v_yield=0.5))
    assert (m.D_k, m.D_c, m.barrier) == (0.004, 0.01, False)
    why = model_applies("paper", sc)
    assert why is not None and "\n" not in why
    ou = scene_from_dict({**TWO, "noise": {"kind": "ou", "D": D, "alpha1": 2.0}})
    why = model_applies("corrected", ou)
    assert "wall offset" in why and "\n" not in why
    assert model_applies("corrected", sc) is None  # white noise: the compounded losses


@pytest.mark.slow
def test_solve_on_a_walled_scene_gives_phase_densities_on_the_interval():
    from vifpk import averaging
    from vifpk.core.scene import scene_from_dict

    sc = scene_from_dict({**TWO, "noise": {"kind": "white", "D": D},
                          "averaging": {"points": 201, "phase_points": 41}})
    res = averaging.solve(sc, model="exact")
    x1 = res.data["x1"]["x"]
    assert (x1[0], x1[-1]) == (LO, HI)  # p(x1) lives on [a, b]
    for key in ("A", "E", "x1", "x2"):
        d = res.data[key]
        assert np.all(np.isfinite(d["p"])) and np.trapezoid(d["p"], d["x"]) == pytest.approx(1.0)
    assert res.info["diagnostics"]["tail_mass"] < 1e-8
