"""First passage and starts of the original system's Monte Carlo (montecarlo/passage.py).

Truths: the conservative orbit's time averages by solve_ivp (starts uniform in time); the
crossing time of a noise-free path by solve_ivp's event location (crossing order); the
identity of paths between runs that differ only in their horizon, thread count or cut into
kernel calls (censoring, seeds). Statistical tolerances: |z| < 4 on fixed seeds.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import vifpk.montecarlo.passage as P
from scipy.integrate import solve_ivp
from vifpk.montecarlo import PassageSettings, first_passage, sample_starts

from tests.conftest import vary
from vifpk.core.result import BadInput

# xdist_group: tests that run the same compiled kernel shape go to one worker (CI's --dist
# loadgroup), so it is compiled once rather than by both workers at the same time.


def settings(**kw) -> PassageSettings:
    return PassageSettings(**{"paths": 64, "blocks": 4, "dt": 0.01, "horizon": 100.0,
                              "seed": 7, "progress": False, **kw})


# ------------------------------------------------------------------------------ starts
def orbit_averages(k: tuple[float, ...], A: float) -> dict[str, float]:
    """Time averages over the conservative orbit of amplitude A of x'' = -(k1 x + k3 x^3 +
    ...), by direct integration (solve_ivp, rtol 1e-12) over the quarter period from (A, 0)
    to x = 0: |x|, x^2, x^4, v^2 (even in the quarter-period symmetry of the orbit)."""
    def g(x):
        return sum(c * x ** (2 * i + 1) for i, c in enumerate(k))

    def rhs(t, s):
        x, v = s[0], s[1]
        return [v, -g(x), abs(x), x * x, x**4, v * v]

    def at_zero(t, s):
        return s[0]

    at_zero.terminal, at_zero.direction = True, -1
    sol = solve_ivp(rhs, (0, 100), [A, 0, 0, 0, 0, 0], rtol=1e-12, atol=1e-14,
                    events=at_zero)
    T4 = sol.t_events[0][0]
    acc = sol.y_events[0][0][2:] / T4
    return {"|x|": acc[0], "x2": acc[1], "x4": acc[2], "v2": acc[3]}


@pytest.mark.parametrize(("k", "A", "barrier"), [((1.0, 5.0), 1.5, True),
                                                 ((1.0, 5.0), 1.5, False),
                                                 ((1.0, -0.8, 1.0), 1.2, True)])
def test_starts_are_uniform_in_time(base, k, A, barrier):
    """Moments of 200000 starts against the orbit's time averages (solve_ivp): a strongly
    hardening Duffing spring (alpha A^2 = 11 omega0^2), and a quintic one softening then
    hardening (k3 < 0: the slowest phase is not at x = 0, the rejection bound comes from the
    grid of orbit_point). The uniform-ANGLE law of pilots.starts is 20+ standard errors
    off the Duffing truth for x^2: the test tells the two apart."""
    sc = vary(base, restoring=k, barrier=barrier)
    s = sample_starts(sc.system, sc.noise, amplitude=A, n=200_000, seed=3)
    x, v = s[:, 0], s[:, 1]
    truth = orbit_averages(k, A)

    def U(y):
        return sum(c * y ** (2 * i + 2) / (2 * i + 2) for i, c in enumerate(k))

    np.testing.assert_allclose(0.5 * v**2 + U(x), U(A), rtol=1e-12)
    if barrier:
        assert x.min() >= 0
    est = {"|x|": np.abs(x), "x2": x**2, "x4": x**4, "v2": v**2}
    for key, vals in est.items():
        z = (vals.mean() - truth[key]) / (vals.std() / math.sqrt(vals.size))
        assert abs(z) < 4, (key, vals.mean(), truth[key], z)
    # v changes sign with equal weight, and xi has its stationary law N(0, D / alpha1)
    assert abs(np.mean(np.sign(v))) < 4 / math.sqrt(v.size)
    xi = s[:, 2]
    sd = math.sqrt(sc.noise.D / sc.noise.alpha1)
    assert abs(xi.std() / sd - 1) < 4 * math.sqrt(0.5 / xi.size)
    if len(k) == 2:
        th = np.random.default_rng(1).uniform(0, 2 * math.pi, x.size)
        angle = (A * np.cos(th)) ** 2
        assert abs(angle.mean() - truth["x2"]) > 20 * angle.std() / math.sqrt(x.size)


# ---------------------------------------------------------------------- first passage
def test_bad_input_is_one_line(base):
    cases = [dict(threshold=1.0, start=1.0), dict(threshold=1.0, start=1.5),
             dict(threshold=-1.0, start=0.5), dict(threshold=1.0, start="equilibrium"),
             dict(threshold=math.nan, start=0.5)]
    for kw in cases:
        with pytest.raises(BadInput) as err:
            first_passage(base.system, base.noise, settings(), **kw)
        assert "\n" not in str(err.value)
    for bad in (dict(dt=0.0), dict(horizon=-1.0), dict(paths=3), dict(blocks=1)):
        with pytest.raises(BadInput):
            first_passage(base.system, base.noise, settings(**bad), threshold=1.2, start=1.0)
    with pytest.raises(BadInput, match="burn_in"):
        first_passage(base.system, base.noise, settings(), threshold=1.2, start="stationary")


@pytest.mark.xdist_group("passage-paper-base")
@pytest.mark.slow
def test_same_seed_same_numbers_any_threads_and_cut(base, monkeypatch):
    """Bit-identical first-passage times on 1 and 2 threads, and when the run is cut into
    many more kernel calls (a tiny CHUNK_SECONDS: a path's budget per call is then a few
    steps)."""
    kw = dict(threshold=1.05, start=1.0)
    one = first_passage(base.system, base.noise, settings(threads=1), **kw)
    two = first_passage(base.system, base.noise, settings(threads=2), **kw)
    monkeypatch.setattr(P, "CHUNK_SECONDS", 1e-6)
    cut = first_passage(base.system, base.noise, settings(threads=2), **kw)
    f1 = one.data["fpt"]
    assert 0 < f1["censored"].sum() < f1["censored"].size  # both kinds of path present
    for other in (two, cut):
        np.testing.assert_array_equal(f1["time"], other.data["fpt"]["time"])
        np.testing.assert_array_equal(f1["censored"], other.data["fpt"]["censored"])
        np.testing.assert_array_equal(one.data["start"]["x"], other.data["start"]["x"])
    other = first_passage(base.system, base.noise, settings(threads=1, seed=8), **kw)
    assert not np.array_equal(f1["time"], other.data["fpt"]["time"])


@pytest.mark.xdist_group("passage-paper-base")
def test_censoring_is_exact(base):
    """A short horizon cuts the same paths: every path that crossed before it has the very
    same time as with a long horizon, every other one is censored at exactly the horizon."""
    kw = dict(threshold=1.08, start=1.0)
    long = first_passage(base.system, base.noise, settings(horizon=400.0), **kw)
    short = first_passage(base.system, base.noise, settings(horizon=40.0), **kw)
    T, C = long.data["fpt"]["time"], long.data["fpt"]["censored"]
    t, c = short.data["fpt"]["time"], short.data["fpt"]["censored"]
    inside = ~C & (T <= 40.0)
    assert 5 < inside.sum() < T.size - 5
    np.testing.assert_array_equal(t[inside], T[inside])
    assert not c[inside].any()
    assert c[~inside].all() and np.all(t[~inside] == 40.0)
    assert short.info["censored"] == int((~inside).sum())
    assert np.all(T[C] == 400.0) and np.all(T[~C] <= 400.0) and np.all(T > 0)
    assert short.info["status"]["code"] == "censored"  # the outcome named (issue 38)
    assert long.info["status"]["code"] == ("censored" if C.any() else "simulated")


@pytest.mark.xdist_group("passage-paper-base")
def test_stationary_start_is_below_threshold(base):
    """'stationary': every clock starts below Ac, after the burn-in, and info says how."""
    res = first_passage(base.system, base.noise, settings(horizon=20.0, burn_in=50.0),
                        threshold=0.6, start="stationary")
    assert np.all(res.data["start"]["A"] < 0.6)
    st = res.info["stationary"]
    assert st["burn_in"] == 50.0 and st["burn_start"] == 0.3 and st["restarts"] >= 0
    assert "rejection" in res.info["start_law"]


@pytest.mark.xdist_group("passage-white")
@pytest.mark.slow
def test_crossing_time_second_order_against_solve_ivp(base):
    """Noise-free van der Pol-Duffing paths (no barrier, no friction: the smooth sub-system):
    the interpolated crossing time against solve_ivp's event location from the same start.
    The error falls by 4 per halving of dt (CROSSING_ORDER = 2); a crossing at the grid times
    would fall by 2 only. Noise-free to double precision: white noise of D = 1e-30, whose kicks
    (sqrt(2 D dt) <= 3e-16 a step, ~1e-14 summed over a path) are 10 orders below the errors
    (measured 2.4e-3, 5.9e-4, 1.5e-4 at dt = 0.04, 0.02, 0.01: orders 2.01, 2.00); so the
    kernel is the white-noise tests' (the same record type as
    test_white_noise_bridge_keeps_coarse_steps_unbiased), not one compiled for this test
    alone; its bridge test runs on every step but cannot fire unless a step ends within
    ~1e-15 of Ec (its variance is ~1e-30: passage_kernels.BRIDGE_FLOOR)."""
    sc = vary(base, mu=0.0, barrier=False, c1=0.2, c2=0.2, alpha=0.6, f=1.0, kind="white",
              D=1e-30)
    k1, k3, c1, c2 = 1.0, 0.6, 0.2, 0.2
    Ac = 1.5
    Ec = 0.5 * k1 * Ac**2 + 0.25 * k3 * Ac**4
    errs = []
    for dt in (0.04, 0.02, 0.01):
        res = first_passage(sc.system, sc.noise, settings(paths=8, blocks=2, dt=dt,
                                                          horizon=200.0),
                            threshold=Ac, start=0.5)
        s = res.data["start"]
        err = 0.0
        for i in range(8):
            def rhs(t, y):
                return [y[1], -(c2 * y[0] ** 2 - c1) * y[1] - k1 * y[0] - k3 * y[0] ** 3]

            def cross(t, y):
                return 0.5 * y[1] ** 2 + 0.5 * k1 * y[0] ** 2 + 0.25 * k3 * y[0] ** 4 - Ec

            cross.terminal, cross.direction = True, 1
            sol = solve_ivp(rhs, (0, 200), [s["x"][i], s["v"][i]], rtol=1e-12, atol=1e-12,
                            events=cross, method="DOP853")
            err = max(err, abs(res.data["fpt"]["time"][i] - sol.t_events[0][0]))
        errs.append(err)
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > P.CROSSING_ORDER - 0.3), (errs, orders)
    assert errs[-1] < 0.05 * 0.01  # a crossing at the grid times errs by up to dt


@pytest.mark.xdist_group("passage-paper-base")
def test_door_turns_failures_into_one_line(base, monkeypatch):
    """harness.door.timedomain.passage_montecarlo: scene -> settings -> solver, with the scene's dt
    and seed; the solver's failures (a blow-up, a stationary start it cannot place) become
    SolverFailure with the solver's one line; bad input stays BadInput."""
    import vifpk.montecarlo
    from vifpk.harness.door.solvers import SolverFailure
    from vifpk.harness.door.timedomain import passage_montecarlo, time_step

    res = passage_montecarlo(base, threshold=1.05, start=1.0, horizon=10.0, paths=4,
                             blocks=2, progress=False)
    assert res.info["dt"] == time_step(base)  # "auto": the time domain's fixed step
    assert res.info["seed"]["root"] == base.montecarlo.seed
    with pytest.raises(BadInput, match="threshold"):
        passage_montecarlo(base, threshold=1e90, start=1.0, horizon=10.0, paths=4, blocks=2)
    for exc in (vifpk.montecarlo.SimulationDiverged("blew up at dt = 0.01"),
                vifpk.montecarlo.StartRejected("cannot start")):
        def fail(*a, exc=exc, **k):
            raise exc

        monkeypatch.setattr(vifpk.montecarlo, "first_passage", fail)
        with pytest.raises(SolverFailure, match=str(exc)):
            passage_montecarlo(base, threshold=1.05, start=1.0, horizon=10.0, paths=4)


@pytest.mark.xdist_group("passage-white")
@pytest.mark.slow
def test_stationary_start_is_the_restricted_stationary_law(base):
    """'stationary' on a linear oscillator under white noise, x'' + c x' + x = f W: its
    stationary law is Gaussian with var x = var v = f^2 D / c = s^2, so A = sqrt(x^2 + v^2)
    is Rayleigh(s), and restricted to A < Ac its CDF is (1 - e^{-a^2/2s^2}) /
    (1 - e^{-Ac^2/2s^2}). 20000 starts after a burn-in of 8 relaxation times (1/c each) of the
    energy: Kolmogorov-Smirnov p > 1e-4; the restarts are about P(A >= Ac) per path. Then
    through the door, whose burn-in is "auto" (the relaxation pilot's): the same law."""
    from scipy import stats
    from vifpk.harness.door.timedomain import passage_montecarlo

    from vifpk.core.defaults import BURN_FACTOR

    c, f, D, Ac = 0.2, 1.0, 0.05, 0.8
    sc = vary(base, c1=-c, c2=0.0, alpha=0.0, mu=0.0, barrier=False, f=f, kind="white", D=D)
    s2 = f * f * D / c
    res = first_passage(sc.system, sc.noise, settings(paths=20000, blocks=40, horizon=0.5,
                                                      burn_in=8 / c), threshold=Ac,
                        start="stationary")
    auto = passage_montecarlo(sc, threshold=Ac, start="stationary", horizon=0.5, paths=5000,
                              blocks=40, seed=8, progress=False)
    info = auto.info["stationary"]
    assert info["burn_in_mode"] == "auto"
    assert info["burn_in"] == pytest.approx(max(BURN_FACTOR * info["relaxation"]["tau"], 20),
                                            abs=0.01)
    A = res.data["start"]["A"]
    assert A.max() < Ac

    def cdf(a):
        return (1 - np.exp(-a * a / (2 * s2))) / (1 - math.exp(-Ac * Ac / (2 * s2)))

    assert stats.kstest(A, cdf).pvalue > 1e-4
    assert stats.kstest(auto.data["start"]["A"], cdf).pvalue > 1e-4
    above = math.exp(-Ac * Ac / (2 * s2))  # P(A >= Ac) of one burn-in
    restarts = res.info["stationary"]["restarts"]
    expect = 20000 * above / (1 - above)  # geometric number of failures per path
    assert abs(restarts - expect) < 4 * math.sqrt(expect / (1 - above))


@pytest.mark.xdist_group("passage-white")
@pytest.mark.slow
def test_white_noise_bridge_keeps_coarse_steps_unbiased(base):
    """White noise: the energy may cross Ec and come back inside a step; the bridge
    correction counts those crossings. A linear oscillator (c = 0.2, f^2 D = 0.05) from
    A0 = 0.3 to Ac = 1 (MFPT ~ 18): the mean FPT at dt = 0.1 within 4 combined standard
    errors of the one at dt = 0.00625. Measured without the bridge (run_passage called with
    bridge=None): 21.0, 19.4, 18.5 (+- 0.2) at dt = 0.1, 0.025, 0.00625, the O(dt^1/2) bias
    of monitoring at the grid times, 10 standard errors at dt = 0.1."""
    sc = vary(base, c1=-0.2, c2=0.0, alpha=0.0, mu=0.0, barrier=False, f=1.0, kind="white",
              D=0.05)
    out = []
    for dt in (0.1, 0.00625):
        res = first_passage(sc.system, sc.noise, settings(paths=8000, blocks=16, dt=dt,
                                                          horizon=1e4, seed=3),
                            threshold=1.0, start=0.3)
        t = res.data["fpt"]["time"]
        assert res.info["censored"] == 0 and "bridge" in res.info["crossing"]["method"]
        out.append((t.mean(), t.std(ddof=1) / math.sqrt(t.size)))
    (m1, e1), (m2, e2) = out
    assert abs(m1 - m2) < 4 * math.hypot(e1, e2), out


@pytest.mark.xdist_group("passage-paper-base")
def test_switched_off_effects_reach_the_kernel_as_none(base):
    """The scene's switches reach run_passage as simulate's reach run_paths: an effect the
    scene does not have is None (numba prunes its branches, tests/test_montecarlo.py), here
    the higher spring, damping and velocity terms and the white-noise bridge (OU noise)."""
    first_passage(base.system, base.noise, settings(paths=4, blocks=2, horizon=1.0),
                  threshold=1.05, start=1.0)
    from vifpk.montecarlo import passage_kernels
    from vifpk.montecarlo.pieces import record_class

    names = ("mu", "lo", "up", "khi", "dhi", "ev", "bridge")
    # the last argument is the physics record (plan.record): its fields' numba types
    sigs = [{n: str(t) for n, t in zip(sig[-1].instance_class._fields, sig[-1].types,
                                       strict=True)}
            for sig in passage_kernels._passage_block.signatures]
    want = {"mu": "float64", "lo": "float64", "up": "none", "khi": "none", "dhi": "none",
            "ev": "none", "bridge": "none"}
    assert any({n: s[n] for n in names} == want for s in sigs), sigs
    # the record is the OU kind's with one Newton wall: their pieces are the ones compiled
    assert any(sig[-1].instance_class is record_class("ou", "newton", None)
               for sig in passage_kernels._passage_block.signatures)


@pytest.mark.xdist_group("passage-paper-base")
def test_paths_not_a_multiple_of_blocks_finish(base):
    """Found by the splitting helper: with 100 paths in 32 blocks some blocks have a padding
    lane the kernel never advances; counted as active, it kept the driver's loop going for
    ever. Every real path is returned, and the run ends."""
    res = first_passage(base.system, base.noise, settings(paths=40, blocks=32, horizon=5.0),
                        threshold=1.05, start=1.0)
    assert res.data["fpt"]["time"].shape == (40,)


@pytest.mark.parametrize("name", [
    pytest.param("paper-base", marks=pytest.mark.xdist_group("passage-paper-base")),
    pytest.param("hard/white", marks=pytest.mark.xdist_group("passage-white"))])
def test_a_path_is_the_same_in_any_lane_and_any_budget(name):
    """The first-passage kernel runs LANES = 32 paths of a block in lanes and refills a lane
    whose path ended with the block's next one (montecarlo/passage_kernels.py): a path's
    result must not depend on that. 70 paths in one block (lanes refilled, budgets of 37
    steps a call) against the same 70 generators as 70 blocks of one path (one lane each,
    one call): fpt, phase, steps, tries, the state where the clock started and where the
    path ended, and its generator words, bit for bit; burn-ins from a stationary start (with
    restarts), crossings and censored or refused paths all occur."""
    from vifpk.montecarlo.passage_kernels import run_passage
    from vifpk.montecarlo.pieces import record
    from vifpk.montecarlo.plan import physics
    from vifpk.montecarlo.rng import block_seeds

    from vifpk.core.scene import load_scene

    sc = load_scene(f"scenes/{name}.toml")
    phys = physics(sc.system, sc.noise)
    h, n = 0.02, 70
    rec = record(phys, h)
    B = (rec.bridge, rec.pk, rec.pc)
    Ec = 0.5 * 0.35 ** 2 + 0.15 * 0.35 ** 4  # U(0.35), w0 = 1, alpha = 0.6
    run = (0, 3000, 400, 60.0, Ec, 0.0, 0.2, 3)  # budget set below, n_max, n_burn, ...
    words = block_seeds(11, 1, n)

    def go(blocks, per, budget):
        ints = [np.zeros((blocks, per), np.int64) for _ in range(3)]  # phase, steps, tries
        a = [words.reshape(blocks, per, 4).copy(), np.zeros((blocks, per, 3)),
             np.zeros((blocks, per, 3)), *ints, np.zeros((blocks, per))]
        count = np.full(blocks, per, np.int64)
        while np.any(a[3] < P.CROSSED):
            run_passage(tuple(a), count, (budget, *run[1:]), h, B, rec)
        return [x.reshape((n, *x.shape[2:])) for x in a]

    lanes = go(1, n, 37)
    alone = go(n, 1, 10 ** 6)
    for got, want in zip(lanes, alone, strict=True):
        assert np.array_equal(got, want)
    assert np.sum(lanes[3] == P.CROSSED) > 5  # and paths that ended otherwise:
    assert np.sum(np.isin(lanes[3], (P.CENSORED, P.REFUSED))) > 0
    assert np.sum(lanes[5]) > 0  # some burn-ins ended above the threshold: restarts
