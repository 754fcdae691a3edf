"""The compounded and corrected models (averaging/corrected.py; docs/averaging.md section 10)."""

from __future__ import annotations

import numpy as np
import pytest
from vifpk.averaging.corrected import CompoundedModel, q_frame_density, wall_offset

from tests.conftest import ROOT
from vifpk import averaging
from vifpk.core.scene import load_scene

BASE = load_scene(ROOT / "scenes" / "paper-base.toml")


def _l1(a, b) -> float:
    x = a.data["A"]["x"]
    q = np.interp(x, b.data["A"]["x"], b.data["A"]["p"], left=0.0, right=0.0)
    return float(np.trapezoid(np.abs(a.data["A"]["p"] - q), x))


@pytest.mark.parametrize("values", [{"system.r": 1.0}, {"system.barrier": False}])
def test_compounded_is_exact_without_impact_loss(values):
    """lambda = -ln r^2 = 0 (elastic wall, or no wall): the two models are the same model."""
    scene = BASE.with_values(values)
    e, c = (averaging.solve(scene, model=m) for m in ("exact", "compounded"))
    np.testing.assert_allclose(c.data["A"]["p"], e.data["A"]["p"], rtol=1e-12, atol=1e-12)


def test_impact_term_is_the_compounded_loss():
    """-(2/T) ln(r^2) E: two impacts a period, each removing ln(1/r^2) of ln E."""
    m = averaging.build_model(BASE, "compounded")
    A = np.array([0.2, 0.5, 1.0])
    et = m.energy_terms(A)
    np.testing.assert_allclose(et["impact"], 2.0 * np.log(0.96**2) * et["E"] / et["T"],
                               rtol=1e-14)
    assert isinstance(m, CompoundedModel) and m.impact == "compounded"


@pytest.mark.parametrize("r", [0.98, 0.96, 0.92])
def test_q_frame_quadrature_agrees_with_closed_form(r):
    """The un-simplified Q-frame model (weights e^{lambda(1-s)}, back-transform over the flight
    phase) and the closed form differ only by O(lambda) terms from the nonlinearity of the
    drift in E (docs section 10). Measured L1 / lambda = 0.012-0.014 for r in 0.84-0.99 at the
    base scene (quadrature converged: 801 and 3201 points agree to 2e-5); bound 0.02 lambda."""
    scene = BASE.with_values({"system.r": r})
    c = averaging.solve(scene, model="compounded")
    m = averaging.build_model(scene, "compounded")
    A = c.data["A"]["x"][1:]
    p = q_frame_density(m, A)
    l1 = np.trapezoid(np.abs(p - c.data["A"]["p"][1:]), A)
    assert l1 <= 0.02 * m.lam


@pytest.mark.slow
@pytest.mark.parametrize("model", ["compounded", "corrected"])
def test_consistency_tends_to_exact_at_first_order(model):
    """Scale c1, c2, mu, D and 1 - r by k -> 0: the first-order density is invariant (drift and
    diffusion both scale with k) and the correction is O(k): L1(corrected, exact) ~ k^1.
    The O(k^2) remainder makes the measured order 1.009, 1.004 (compounded) for
    k = 1 -> 0.5 -> 0.25; bound |order - 1| <= 0.05. For ``corrected`` the wall offset and
    the fast fluctuation are both O(D) = O(k) too."""
    l1 = []
    for k in (1.0, 0.5, 0.25):
        scene = BASE.with_values({"system.c1": 0.025 * k, "system.c2": 0.05 * k,
                                  "system.mu": 0.001 * k, "system.r": 1 - 0.04 * k,
                                  "noise.D": 0.01 * k})
        e, c = (averaging.solve(scene, model=m) for m in ("exact", model))
        l1.append(_l1(c, e))
    orders = np.log2(np.array(l1[:-1]) / np.array(l1[1:]))
    assert np.all(np.abs(orders - 1.0) <= 0.05), orders


# ------------------------------------------------------------- section 10.3 terms (issue 23)
def _wall_offset_linear_quadrature(w: float, f: float, D: float, a1: float) -> float:
    """delta for the linear oscillator by nested scipy quad on the closed-form orbit and
    response (x' = v0 cos wt, Phi_x(t, s) = sin(w(t - s)) / w, Phi_v = cos(w(t - s))): an
    independent evaluation of the formula of docs/averaging.md 10.3 (a)."""
    from scipy.integrate import quad

    tau = np.pi / w
    R = lambda s: (D / a1) * np.exp(-a1 * abs(s))  # noqa: E731
    inner = lambda tp: quad(lambda s: R(tp - s) * np.cos(w * (tp - s)), 0, tp)[0]  # noqa: E731
    EW = lambda t: f**2 * quad(inner, 0, t)[0]  # noqa: E731
    px = lambda t: quad(lambda s: np.sin(w * (tau - s)) / w * R(t - s), 0, tau)[0]  # noqa: E731
    cross = -(f**2 / np.cos(w * tau)) * quad(lambda t: np.cos(w * t) * px(t), 0, tau)[0]
    total = EW(tau) - f**2 * px(tau)
    return (quad(EW, 0, tau, limit=20)[0] + cross) / tau - 0.5 * total


@pytest.mark.parametrize("a1", [0.5, 2.0])
def test_wall_offset_against_quadrature_linear_oscillator(a1):
    """RK4 flight + trapezoid (120 steps) against nested adaptive quadrature of the same
    formula on the closed-form linear orbit; the trapezoid error (pi/120)^2 / 12 relative to
    the integrands' curvature is ~1e-4: bound 1e-3 relative."""
    d = wall_offset(1.3, 0.0, 1.0, 0.01, a1, np.array([0.4]))[0]
    q = _wall_offset_linear_quadrature(1.3, 1.0, 0.01, a1)
    assert abs(d - q) <= 1e-3 * abs(q), (d, q)


def test_wall_offset_quasi_static_limit():
    """alpha1 -> 0 with a linear spring: a constant force F leaves H - F x conserved over a
    flight, so delta -> <F^2> <dx/dF> = f^2 (D / alpha1) / omega0^2; at alpha1 = 0.01 the
    correlation time is 16 flights, the remaining O(alpha1 tau) part ~2%: bound 4%."""
    d = wall_offset(1.0, 0.0, 1.0, 0.01, 0.01, np.array([0.5]))[0]
    assert abs(d / (0.01 / 0.01) - 1.0) <= 0.04, d


def test_fast_fluctuation_variance_against_orbit_simulation():
    """V = (D / alpha1) <a^2>, a(t) = -f int_0^inf e^{-alpha1 s} Y'(t + s) ds on the orbit
    (Y = |y|), equals sigma_E^2 / (2 alpha1): the orbit integrated with solve_ivp (rtol 1e-10),
    a(t) by trapezoid on 4000 points of a period (kinks of |y| at the impacts: O(h^2));
    bound 1e-3 relative."""
    from scipy.integrate import solve_ivp

    m = averaging.build_model(BASE.with_values({"noise.alpha1": 1.0}), "corrected", fast=True)
    A = 0.4
    T = float(m.period(np.array([A]))[0])
    n = 4000
    t = np.linspace(0.0, T, n + 1)
    sol = solve_ivp(lambda _t, z: [z[1], -(m.omega0**2 * z[0] + m.alpha * z[0] ** 3)],
                    (0, T), [A, 0.0], t_eval=t, rtol=1e-10, atol=1e-12)
    Yd = np.sign(sol.y[0]) * sol.y[1]  # d|y|/dt
    a1 = m.spectrum.alpha1
    Yd2 = np.concatenate([Yd[:-1], Yd])  # two periods
    t2 = np.linspace(0.0, 2 * T, 2 * n + 1)[:-1]
    kern = np.exp(-a1 * t2[:n + 1])
    a = np.array([-m.f * np.trapezoid(kern * Yd2[i:i + n + 1], t2[:n + 1])
                  for i in range(0, n, 8)]) / (1.0 - np.exp(-a1 * T))
    V_sim = m.spectrum.D / a1 * np.mean(a**2)
    V = float(m.observation_sd(np.array([A]))[0] ** 2)
    assert abs(V_sim / V - 1.0) <= 1e-3, (V_sim, V)


def test_observation_map_is_a_markov_kernel_adding_the_fast_variance():
    """Columns of the observation matrix sum to 1 on edges that hold the kernel; the observed
    energy has the slow mean (truncation negligible where E >> sd) and variance V + 0."""
    m = averaging.build_model(BASE, "corrected", fast=True)
    A = np.array([0.5, 0.8])
    edges = np.linspace(0.0, 2.0, 4001)
    M = m.observation_matrix(A, edges)
    np.testing.assert_allclose(M.sum(axis=0), 1.0, atol=1e-12)
    from vifpk.averaging.geometry import potential

    E_mid = potential(0.5 * (edges[1:] + edges[:-1]), m.omega0, m.alpha)
    mean = E_mid @ M
    var = (E_mid[:, None] - mean[None, :]) ** 2 * M
    V = m.observation_sd(A) ** 2
    np.testing.assert_allclose(mean, potential(A, m.omega0, m.alpha), rtol=1e-4)
    np.testing.assert_allclose(var.sum(axis=0), V, rtol=2e-2)  # cell width in E ~ 1e-3 sd


@pytest.mark.slow
def test_fpk_of_corrected_is_observed_alike():
    """With the observation map on, the FPK goes through the same map: its p(A) matches the
    closed form to the FPK's own discretisation error (400 cells: 4e-5; bound 1e-3)."""
    from vifpk.harness.door.solvers import closed_form, fpk_solution
    from vifpk.harness.workflows.compare import compare

    scene = BASE.with_values({"noise.alpha1": 1.0})
    c = closed_form(scene, model="corrected", fast=True)
    f = fpk_solution(scene, model="corrected", cells=400, fast=True)
    assert compare(c.data["A"], f.data["A"])["L1"] < 1e-3


def _gaussian_linear_oscillator(w, c, D, a1):
    """x'' + c x' + w^2 x = xi, xi' = -a1 xi + W (E W W = 2 D delta): the stationary law is
    Gaussian; its covariance from the Lyapunov equation. Returns the scene and the laws'
    scales (w^2 Var x, Var v): H = Var v chi2_1 / 2 + w^2 Var x chi2_1 / 2 exactly."""
    from scipy.linalg import solve_continuous_lyapunov

    scene = BASE.with_values({"system.barrier": False, "system.alpha": 0.0, "system.c2": 0.0,
                              "system.mu": 0.0, "system.c1": -c, "system.omega0": w,
                              "noise.D": D, "noise.alpha1": a1})
    M = np.array([[0, 1, 0], [-w * w, -c, 1], [0, 0, -a1]])
    P = solve_continuous_lyapunov(M, -np.diag([0, 0, 2 * D]))
    return scene, w * w * P[0, 0], P[1, 1]


@pytest.mark.parametrize("a1", [1.0, 0.5])
def test_fast_map_against_the_exact_gaussian_law_of_the_linear_oscillator(a1):
    """An exactly solvable case: the linear oscillator under OU noise (no wall). p(A) of the
    exact Gaussian law (A = sqrt(2H)/w; the cdf of H from two independent chi2_1 by
    quadrature) against the first-order model and the model with the fast-fluctuation map.
    Measured (w = 1, c = 0.05, D = 0.01): first order L1 0.004 (a1 = 1), 0.021 (a1 = 0.5);
    with the map 0.033, 0.045. So the map as derived (variance sigma_E^2 / 2 alpha1 added to
    the slow energy) is NOT the missing O(eps) term: asserted as measured (first order within
    0.025 and the map at least 0.01 worse), which is why ``corrected`` leaves it off."""
    from scipy.stats import chi2
    from vifpk.averaging.corrected import observed_density

    scene, sx, sv = _gaussian_linear_oscillator(1.0, 0.05, 0.01, a1)
    ex = averaging.solve(scene, model="exact").data["A"]
    m = averaging.build_model(scene, "corrected", fast=True)
    xf, pf = observed_density(m, ex["x"], ex["p"])
    edges = np.linspace(0.0, ex["x"][-1], 201)
    # exact cdf of H = sv U / 2 + sx V / 2, U, V ~ chi2_1 independent, on the edges
    u = 0.5 * (np.linspace(0, 1, 4001)[1:] + np.linspace(0, 1, 4001)[:-1])  # midpoints
    Uq = chi2.ppf(u, 1)
    H = 0.5 * edges**2  # w = 1
    cdf = np.mean(chi2.cdf(np.maximum(H[:, None] - 0.5 * sv * Uq[None, :], 0) / (0.5 * sx), 1)
                  * (H[:, None] >= 0.5 * sv * Uq[None, :]), axis=1)
    exact_mass = np.diff(cdf)

    def l1(x, p):
        c = np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(x))])
        mass = np.diff(np.interp(edges, x, c / c[-1], left=0.0, right=1.0))
        return float(np.sum(np.abs(mass - exact_mass)))

    first, fast = l1(ex["x"], ex["p"]), l1(xf, pf)
    assert first <= 0.025, first
    assert fast >= first + 0.01, (first, fast)


@pytest.mark.slow
def test_corrected_tends_to_the_white_noise_model_as_the_band_widens():
    """OU noise with alpha1 -> infinity at fixed S(0) (D = D_white alpha1^2) is white noise:
    corrected must tend to compounded under white noise at first order in 1/alpha1 (S(n Omega)
    / S(0) = 1 - O(Omega^2 / alpha1^2), the fast fluctuation and the wall offset O(1/alpha1)).
    Before the wall offset resolved the covariance's cusp (alpha1 h <= 0.1) its trapezoid gave
    delta of the wrong sign from alpha1 tau ~ 20: L1 1.16 at alpha1 = 20 and no stationary
    density at 40. Bounds, at alpha1 = 5 and 20 (alpha1 tau up to 16 and 63 on the wall
    table: both take the resolved path, more than 120 steps a flight; alpha1 = 40 cost 12 s of
    CPU for the same check): the L1 gap shrinks by at least 2 over the factor 4 in alpha1
    (first order: 4; measured 4.4, gaps 0.193 and 0.044; 10 -> 40 measured 3.7), and at
    alpha1 = 20 it is below 0.1, i.e. alpha1 x gap < 2 (first order: a constant; measured
    0.96, 0.89, 0.88 at alpha1 = 5, 10, 20; the old wrong sign gave a gap of 1.16 at 20)."""
    white = averaging.solve(BASE.with_values({"noise.kind": "white"}), model="compounded")
    ref = white.data["A"]
    gaps = []
    for a1 in (5.0, 20.0):
        sc = BASE.with_values({"noise.alpha1": a1, "noise.D": BASE.noise.D * a1**2})
        r = averaging.solve(sc, model="corrected").data["A"]
        p = np.interp(ref["x"], r["x"], r["p"], right=0.0)
        gaps.append(float(np.trapezoid(np.abs(p - ref["p"]), ref["x"])))
    assert np.isfinite(gaps).all() and gaps[1] < 0.1, gaps
    assert gaps[0] / gaps[1] >= 2.0, gaps
