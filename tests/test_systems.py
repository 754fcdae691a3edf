"""User-defined restoring and damping laws (issue 21): scene keys, the exact orbit of the
general spring, and the stationary truths every solver must meet.

Truths used (independent of the code under test):

- Gibbs: with linear damping d0 only, an elastic barrier (r = 1) or none, no friction and
  white noise, the stationary density of x'' + d0 x' + g(x) = f W is
  p(x, x') ~ exp(-d0 H / (D f^2)), H = x'^2/2 + U(x) (the FPK's detailed balance; e.g.
  Risken, *The Fokker-Planck Equation*, 1989, sec. 10.1). Its x1 marginal is
  ~ exp(-d0 U(x) / (D f^2)), computed here by scipy.integrate.quad on U written out again.
- Energy balance: under white noise the stationary mean power in is f^2 D (Ito), out is
  E[(d(x) + e(x')) x'^2] + mu E|x'| (+ impact losses, none at r = 1).
- The orbit of amplitude A: its period by solve_ivp of y'' + g(y) = 0 (DOP853, rtol 1e-12),
  and sigma_E^2 = 2 pi sum |G_n|^2 S(n Omega) from the FFT of the simulated G = f sgn(y) y'.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from vifpk.core.scene import SceneError, load_scene, restoring_problem, scene_from_dict

DONE_WHEN = [1.0, 0.3, 0.2]  # the "Done when" spring


def gibbs_scene(restoring, *, damping=(0.1,), D=0.01, f=1.0, barrier=True, **extra):
    sys_ = {"restoring": list(restoring), "damping": list(damping), "mu": 0.0, "r": 1.0,
            "f": f, "barrier": barrier}
    return scene_from_dict({"system": sys_, "noise": {"kind": "white", "D": D}, **extra},
                           source="gibbs.toml")


def U_of(k):
    """U(x) = sum_j k_{2j-1} x^{2j} / (2j), written out independently of the code."""
    return lambda x: sum(c * x ** (2 * j + 2) / (2 * j + 2) for j, c in enumerate(k))


def gibbs_x1(k, x, *, beta, barrier=True):
    """p(x1) ~ exp(-beta U(x)) on x > 0 (x in R without the barrier), normalised by quad."""
    U = U_of(k)
    lo = 0.0 if barrier else -np.inf
    Z = quad(lambda s: math.exp(-beta * U(s)), lo, np.inf, epsabs=0, epsrel=1e-12)[0]
    return np.exp(-beta * U(np.asarray(x))) / Z


# ----------------------------------------------------------------------------- scene keys
def test_paper_names_are_the_same_coefficients():
    a = scene_from_dict({"system": {"omega0": 1.5, "alpha": 0.3, "c1": 0.02, "c2": 0.07}})
    b = scene_from_dict({"system": {"restoring": [2.25, 0.3], "damping": [-0.02, 0.07]}})
    for s in (a.system, b.system):
        assert s.restoring_law == (2.25, 0.3) and s.damping_law == (-0.02, 0.07)
        assert s.paper_family_problem() is None
    assert b.system.omega0 is None and b.system.c1 is None  # no stale paper default


@pytest.mark.parametrize(("system", "needle"), [
    ({"restoring": [1.0, 0.3], "alpha": 0.3}, "system.alpha and system.restoring both set"),
    ({"damping": [0.1], "c1": -0.1}, "system.c1 and system.damping both set"),
    ({"restoring": [1.0, -0.3]}, "U(x) does not grow without bound"),
    ({"restoring": [1.0, -0.3, 0.01]}, "g(x) vanishes at x = 1.954"),
    ({"restoring": [-1.0, 0.0, 1.0]}, "allowed: k1 >= 0"),
    ({"restoring": []}, "allowed: a list of 1 to 10 finite numbers"),
    ({"restoring": [1.0, "x"]}, "system.restoring[1] = 'x' must be a finite number"),
    ({"velocity_damping": [0.1] * 11}, "a list of 0 to 10"),
    ({"restoring_law": [1.0]}, "did you mean 'restoring'?"),
])
def test_bad_laws_are_one_line(system, needle):
    with pytest.raises(SceneError) as exc:
        scene_from_dict({"system": system}, source="s.toml")
    assert needle in str(exc.value) and "\n" not in str(exc.value)


def test_restoring_problem_sees_a_double_root_and_allows_pure_cubic():
    # g/x = (1 - 0.15 x^2)^2: touches zero at x^2 = 20/3 (a degenerate second equilibrium)
    assert "vanishes" in restoring_problem((1.0, -0.3, 0.0225))
    assert restoring_problem((1.0, -0.3, 0.0226)) is None  # just above: one well
    assert restoring_problem((0.0, 1.0)) is None


def test_indexed_override_and_alias_on_either_spelling(base):
    s = base.with_values({"system.restoring[2]": 0.2})
    assert s.system.restoring_law == (1.0, 0.6, 0.2) and s.system.damping_law == (-0.025, 0.05)
    assert "x^5" in s.system.paper_family_problem()
    t = s.with_values({"system.alpha": 0.3, "system.c1": 0.1})
    assert t.system.restoring_law == (1.0, 0.3, 0.2) and t.system.damping_law == (-0.1, 0.05)
    # the scene's dict keeps one spelling per law and loads back to the same scene
    d = t.to_dict()
    assert "alpha" not in d["system"] and "restoring" in d["system"]
    assert scene_from_dict(d).system == t.system
    # the base scene's dict is unchanged (paper names only)
    assert set(base.to_dict()["system"]) == {"c1", "c2", "omega0", "alpha", "mu", "r", "f",
                                             "barrier"}


def test_shipped_scenes_of_new_families_load():
    for name in ("systems/quintic", "systems/rayleigh", "systems/linear-ou"):
        s = load_scene(name)
        assert "after" in s.description  # adapted from a published system, said so
    assert load_scene("systems/linear-ou").system.paper_family_problem() is None
    assert "velocity damping" in load_scene("systems/rayleigh").system.paper_family_problem()


# ----------------------------------------------------------------------------- orbit
@pytest.mark.slow
@pytest.mark.parametrize("k", [(1.0, 0.3, 0.2),
                               pytest.param((1.0, -0.3, 0.03), marks=pytest.mark.slow),
                               pytest.param((0.0, 1.0), marks=pytest.mark.slow),
                               pytest.param((1.0, 0.0, 0.0, 0.0, 0.05), marks=pytest.mark.slow)])
def test_period_and_sigma2_of_the_general_orbit(k):
    """T(A) against solve_ivp; sigma_E^2 (OU, sgn form) against the FFT of the simulated
    G = f sgn(y) y' (2^16 samples; tolerance 5e-8: the FFT's N^-2 convergence on the kink of
    sgn(y) y', 2e-8 measured at 2^15 in tests/test_averaging.py, x 2.5 here for the
    stiffer springs). All four in the slow tier (the quintic one took 21 s of the fast tier)."""
    from vifpk.averaging.exact import ExactModel

    sc = scene_from_dict({"system": {"restoring": list(k), "damping": [0.05]},
                          "noise": {"kind": "ou", "D": 0.01, "alpha1": 2.0}})
    m = ExactModel.from_scene(sc)
    g = lambda y: sum(c * y ** (2 * j + 1) for j, c in enumerate(k))  # noqa: E731
    zero = lambda _, z: z[0]  # noqa: E731
    zero.terminal = True  # the first zero of y is the quarter period: stop there
    for A in (0.4, 1.7):
        quarter = solve_ivp(lambda _, z: [z[1], -g(z[0])], (0, 1e3), [A, 0.0], rtol=1e-12,
                            atol=1e-14, method="DOP853", events=zero).t_events[0][0]
        T = 4 * quarter
        assert m.period(np.array([A]))[0] == pytest.approx(T, rel=1e-9)
        n = 1 << 16
        t = np.arange(n) * T / n
        sol = solve_ivp(lambda _, z: [z[1], -g(z[0])], (0, T), [A, 0.0], t_eval=t,
                        rtol=1e-12, atol=1e-14, method="DOP853")
        y, v = sol.y
        G = np.sign(y) * v
        Gn = np.fft.fft(G) / n
        w = np.fft.fftfreq(n, d=T / n) * 2 * math.pi
        S = 0.01 / math.pi / (w**2 + 4.0)
        ref = 2 * math.pi * np.sum(np.abs(Gn) ** 2 * S)
        assert m.sigma2_energy(np.array([A]))[0] == pytest.approx(ref, rel=5e-8)
        # the damping averages: -<d(x) v^2> with d = 0.05
        assert m.energy_terms(np.array([A]))["damping"][0] == pytest.approx(
            -0.05 * np.mean(v**2), rel=1e-9)


def test_velocity_damping_average_against_the_orbit():
    from vifpk.averaging.exact import ExactModel

    sc = scene_from_dict({"system": {"restoring": [1.0, 0.3, 0.2], "damping": [0.0, 0.1, 0.02],
                                     "velocity_damping": [0.3, 0.05]}})
    m = ExactModel.from_scene(sc)
    A = 1.3
    g = lambda y: y + 0.3 * y**3 + 0.2 * y**5  # noqa: E731
    T = m.period(np.array([A]))[0]
    n = 1 << 14
    sol = solve_ivp(lambda _, z: [z[1], -g(z[0])], (0, T), [A, 0.0], t_eval=np.arange(n) * T / n,
                    rtol=1e-12, atol=1e-14, method="DOP853")
    y, v = sol.y
    ref = -np.mean((0.1 * y**2 + 0.02 * y**4 + 0.3 * v**2 + 0.05 * v**4) * v**2)
    assert m.energy_terms(np.array([A]))["damping"][0] == pytest.approx(ref, rel=1e-9)


# ----------------------------------------------------------------------------- Gibbs
# The grid of the stationary density holds all but 1e-8 of the mass (averaging/stationary.py,
# tail = 1e-10); its cubic spline in A and the Gauss-Legendre marginals are good to ~1e-10
# (measured 4e-11 .. 5e-11 on the four laws below): L1 <= 1e-7 is that budget x 10.
GIBBS_L1 = 1e-7


def _exact_vs_gibbs(k, model="exact", **kw):
    from vifpk import averaging

    sc = gibbs_scene(k, **kw)
    r = averaging.solve(sc, model=model)
    x, p = r.data["x1"]["x"], r.data["x1"]["p"]
    beta = sc.system.damping_law[0] / (sc.noise.D * sc.system.f**2)
    ref = gibbs_x1(k, x, beta=beta, barrier=sc.system.barrier)
    return float(np.trapezoid(np.abs(p - ref), x)), r


def test_done_when_scene_exact_model_is_gibbs():
    l1, r = _exact_vs_gibbs(DONE_WHEN)
    assert l1 < GIBBS_L1 and r.info["status"]["ok"]


@pytest.mark.slow
@pytest.mark.parametrize("k", [(1.0, -0.3, 0.03),    # softening, then bounded by k5
                               (1.0, -0.3, 0.0226),  # soft spring just above its bound
                               (0.0, 1.0),           # pure cubic (no linear spring)
                               (1.0, 0.0, 0.0, 0.0, 0.05),  # degree 9
                               (1.0, 0.3, 20.0)])    # large quintic coefficient
@pytest.mark.parametrize("model", ["exact", "corrected"])
def test_exact_and_corrected_are_gibbs(k, model):
    """At r = 1 the corrected model's loss -ln r^2 is 0 too: both must be Gibbs."""
    l1, r = _exact_vs_gibbs(k, model=model)
    assert l1 < GIBBS_L1 and r.info["status"]["ok"]


@pytest.mark.slow
def test_gibbs_without_barrier_and_with_gain():
    l1, _ = _exact_vs_gibbs(DONE_WHEN, barrier=False, f=1.7, D=0.02)
    assert l1 < GIBBS_L1


def test_paper_model_refuses_outside_its_family():
    from vifpk import averaging

    with pytest.raises(ValueError, match="x\\^5 term"):
        averaging.build_model(gibbs_scene(DONE_WHEN), "paper")


# ----------------------------------------------------------------------------- Monte Carlo
# An MC density is within its noise when L1 <= 2.5 x its L1 noise floor (the floor is the
# expected L1 of the noise alone; 2.5 is harness.workflows.verdict.SAMPLING_FACTOR, where the same
# test judges an averaged SDE against its closed form).
MC_FACTOR = 2.5


def _mc(scene):
    from vifpk.harness.door.solvers import montecarlo_solution

    return montecarlo_solution(scene, progress=False)


@pytest.mark.slow
def test_montecarlo_done_when_scene_is_gibbs():
    """The issue's scene: the simulated x1 histogram against Gibbs integrated over each bin."""
    sc = gibbs_scene(DONE_WHEN, montecarlo={"floor": 0.01, "dt": "auto"})
    r = _mc(sc)
    d = r.data["x1"]
    e = np.asarray(d["edges"])
    beta = 0.1 / 0.01
    U = U_of(DONE_WHEN)
    Z = quad(lambda s: math.exp(-beta * U(s)), 0, np.inf, epsrel=1e-12)[0]
    ref = np.array([quad(lambda s: math.exp(-beta * U(s)), a, b, epsrel=1e-10)[0]
                    for a, b in zip(e[:-1], e[1:], strict=True)]) / Z
    l1 = float(np.sum(np.abs(np.asarray(d["p"]) * np.diff(e) - ref)))
    assert l1 <= MC_FACTOR * r.info["L1_floor"]["x1"], (l1, r.info["L1_floor"])


@pytest.mark.slow
def test_montecarlo_energy_balance_general_damping_and_friction():
    """E[(d(x) + e(x')) x'^2] + mu E|x'| = f^2 D under white noise (elastic barrier: no
    impact loss), within 3 standard errors of the block means; a quintic spring, a
    damping law with x^2 and x^4 terms, Rayleigh velocity damping and friction all on."""
    sc = scene_from_dict({
        "system": {"restoring": [1.0, 0.3, 0.2], "damping": [0.02, 0.05, 0.01],
                   "velocity_damping": [0.05, 0.01], "mu": 0.002, "r": 1.0, "f": 1.3},
        "noise": {"kind": "white", "D": 0.01},
        "montecarlo": {"paths": 256, "blocks": 16, "time": 1000.0},
        "observables": {"energy": True, "x1": False, "x2": False}})
    en = _mc(sc).info["energy"]
    losses, exact = en["losses"], 1.3**2 * 0.01
    assert abs(losses["value"] - exact) <= 3 * losses["err"], (losses, exact)
    assert en["damping"]["value"] > 0 and en["friction"]["value"] > 0


# ----------------------------------------------------------------------------- hard cases
@pytest.mark.slow
@pytest.mark.parametrize("name", ["soft-bound", "degree9", "quintic-large"])
def test_hard_springs_give_finite_normalised_densities(name):
    """Every solver of check (closed forms, FPKs, averaged SDEs, the original system's Monte
    Carlo) on the hard springs of scenes/hard/: finite, normalised densities and finite
    metrics (harness.workflows.check.output_problems, the same bounds as the other hard scenes)."""
    from vifpk.harness.workflows.check import cross_check, output_problems

    scene = load_scene(f"hard/{name}").with_values(
        {"montecarlo.paths": 64, "montecarlo.blocks": 16, "montecarlo.time": 100.0})
    result = cross_check(scene, quiet=True)
    assert output_problems(result) == []
    assert "paper" not in result.metrics["models"] and "models_absent" in result.metrics


# ----------------------------------------------------------------------------- the harness
def test_paper_model_absent_outside_its_family(capsys):
    """solve --model paper: exit 2, one line, before any computation; check and figures take
    the models that apply."""
    from vifpk.harness.cli.app import main
    from vifpk.harness.workflows.check import models_of
    from vifpk.harness.workflows.figures import figure_models

    assert main(["solve", "systems/quintic", "--solver", "averaging", "--model", "paper"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--model paper" in err and "x^5 term" in err and "\n" not in err
    q = load_scene("systems/quintic")
    assert models_of(q) == (("exact", "corrected"), {"paper": q.system.paper_family_problem()})
    assert figure_models(q) == ("exact", "corrected")
    base = load_scene("paper-base")
    assert models_of(base)[0] == ("paper", "exact", "corrected")
    assert figure_models(base) == ("paper", "exact", "corrected")  # issue 28: corrected too


def test_sweep_over_a_coefficient_loads():
    from vifpk.harness.sweeps.spec import load_sweep

    sw = load_sweep("quintic-k5")
    ks = sorted(p.scene.system.restoring_law[2] for p in sw.points)
    assert ks == [0.0, 0.5, 1.0, 2.0, 4.0]


def test_figures_of_your_own_scene_options(capsys, tmp_path):
    """figures --scene draws any scene (run in the slow tier below); with --figure it is
    refused before any work; the table takes the two models drawn as its columns."""
    from vifpk.harness.cli.app import main
    from vifpk.harness.workflows.figures import render_table

    assert main(["figures", "--scene", "systems/quintic", "--figure", "5",
                 "--out", str(tmp_path / "f")]) == 2
    assert "--figure: does not apply with --scene" in capsys.readouterr().err
    l1 = {m: {o: 0.01 for o in ("A", "x1", "x2")} for m in ("exact", "corrected")}
    text = render_table({"figure-q": {"varied": "system.r", "values": [0.98],
                                      "models": ["exact", "corrected"], "L1": [l1],
                                      "L1_floor": [{"A": 0.02}]}})
    assert "L1(A) exact | L1(A) corrected" in text and "paper" not in text
    assert "| q | r = 0.98 |" in text
    l1["paper"] = {o: 0.3 for o in ("A", "x1", "x2")}
    text = render_table({"figure2": {"varied": "system.r", "values": [0.98],
                                     "models": ["paper", "exact", "corrected"], "L1": [l1],
                                     "L1_floor": [{"A": 0.02}]}})
    assert "| L1(A) paper | L1(A) exact | L1(A) corrected |" in text
    assert "| 2 | r = 0.98 | 0.300 | 0.010 | 0.010 |" in text


@pytest.mark.slow
def test_figures_of_your_own_scene(tmp_path):
    from vifpk.harness.cli.app import main

    out = tmp_path / "f"
    assert main(["figures", "--scene", "systems/quintic", "--out", str(out), "--paths", "64",
                 "--time", "100", "--quiet"]) == 0
    assert (out / "systems-quintic-joint.png").stat().st_size > 0
    assert (out / "systems-quintic-pdfs.png").stat().st_size > 0


def test_general_code_path_reproduces_the_paper_spring(base):
    """The base scene's spring written with a zero quintic term runs the general code (nu as
    a polynomial in cos^2, U^-1 by bisection and Newton) instead of the Duffing closed forms:
    the exact model's densities agree to 1e-9 relative to their peak (round-off of two
    evaluations of the same formula: 7e-16 measured; 1e-9 leaves room for other platforms)."""
    from vifpk import averaging

    general = base.with_values({"system.restoring": [1.0, 0.6, 0.0]})
    assert general.system.restoring_law == (1.0, 0.6, 0.0)
    a = averaging.solve(base, model="exact")
    b = averaging.solve(general, model="exact")
    for o in ("A", "x1", "x2"):
        np.testing.assert_allclose(b.data[o]["p"], a.data[o]["p"],
                                   atol=1e-9 * float(np.max(a.data[o]["p"])), rtol=0)


def test_strong_velocity_damping_is_warned():
    """A Rayleigh force e2 x'^2 x' that takes most of the energy each period trips the
    strong-damping warning and is named as its main effect (energy_rates' "velocity
    damping"): with e2 = 3 the energy changes by 0.77 of itself per period at the mean
    amplitude (measured; the warning's threshold is 0.5, docs/report.md)."""
    from vifpk.harness.workflows.assumptions import assumption_warnings

    from vifpk import averaging

    sc = load_scene("systems/rayleigh").with_values(
        {"system.velocity_damping": [3.0], "system.damping": [0.0], "noise.D": 0.05})
    w = assumption_warnings(sc, {"exact": averaging.solve(sc, model="exact")}, {})
    text = " ".join(str(x) for x in w)
    assert "strong damping" in text and "velocity damping" in text, text


# ------------------------------------------------- pure-power springs under OU noise (issue 28)
def _ou_scene(restoring, **averaging):
    return scene_from_dict({"system": {"restoring": list(restoring), "damping": [-0.025, 0.05],
                                       "mu": 0.001, "r": 0.96, "f": 1.0},
                            "noise": {"kind": "ou", "D": 0.01, "alpha1": 2.0},
                            **({"averaging": averaging} if averaging else {})})


def _sigma2_by_fft(k, A, D, alpha1, samples):
    """sigma_E^2 = 2 pi sum |G_n|^2 S(n Omega), G = sgn(y) y' of the orbit simulated by
    solve_ivp (the truth of test_period_and_sigma2_of_the_general_orbit)."""
    g = lambda y: sum(c * y ** (2 * j + 1) for j, c in enumerate(k))  # noqa: E731
    ev = lambda _, z: z[0]  # noqa: E731
    ev.terminal = True
    quarter = solve_ivp(lambda _, z: [z[1], -g(z[0])], (0, 1e9), [A, 0.0], rtol=1e-12,
                        atol=1e-14 * A, method="DOP853", events=ev).t_events[0][0]
    T = 4 * quarter
    t = np.arange(samples) * T / samples
    y, v = solve_ivp(lambda _, z: [z[1], -g(z[0])], (0, T), [A, 0.0], t_eval=t, rtol=1e-12,
                     atol=1e-14 * A, method="DOP853").y
    Gn = np.fft.fft(np.sign(y) * v) / samples
    w = np.fft.fftfreq(samples, d=T / samples) * 2 * math.pi
    return 2 * math.pi * np.sum(np.abs(Gn) ** 2 * D / math.pi / (w**2 + alpha1**2))


@pytest.mark.parametrize("restoring,model", [
    ((0.0, 0.0, 1.0), "exact"),
    pytest.param((0.0, 0.0, 1.0), "corrected", marks=pytest.mark.slow),
    pytest.param((1e-90, 0.0, 1.0), "exact", marks=pytest.mark.slow),
    pytest.param((1e-90, 0.0, 1.0), "corrected", marks=pytest.mark.slow),
    pytest.param((0.0, 0.6), "exact", marks=pytest.mark.slow),
    pytest.param((0.0, 0.6), "corrected", marks=pytest.mark.slow)])
def test_pure_power_spring_under_ou_noise_has_its_density(restoring, model):
    """k1 = 0: the orbit's frequency Omega -> 0 as A -> 0, where the Parseval form of the OU
    harmonic sum cancels to all digits (it used to raise 'sigma_E^2 < 0 at A = 0.00044',
    whatever the harmonics), and the corrected model's wall energy E e^{-delta/E} overflowed
    (delta < 0 growing like the flight); each closed form now gives a density of mass 1."""
    from vifpk.averaging.solve import solve

    res = solve(_ou_scene(restoring), model=model)
    p, x = res.data["A"]["p"], res.data["A"]["x"]
    assert np.all(np.isfinite(p)) and np.all(p >= 0)
    assert np.trapezoid(p, x) == pytest.approx(1.0, abs=1e-6)


def test_wall_energy_is_first_order_and_bounded_on_a_slow_orbit():
    """E_wall = E - delta + O(delta^2 / E) where |delta| << E, and within (0, 2E) where the
    linear response does not hold (delta < 0 and |delta| >> E on the quintic at small A)."""
    from vifpk.averaging.corrected import CorrectedModel
    from vifpk.averaging.geometry import potential_k

    m = CorrectedModel.from_scene(_ou_scene((0.0, 0.0, 1.0)))
    A = np.array([1e-3, 0.05, 0.3, 1.0, 2.0])
    E, d, Ew = potential_k(A, m.restoring), m.wall_offset(A), m.wall_energy(A)
    assert np.all((Ew > 0) & (Ew <= 2 * E))
    small = np.abs(d) < 0.1 * E
    assert small.sum() >= 1 and np.all(d[~small] < 0)  # both regimes are exercised
    # <=: where the flight is many correlation times long (A -> 0 here) delta is at its
    # white-noise limit 0 and E_wall = E exactly (corrected.WALL_STEPS_MAX)
    assert np.all(np.abs(Ew - (E - d))[small] <= (d**2 / E)[small])


def test_slow_orbit_sigma2_tends_to_white_noise_with_the_impact_correction():
    """Independent truth: for Omega << alpha1 the OU noise looks white, sigma_E^2 ->
    2 f^2 D <v^2> / alpha1^2, less the impacts' share: expanding sum u^2 Y_n^2 S(u) with
    Y_n ~ 4 v0 / (T u^2) (the kinks of |y|) gives the relative deficit
    eps = 4 v0^2 / (T alpha1 <v^2>) + O(eps^2). For U = A^6 / 6 (k = (0, 0, 1)) T and <v^2>
    are Beta integrals (written out here, not the code's orbit): T = (4 sqrt 3 / A^2)
    B(1/6, 1/2) / 6 and T <v^2> = 4 (A^4 / sqrt 3) B(1/6, 3/2) / 6, v0^2 = A^6 / 3. The
    remainder must be second order over these three decades of eps (6e-8 to 3e-3):
    |ratio - (1 - eps)| < 3 eps^2 (measured 1.9 eps^2 at every A; 1e-13: the orbit averages'
    rounding). A first-order error (a wrong tail, a wrong form) fails it at once."""
    from scipy.special import beta
    from vifpk.averaging.exact import ExactModel

    m = ExactModel.from_scene(_ou_scene((0.0, 0.0, 1.0)))
    for A in (4.4e-4, 1e-2, 3e-2, 1e-1):
        T = 4 * math.sqrt(3) / A**2 * beta(1 / 6, 1 / 2) / 6
        v2 = 4 * (A**4 / math.sqrt(3)) * beta(1 / 6, 3 / 2) / 6 / T
        eps = 4 * (A**6 / 3) / (T * 2.0 * v2)
        white = 2 * 0.01 * v2 / 2.0**2
        ratio = m.sigma2_energy(np.array([A]))[0] / white
        assert abs(ratio - (1 - eps)) < 3 * eps**2 + 1e-13, (A, ratio, eps)


@pytest.mark.parametrize("name,k,A", [("quintic, slow orbit", (0.0, 0.0, 1.0), 0.1),
                                      ("wide band (alpha1-wide)", (1.0, 0.6), 1.0)])
def test_sigma2_of_a_slow_orbit_against_the_fft(name, k, A):
    """Omega / alpha1 = 4e-3 (the quintic at A = 0.1) and 1.2e-2 (alpha1 = 100 on the paper's
    spring): sigma_E^2 against the FFT of the simulated orbit, 2^18 samples (the FFT's N^-2
    error, measured 2^16 -> 2^18: 1.6e-7 and 7e-8, leaves < 1e-8 at 2^18): tolerance 3e-8.
    Before, the Parseval form was 9e-8 and 3.4e-6 off (its tail's S ~ c / w^2 and its
    missing k1 / u^2 term)."""
    from vifpk.averaging.exact import ExactModel

    alpha1 = 2.0 if k[0] == 0.0 else 100.0
    sc = scene_from_dict({"system": {"restoring": list(k)},
                          "noise": {"kind": "ou", "D": 0.01, "alpha1": alpha1}})
    ref = _sigma2_by_fft(k, A, 0.01, alpha1, 1 << 18)
    assert ExactModel.from_scene(sc).sigma2_energy(np.array([A]))[0] == pytest.approx(
        ref, rel=3e-8, abs=0)


def test_more_harmonics_than_the_quadrature_resolves_is_refused():
    """harmonics 96 on 64 nodes gave a negative sigma_E^2 whose advice was 'raise harmonics'."""
    with pytest.raises(SceneError, match=r"averaging.harmonics = 96 .* at most 3/4 of "
                                         r"theta_nodes \(48\).*theta_nodes to 128"):
        _ou_scene((0.0, 0.0, 1.0), harmonics=96)
    _ou_scene((0.0, 0.0, 1.0), harmonics=96, theta_nodes=128)
