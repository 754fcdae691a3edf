"""dt = "auto" (issue 29): the step rule reads the scene's time scale, and a run-time check
judges the bias it leaves (montecarlo/tuning.py; docs/montecarlo.md, "The step rule on other
scenes"). The fast tests hold the formulas and the check's statistics on histograms whose
truth is known; the slow ones run the Monte Carlo."""

from __future__ import annotations

import math
from dataclasses import asdict

import numpy as np
import pytest
from scipy.special import ellipk
from vifpk.montecarlo import tuning
from vifpk.montecarlo.plan import physics, step_size

from vifpk import montecarlo as mc
from vifpk.core.scene import MonteCarloSettings, load_scene, scene_from_dict


def _phys(w0sq=1.0, alpha=0.6, khi=None, c1=0.025, c2=0.05, mu=0.001, D=0.01, alpha1=2.0):
    return {"w0sq": w0sq, "alpha": alpha, "khi": None if khi is None else np.array(khi),
            "c1": c1, "c2": c2, "mu": mu, "D": D, "alpha1": alpha1, "r": 0.96, "f": 1.0,
            "dhi": None, "ev": None}


@pytest.mark.parametrize("w0sq, alpha, A", [(1.0, 0.6, 0.4), (1.0, 10.0, 1.5), (4.0, 2.0, 0.9)])
def test_orbit_frequency_is_the_duffing_period(w0sq, alpha, A):
    """x'' + w0^2 x + alpha x^3 = 0 from amplitude A: T = 4 K(m) / sqrt(w0^2 + alpha A^2),
    m = alpha A^2 / (2 (w0^2 + alpha A^2)) (the Jacobi cn solution)."""
    s = w0sq + alpha * A * A
    T = 4 * ellipk(alpha * A * A / (2 * s)) / math.sqrt(s)
    assert tuning.orbit_omega(_phys(w0sq, alpha), A) == pytest.approx(2 * math.pi / T, rel=1e-10)
    assert tuning.orbit_omega(_phys(w0sq, alpha), 0.0) == pytest.approx(math.sqrt(w0sq))


def test_the_fastest_orbit_of_softening_and_hardening_springs():
    soft = _phys(1.0, -0.3, khi=[0.0226])  # scenes/hard/soft-bound.toml: g/x dips below 1
    assert tuning.scene_omega(soft, 1.5) == pytest.approx(1.0)
    hard = _phys(1.0, 10.0)
    assert tuning.scene_omega(hard, 1.5) == pytest.approx(tuning.orbit_omega(hard, 1.5))
    assert tuning.scene_omega(_phys(0.0, 1.0), 1.0) > 0  # a pure cubic has a frequency too


@pytest.mark.parametrize("floor", [0.002, 0.005, 0.01, 0.05])
def test_the_step_scales_with_the_scene_time(floor):
    """A scene with every frequency times s (k -> s^2 k, c -> s c, alpha1 -> s alpha1, ...) is
    the same system on a clock s times faster: its automatic step is the base one / s."""
    base = _phys()
    for s in (0.5, 2.0, 3.0):
        fast = _phys(s * s, s * s * 0.6, c1=s * 0.025, c2=s * 0.05, mu=s * s * 0.001,
                     D=s**3 * 0.01, alpha1=s * 2.0)
        for a_max in (0.5, 1.0, 2.0):
            assert tuning.auto_dt(floor, fast, a_max) == pytest.approx(
                tuning.auto_dt(floor, base, a_max) / s, rel=1e-12)


def test_the_base_scene_step():
    """The base scene's step from the bias envelope (issue 44; montecarlo/tuning.py): 0.5 / 21
    at floor 0.005 at the default seed's pilot amplitude (0.5 / 23 before the envelope), 0.5 /
    20 or 0.5 / 21 over the amplitudes its scale pilot sees from any seed (BASE_AMPLITUDES:
    Omega 1.115-1.145 puts the envelope's step 0.0247 OMEGA_REF / Omega across 0.5 / 20.2),
    and 0.5 / 13 at 0.01 and without a floor for every seed, as before."""
    phys = physics(*(lambda s: (s.system, s.noise))(load_scene("paper-base")))
    default_seed = 0.8330  # the pilot's amplitude at the default seed
    assert step_size("auto", 0.005, phys, 0.5, default_seed) == pytest.approx(0.5 / 21)
    for a in (*tuning.BASE_AMPLITUDES, default_seed):
        assert 0.5 / step_size("auto", 0.005, phys, 0.5, a) in (pytest.approx(20),
                                                                 pytest.approx(21))
        assert step_size("auto", 0.01, phys, 0.5, a) == pytest.approx(0.5 / 13)
        assert step_size("auto", 0.0, phys, 0.5, a) == pytest.approx(0.5 / 13)
    # before the pilot: the provisional step is the base family's
    assert step_size("auto", 0.005, phys, 0.5) == pytest.approx(0.5 / 21)


def test_a_stiffer_spring_gets_a_shorter_step():
    base, stiff = _phys(), _phys(1.0, 10.0)
    assert tuning.auto_dt(0.005, stiff, 1.2) < 0.5 * tuning.auto_dt(0.005, base, 1.2)


# --- the run-time check, on histograms whose truth is known ----------------------------------

def _hist(truth, se, rng, blocks=32):
    """A Monte Carlo-like histogram of ``truth``: block densities with per-bin noise such that
    the block mean has standard error ``se``."""
    p_blocks = truth + rng.standard_normal((blocks, truth.size)) * se * math.sqrt(blocks)
    p = p_blocks.mean(axis=0)
    err = p_blocks.std(axis=0, ddof=1) / math.sqrt(blocks)
    return {"p": p, "err": err, "p_blocks": p_blocks}


def _setup(bias, floor=0.005, factor=tuning.CHECK_FACTOR, order=tuning.BIAS_P, seed=0):
    """Two runs of a Gaussian p(A): the run at dt with L1 bias ``bias``, the check at
    factor x dt with bias factor^order x that (a shift of the law), floors floor and 2 floor."""
    rng = np.random.default_rng(seed)
    edges = np.linspace(0.0, 1.0, 101)
    x, w = 0.5 * (edges[1:] + edges[:-1]), np.diff(edges)

    def law(shift):
        return np.exp(-0.5 * ((x - 0.4 - shift) / 0.1) ** 2) / (0.1 * math.sqrt(2 * math.pi))

    unit = np.sum(np.abs(law(1e-3) - law(0.0)) * w) / 1e-3  # L1 per unit shift
    p0 = law(0.0)
    se = floor / (math.sqrt(2 / math.pi) * np.sum(np.sqrt(p0 / p0.sum()) * w)) * \
        np.sqrt(p0 / p0.sum())
    run = _hist(law(bias / unit), se, rng) | {"edges": edges}
    coarse = _hist(law(factor**order * bias / unit), 2 * se, rng)
    return run, coarse


@pytest.mark.parametrize("seed", range(5))
def test_the_check_passes_a_small_bias_and_fails_a_large_one(seed):
    """Floors 0.005 (the run) and 0.01 (the check), allowance 0.0025, the bias growing like
    dt^BIAS_P: 0.2 x the allowance is not failed (passed in most seeds, else undecided), 8x
    is failed (beyond the allowance even if it grew like dt^2), and the range of the bias
    the two declared orders allow holds the truth."""
    allowance, k = 0.0025, tuning.CHECK_FACTOR
    ok = tuning.step_check(*_setup(0.0005, seed=seed), dt=0.02, factor=k, allowance=allowance)
    assert ok["verdict"] in ("passed", "undecided") and ok["bias"] < allowance
    bad = tuning.step_check(*_setup(0.02, seed=seed), dt=0.02, factor=k, allowance=allowance)
    assert bad["verdict"] == "failed"
    lo, hi = bad["bias_range"]
    assert lo <= 0.02 <= hi


def _looking(bias, floors, seed=0):
    """run_step_check with a canned coarse run: look i returns the law shifted by 4^BIAS_P x
    ``bias`` with floor ``floors[i]`` (a stand-in for simulate: the looks are what is tested,
    not the Monte Carlo). Returns the check's record and the settings each look asked for."""
    from types import SimpleNamespace

    from vifpk.montecarlo.stepcheck import run_step_check

    run, _ = _setup(bias, seed=seed)
    asked = []

    def simulate(system, noise, st):
        i = len(asked)
        asked.append(st)
        _, coarse = _setup(bias, floor=floors[i] / 2, seed=seed + 1 + i)
        timing = {"stages": {"sampling": {"wall": 1.0, "cpu": 1.0}},
                  "total": {"wall": 1.0, "cpu": 1.0}}
        return SimpleNamespace(data={"A": coarse}, info={
            "timing": timing, "L1_floor": {"A": floors[i]},
            **({"checkpoint": f"state {i}"} if st.keep_state else {})})

    st = _settings(dt="auto", floor=0.005)
    out = run_step_check(simulate, None, None, st, run, {}, 0.02, 100.0, 1000.0, 0.005, 0.005,
                         math.inf, 1.0, reach=1.2)
    return out, asked


def test_the_sequential_check_stops_at_the_first_look_that_decides():
    """The check's looks (tuning.CHECK_LOOKS): a bias 0.1 x the allowance is excluded from
    failing at the first look when that look's floor allows it (the verdict stays
    "undecided", the failure excluded); a bias 8 x the allowance fails at the first look; a
    bias at the failure threshold goes on to the last look, whose floor is today's single
    run's (seed 0 of the canned noise). Each look continues the one before (resume) and the
    last keeps no state; the coarse run reuses the run's reach (no scale pilot)."""
    looks = tuning.CHECK_LOOKS
    floors = [r * 0.005 for r in looks]
    small, asked = _looking(0.00025, floors)
    assert small["verdict"] == "undecided" and small["stopped"] == "a failure excluded"
    assert len(small["looks"]) == 1 and small["timing"]["total"]["cpu"] == 1.0
    quiet, _ = _looking(0.00025, [0.3 * f for f in floors])  # a check whose noise is small
    assert quiet["verdict"] == "passed" and quiet["stopped"] == "decided"
    assert asked[0].resume is None and asked[0].keep_state and asked[0].start_reach == 1.2
    assert asked[0].floor == pytest.approx(looks[0] * 0.005)
    bad, _ = _looking(0.02, floors)
    assert bad["verdict"] == "failed" and len(bad["looks"]) == 1
    edge, asked = _looking(0.0025 * (tuning.CHECK_FACTOR**2 - 1)
                           / (tuning.CHECK_FACTOR**tuning.BIAS_P - 1), floors)
    assert len(edge["looks"]) == len(looks) and edge["stopped"] in ("decided", "last look")
    assert [a.resume for a in asked] == [None, "state 0", "state 1"]
    assert not asked[-1].keep_state and asked[-1].floor == pytest.approx(
        tuning.CHECK_FLOOR_RATIO * 0.005)
    assert edge["timing"]["total"]["cpu"] == len(looks)


def test_the_coarse_burn_in_follows_its_formula():
    """burnin._coarse_burn_in on a canned plan: at dt, tau ln(D tau / (BURN_SHARE F T_1))
    with D = (k^2 - 1) BIAS_FRACTION F; none without the step check, a target floor or a
    stable k dt, nor where the split would cost more than the burn-in at dt."""
    from types import SimpleNamespace

    from vifpk.montecarlo.burnin import _coarse_burn_in

    def plan(**kw):
        st = SimpleNamespace(**{"dt": "auto", "dt_check": True, "start_state": None, **kw})
        return SimpleNamespace(settings=st, target=kw.get("target", 0.005))

    relax, tau, F, T1, k = {"tau": 90.0}, 90.0, 0.005, 1000.0, tuning.CHECK_FACTOR
    got = _coarse_burn_in(plan(), relax, 6 * tau, 0.025, T1, 1.1)
    D = (k**2 - 1) * tuning.BIAS_FRACTION * F
    assert got["fine"] == pytest.approx(tau * math.log(D * tau / (tuning.BURN_SHARE * F * T1)))
    assert got["dt"] == k * 0.025 and got["time"] == 6 * tau
    assert _coarse_burn_in(plan(dt_check=False), relax, 6 * tau, 0.025, T1, 1.1) is None
    assert _coarse_burn_in(plan(target=0.0), relax, 6 * tau, 0.025, T1, 1.1) is None
    assert _coarse_burn_in(plan(), relax, 6 * tau, 0.025, T1, 1.0 / (k * 0.025)) is None
    assert _coarse_burn_in(plan(), relax, 6 * tau, 0.025, 1.0, 1.1) is None  # T_1 tiny


def test_the_check_orders_are_the_kernels():
    from vifpk.montecarlo import kernels as K

    assert tuning.CHECK_ORDERS == (K.WEAK_ORDER_NONSMOOTH, K.WEAK_ORDER_SMOOTH)


def test_the_check_estimates_the_bias_at_the_rule_order():
    """With the check's noise small, b_hat = L / (k^p - 1) recovers the bias at dt."""
    est = [tuning.step_check(*_setup(0.004, floor=0.0005, seed=s), dt=0.02,
                             factor=tuning.CHECK_FACTOR, allowance=0.0025)["bias"]
           for s in range(5)]
    assert np.mean(est) == pytest.approx(0.004, rel=0.05)


def _scene(**system):
    raw = {"system": {"c1": 0.025, "c2": 0.05, "omega0": 1.0, "alpha": 0.6, "mu": 0.001,
                      "r": 0.96, "f": 1.0, **system},
           "noise": {"kind": "ou", "D": 0.01, "alpha1": 2.0}}
    return scene_from_dict(raw)


def _settings(**kw):
    return mc.Settings(**{**asdict(MonteCarloSettings()), "progress": False, "threads": 1,
                          "observables": ("A", "moments"), **kw})


@pytest.mark.slow
def test_the_check_runs_with_dt_auto_and_passes_at_the_base_scene():
    sc = load_scene("paper-base")
    res = mc.simulate(sc.system, sc.noise, _settings(dt="auto", floor=0.01))
    chk, rule = res.info["dt_check"], res.info["dt_rule"]
    assert res.info["settings"]["dt"] == pytest.approx(0.5 / 13)
    assert rule["omega"] == pytest.approx(tuning.OMEGA_REF, rel=0.03)
    assert chk["verdict"] in ("passed", "undecided") and res.info["warnings"] == []
    assert chk["check_dt"] == pytest.approx(tuning.CHECK_FACTOR * 0.5 / 13)
    # cheap against the run: about 1 / (4 x 4) of its sampled path-steps, plus its burn-in
    assert res.info["seconds"]["dt_check"] < 0.5 * res.info["seconds"]["run"]
    # the burn-in's two parts (burnin._coarse_burn_in): 6 tau at 4 dt, then at dt the time
    # that leaves at most BURN_SHARE of the floor of the coarse law's distance; equilibrated
    coarse, tau = res.info["burn_in_coarse"], res.info["relaxation"]["tau"]
    assert coarse["dt"] == pytest.approx(4 * 0.5 / 13) and coarse["time"] == pytest.approx(
        6 * tau, rel=0.01)
    assert 0 < coarse["fine"] < 6 * tau and res.info["convergence"]["equilibrated"]
    assert res.info["settings"]["burn_in"] == pytest.approx(coarse["time"] + coarse["fine"],
                                                            abs=0.5 / 13)
    pinned = mc.simulate(sc.system, sc.noise, _settings(dt=0.5 / 13, floor=0.01))
    assert "dt_check" not in pinned.info  # a step given is the caller's: not checked
    assert "burn_in_coarse" not in pinned.info  # nor is its burn-in split


@pytest.mark.slow
def test_the_check_fails_and_says_so_when_the_rule_is_too_optimistic(monkeypatch):
    """A rule far too optimistic (base-family step 0.1 whatever the floor) on a scene with
    strongly inelastic impacts, where the bias at dt = 0.1 is 0.007 in L1 against the
    allowance 0.0025 of floor 0.005 (benchmarks/results/dt_bias.json, r-0.5): the check must
    fail and the run must carry the warning."""
    monkeypatch.setattr(tuning, "DT_RANGE", (0.1, 0.1))
    sc = _scene(r=0.5)
    res = mc.simulate(sc.system, sc.noise, _settings(dt="auto", floor=0.005))
    assert res.info["settings"]["dt"] == pytest.approx(0.1)
    chk = res.info["dt_check"]
    assert chk["verdict"] == "failed", chk
    assert res.info["warnings"] == [chk["message"]] and "ABOVE" in chk["message"]
    # caught at the first look of the sequential check (stepcheck.run_step_check): the
    # coarse run stopped at CHECK_LOOKS[0] x the floor, 1/4 of the last look's time
    assert chk["stopped"] == "decided" and len(chk["looks"]) == 1, chk["looks"]


UNLIKE = {  # benchmarks/bench_dt_bias.py's scenes unlike the base one
    "stiff": ({"alpha": 2.0, "c1": 0.04}, {"D": 0.015}),
    "white": ({}, {"kind": "white"}),
    "mu-0.05": ({"mu": 0.05}, {}),
    "r-0.5": ({"r": 0.5}, {}),
    "omega0-2": ({"omega0": 2.0}, {"D": 0.04}),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(UNLIKE))
def test_the_rule_on_scenes_unlike_the_base_one(name):
    """Floor 0.01, default seed: the step follows the scene's Omega (the omega0 = 2 scene,
    whose bias at the old step was above the allowance, gets about half of the base step;
    docs/montecarlo.md, "The step rule on other scenes"), and the check does not cry wolf
    where the dt ladder measured the bias at that step within the allowance."""
    system, noise = UNLIKE[name]
    raw = {"system": {"c1": 0.025, "c2": 0.05, "omega0": 1.0, "alpha": 0.6, "mu": 0.001,
                      "r": 0.96, "f": 1.0, **system},
           "noise": {"kind": "ou", "D": 0.01, "alpha1": 2.0, **noise}}
    if raw["noise"]["kind"] == "white":  # alpha1 is OU's key: refused for white (issue 43)
        del raw["noise"]["alpha1"]
    sc = scene_from_dict(raw)
    res = mc.simulate(sc.system, sc.noise, _settings(dt="auto", floor=0.01))
    rule, chk = res.info["dt_rule"], res.info["dt_check"]
    assert res.info["settings"]["dt"] <= tuning.DT_RANGE[1] * tuning.OMEGA_REF / rule["omega"]
    if name == "omega0-2":
        assert rule["omega"] == pytest.approx(2.0, rel=0.02)
        assert res.info["settings"]["dt"] < 0.6 * 0.5 / 13
    assert chk["verdict"] != "failed", chk
    assert res.info["warnings"] == []


# --- parametric noise (issue 37): its own rate nu in the step rule ------------------------------

def _linear_phys(k, w, D_k, D_c, s=1.0):
    """A linear oscillator's physics on a clock s times faster (k -> s k, w -> s w, D -> D / s)."""
    scene = scene_from_dict({"system": {"restoring": [(s * w) ** 2], "damping": [s * k],
                                        "mu": 0.0, "barrier": False},
                             "noise": {"kind": "white", "D": 0.01},
                             "parametric": {"stiffness": D_k / s, "damping": D_c / s}})
    return physics(scene.system, scene.noise, scene.parametric)


def test_the_parametric_rate_of_a_linear_oscillator():
    """nu = D_k w^2 + 3 D_c k^2 (docs/averaging.md section 12: b of sigma_E^2 = s E + b E^2),
    at every amplitude; it scales as a frequency; without parametric noise the rule's rate
    is scene_omega's, exactly."""
    for A in (0.3, 1.0, 2.5):
        assert tuning.parametric_rate(_linear_phys(0.2, 1.3, 0.05, 0.1), A) == pytest.approx(
            0.05 * 1.3**2 + 3 * 0.1 * 0.2**2, rel=1e-10)
        assert tuning.parametric_rate(_linear_phys(0.2, 1.3, 0.05, 0.1, s=3.0), A) == \
            pytest.approx(3 * tuning.parametric_rate(_linear_phys(0.2, 1.3, 0.05, 0.1), A))
    off = _linear_phys(0.2, 1.3, 0.0, 0.0)
    assert tuning.scene_rate(off, 1.0) == tuning.scene_omega(off, 1.0)


def test_a_strong_damping_noise_shortens_the_step():
    """k = 2, w = 1, D_c = 0.2 (mean-square stable: 2 D_c k^2 = 1.6 < k): nu = 2.4 > Omega = 1,
    so the automatic step is 1 / 2.4 of the step without the damping noise; a weak one
    (D_c = 0.01, nu = 0.12) leaves it as it was."""
    strong, none = _linear_phys(2.0, 1.0, 0.0, 0.2), _linear_phys(2.0, 1.0, 0.0, 0.0)
    assert tuning.auto_dt(0.005, strong, 1.0) == pytest.approx(
        tuning.auto_dt(0.005, none, 1.0) / 2.4, rel=1e-9)
    weak = _linear_phys(2.0, 1.0, 0.0, 0.01)
    assert tuning.auto_dt(0.005, weak, 1.0) == tuning.auto_dt(0.005, none, 1.0)
