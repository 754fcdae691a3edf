"""The time domain's stated precision and its verdict rule (issue 39 item 5;
harness/workflows/precision.py): fast tests on canned numbers and synthetic units, and one
small slow run on the issue's scene (paper-base from A0 = 0.2 at times 20, 50, 100, 200)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from vifpk.harness.workflows import precision as pr

from vifpk.core.result import Result


# ------------------------------------------------------------------------ the verdict rule
@pytest.mark.parametrize("value, err, expected", [
    (0.275, 0.123, "moderate"),  # the issue's numbers at 1024 paths: 2.2 error bars
    (0.136, 0.134, pr.WITHIN),  # the same model at the default precision (measured below)
    (0.073, 0.127, pr.WITHIN),
    (-0.16, 0.025, "moderate"),  # README's passage example, exact model
    (0.09, 0.04, "small"),
    (0.09, 0.045, "small"),  # exactly 2 error bars: a model error
    (0.0899, 0.045, pr.WITHIN),
    (0.5, math.nan, pr.WITHIN),  # no error bar: no class
])
def test_a_model_error_is_classed_only_beyond_two_error_bars(value, err, expected):
    assert pr.model_error_class(value, err) == expected


def test_the_transient_line_says_within_the_error_bar():
    """The relaxation part of the verdict line carries no class within 2 error bars and
    names the class beyond them (transient_verdict on canned entries)."""
    from vifpk.harness.workflows.transient import _relaxation, transient_verdict

    snap = [{"t": 200.0, "class": "small", "fpk": {"L1": 0.08, "L1_err": 0.01,
                                                    "L1_floor": 0.04, "ks": 0.04}}]
    measured = {"value": 82.75, "err": 9.8}
    for fitted, needle in ((94.02, "(within the error bar: +13.6% +/- 13.5%)"),
                           (60.95, "(-26.3% +/- 8.7%: MODERATE relaxation-time error)")):
        e = {"snapshots": snap, "verdict_class": "small", "worst_time": 200.0,
             "relaxation": _relaxation(91.8, {"value": fitted}, measured)}
        assert needle in transient_verdict("exact", e, measured)


@pytest.mark.parametrize("e", [0.1, -0.1])
def test_the_default_target_tells_a_ten_percent_error_from_noise(e):
    """Finding 4 of REVIEW1: at the default relative SE R of the original system's MFPT, a
    model off by +/-10% (the small/moderate boundary) is a model error, not "within the error
    bar": its bar is (1 + e) R by the delta method (survival.relative_mfpt_error, an
    independent formula), 1.1 R at +10%, so R must be <= 0.1 / 2.2 (0.05 gave 1.8 bars)."""
    from vifpk.harness.request.timedomain import REL_SE_MFPT, REL_SE_RELAXATION
    from vifpk.harness.workflows.survival import relative_mfpt_error

    for rse in (REL_SE_MFPT, REL_SE_RELAXATION):
        err = relative_mfpt_error(1.0 + e, {"value": 1.0, "stderr": rse, "restricted": False})
        assert err["value"] == pytest.approx(e) and err["err"] == pytest.approx((1 + e) * rse)
        assert pr.model_error_class(err["value"], err["err"]) != pr.WITHIN


# ------------------------------------------------------------------------ growth and seeds
def test_unit_seeds_start_at_the_root_and_differ():
    seeds = [pr.unit_seed(20190101, k) for k in range(16)]
    assert seeds[0] == 20190101  # unit 0 is the fixed-paths run of the same seed
    assert len(set(seeds)) == 16
    assert seeds == [pr.unit_seed(20190101, k) for k in range(16)]  # reproducible


def test_the_seed_scheme_is_written_from_the_unit_key(monkeypatch):
    """REVIEW1 finding 8: metrics' seed_scheme names the spawn key unit_seed uses."""
    assert f"spawn_key=({pr.UNIT_KEY:#x}, k)" in pr.record(
        quantity="q", target=0.1, rse=0.1, paths=1, unit=1, max_paths=1, stopped="target met",
    )["seed_scheme"]
    w = np.random.SeedSequence(9, spawn_key=(pr.UNIT_KEY, 3)).generate_state(4, np.uint32)
    assert pr.unit_seed(9, 3) == int(w[0]) + (int(w[1]) << 32) + (int(w[2]) << 64) + (
        int(w[3]) << 96)


def test_unit_seeds_carry_the_whole_entropy_pool():
    """REVIEW1 finding 9: a unit's seed is 128 bits (not one 32-bit word, where 16 units of
    many sweep points would meet birthday collisions); each is a valid SeedSequence
    entropy."""
    seeds = [pr.unit_seed(20190101, k) for k in range(1, 16)]
    assert max(seeds) >= 2 ** 96 and all(0 <= s < 2 ** 128 for s in seeds)
    np.random.default_rng(seeds[0]).random()


@pytest.mark.parametrize("n, rse, cap, expected", [
    (1024, 0.096, 16384, 4096),  # predicts 4150: capped at 4 x n
    (1024, 0.055, 16384, 2048),  # predicts 1362: rounded up to whole units
    (1024, 0.0501, 16384, 2048),  # at least one more unit
    (4096, 0.2, 6000, 6000),  # never past the cap
])
def test_next_total_in_whole_units_within_the_limits(n, rse, cap, expected):
    assert pr.next_total(n, rse, 0.05, 1024, cap) == expected


def _noise_run(c, chi2=None):
    """Units that only carry their seed; the quantity's relative SE is c / sqrt(paths)
    (and its chi2/dof grows as paths when ``chi2`` is given: a fixed misfit)."""
    def run_unit(k, seed):
        return seed

    def measure(units):
        n = 100 * len(units)
        out = {"value": 1.0, "err": c / math.sqrt(n)}
        if chi2 is not None:
            out["chi2_per_dof"], out["dof"] = chi2 * n / 100, 2
            out["err"] *= math.sqrt(max(out["chi2_per_dof"], 1.0))
        return out
    return run_unit, measure


def test_grow_stops_at_the_target_and_says_so():
    run_unit, measure = _noise_run(1.0)  # rse 1/sqrt(N): 0.05 needs N = 400
    units, p = pr.grow(run_unit, measure, seed=7, unit=100, target=0.05, max_paths=1600,
                       budget=0, quantity="MFPT")
    assert p["stopped"] == "target met" and p["paths"] == 400 and p["achieved_rel_se"] <= 0.05
    assert units == [pr.unit_seed(7, k) for k in range(4)]


def test_a_stopped_run_holds_the_first_units_of_a_longer_one():
    """The result for a seed does not depend on when it stopped: the cap cuts a prefix."""
    run_unit, measure = _noise_run(1.0)
    short, p = pr.grow(run_unit, measure, seed=7, unit=100, target=0.01, max_paths=300,
                       budget=0, quantity="MFPT")
    long, q = pr.grow(run_unit, measure, seed=7, unit=100, target=0.01, max_paths=1600,
                      budget=0, quantity="MFPT")
    assert p["stopped"] == q["stopped"] == "paths cap" and p["paths"] == 300
    assert long[:len(short)] == short
    assert "budget reached" in p["status"]


@pytest.mark.parametrize("dof", [1, 2])
def test_a_misfit_within_noise_does_not_stop_the_run(dof):
    """Finding 1 of REVIEW1: a correct model's chi2/dof exceeds 1 with probability ~0.3-0.4
    at 1-2 dof, so chi2/dof = 1.2 (the 99% quantile / dof is 6.6 at dof 1, 4.6 at dof 2) is
    noise: with the noise part 0.048 (widened 0.048 x sqrt(1.2) = 0.053 > 0.05) the run
    keeps growing to the target instead of stopping with 'misfit'."""
    def measure(units):
        n = 100 * len(units)
        return {"value": 1.0, "err": 0.048 * math.sqrt(100 / n) * math.sqrt(1.2),
                "chi2_per_dof": 1.2, "dof": dof}
    units, p = pr.grow(lambda k, s: s, measure, seed=1, unit=100, target=0.05, max_paths=1600,
                       budget=0, quantity="relaxation time", misfit=True)
    assert p["stopped"] == "target met" and p["paths"] == 200, p


def test_grow_stops_when_the_misfit_dominates():
    """A fixed misfit: chi2/dof grows as N, the widened bar does not shrink; once the noise
    part alone is at the target the run stops with 'misfit' instead of spending the cap."""
    run_unit, measure = _noise_run(1.0, chi2=2.0)  # widened rse stays sqrt(2)/10 = 0.14
    units, p = pr.grow(run_unit, measure, seed=1, unit=100, target=0.05, max_paths=1600,
                       budget=0, quantity="relaxation time", misfit=True)
    assert p["stopped"] == "misfit" and p["paths"] < 1600
    assert p["achieved_rel_se"] > 0.05


def test_the_budget_stop_prices_path_steps_not_wall_seconds(monkeypatch):
    """Finding 3 of REVIEW1: the budget prices the units' path-steps (info["steps"]) at
    BUDGET_STEPS_PER_SECOND, so the stop is the same for a seed whatever the wall clock says
    (here a clock that jumps 1e6 s per call, and one that stands still, give one answer).
    Units of 100 paths, 1.5e9 path-steps each = 10 s at 1.5e8/s; budget 45 s: the first
    batch to 400 paths (4 x N, 40 s) fits, the next to 1600 (160 s) would not."""
    import itertools
    import time

    def run_unit(k, seed):
        return Result(data={}, info={"steps": 1.5e9, "seed": seed})

    def measure(units):
        return {"value": 1.0, "err": 1.0 / math.sqrt(100 * len(units))}

    got = []
    for clock in (itertools.count(0.0, 1e6), itertools.repeat(0.0)):
        monkeypatch.setattr(time, "perf_counter", lambda c=clock: float(next(c)))
        units, p = pr.grow(run_unit, measure, seed=3, unit=100, target=0.01, max_paths=10**6,
                           budget=45.0, quantity="MFPT")
        got.append((p["stopped"], p["paths"], p["path_steps"]))
    assert pr.BUDGET_STEPS_PER_SECOND == 1.5e8
    assert got == [("budget", 400, 6e9)] * 2


# ----------------------------------------------------------------------------- pooling
def test_pooled_snapshots_average_and_shrink_as_independent():
    """K units of one histogram pool to the same p and err / sqrt(K) (independent errors
    combined), floors / sqrt(K); paths summed."""
    p, e = np.array([[0.2, 0.8]]), np.array([[0.02, 0.04]])
    r = Result(data={"snapshots": {"t": np.array([1.0]), "A": {
        "edges": np.array([0.0, 1.0, 2.0]), "x": np.array([0.5, 1.5]), "p": p, "err": e}}},
        info={"paths": 64, "steps": 10.0, "L1_floor": {"A": [0.1]}, "seed": {"root": 1}})
    pooled = pr.pool_snapshots([r] * 4)
    a = pooled.data["snapshots"]["A"]
    np.testing.assert_allclose(a["p"], p)
    np.testing.assert_allclose(a["err"], e / 2)
    assert pooled.info["paths"] == 256 and pooled.info["L1_floor"]["A"] == [0.05]


def test_pooled_snapshots_pool_the_moments_from_every_unit():
    """Finding 5 of REVIEW1: the second moments (value, err, blocks) come from all units'
    blocks, as one run of those blocks: checked against numpy on the stacked blocks."""
    rng = np.random.default_rng(5)
    units, allb = [], []
    for _ in range(3):
        b = rng.normal(2.0, 0.3, (8, 2))  # 8 blocks, 2 times
        allb.append(b)
        units.append(Result(data={"snapshots": {"t": np.array([1.0, 2.0]), "moments": {
            "x1x1": {"value": b.mean(0), "err": b.std(0, ddof=1) / math.sqrt(8), "blocks": b}}}},
            info={"paths": 64, "steps": 1.0, "seed": {"root": 1}}))
    m = pr.pool_snapshots(units).data["snapshots"]["moments"]["x1x1"]
    stacked = np.vstack(allb)
    assert m["blocks"].shape == (24, 2)
    np.testing.assert_allclose(m["value"], stacked.mean(0), rtol=1e-14)
    np.testing.assert_allclose(m["err"], stacked.std(0, ddof=1) / math.sqrt(24), rtol=1e-14)


def test_pooled_passage_times_are_concatenated():
    def unit(t):
        return Result(data={"fpt": {"time": np.array(t), "censored": np.array([False] * 2)}},
                      info={"paths": 2, "censored": 0})
    pooled = pr.pool_fpt([unit([1.0, 2.0]), unit([3.0, 4.0])])
    assert pooled.data["fpt"]["time"].tolist() == [1.0, 2.0, 3.0, 4.0]
    assert pooled.info["paths"] == 4


# ------------------------------------------------------------------------- the requests
@pytest.mark.parametrize("kw, needle", [
    ({"paths": 64, "rel_se": 0.1}, "--rel-se: does not apply with --paths"),
    ({"paths": 64, "max_paths": 1024}, "--max-paths: does not apply with --paths"),
    ({"rel_se": 0.0}, "--rel-se 0: out of range; allowed: a number 0 < R < 1"),
    ({"rel_se": 1.5}, "--rel-se 1.5: out of range"),
    ({"rel_se": "0.1"}, "--rel-se '0.1': not a number"),
    ({"max_paths": 10}, "--max-paths 10: out of range; allowed: a whole number >= "
                        "montecarlo.paths = 64"),
])
def test_precision_options_are_checked_before_any_work(kw, needle):
    from vifpk.harness.request.errors import InputError
    from vifpk.harness.request.timedomain import precision

    from tests.conftest import TINY
    from vifpk.core.scene import load_scene

    with pytest.raises(InputError, match=None) as exc:
        precision(load_scene(TINY), paths=kw.get("paths"), rel_se=kw.get("rel_se"),
                  max_paths=kw.get("max_paths"), default=0.05)
    assert needle in str(exc.value)


def test_precision_defaults():
    from vifpk.harness.request.timedomain import precision

    from tests.conftest import TINY
    from vifpk.core.scene import load_scene

    sc = load_scene(TINY)
    assert precision(sc, paths=None, rel_se=None, max_paths=None, default=0.05) == (0.05,
                                                                                     16 * 64)
    assert precision(sc, paths=128, rel_se=None, max_paths=None, default=0.05) == (None, None)


# --------------------------------------------------------------------- the issue's scene
@pytest.mark.slow
def test_issue_case_grown_paths_agree_with_an_independent_simulation():
    """Issue 39: `vifpk transient paper-base --start 0.2 --times 20,50,100,200` at exactly
    1024 paths measured tau = 73.7 +/- 7.1 and called the exact model +27.5% +/- 12.3% off;
    an independent simulation gives 91.2 +/- 8.2. Unit 0 of the grown run is that fixed run
    (its class pinned: the issue's report reproduced). Grown to 4096 paths (the cap given
    here to keep the test small; the default cap runs on to 16384, docs/passage.md), the
    measured tau lies within 2 combined error bars of the independent one. No model class is
    asserted (REVIEW1 finding 7): with no independent truth for the model's error, a class
    would pin one seed's verdict."""
    from vifpk.harness.request import prepare
    from vifpk.harness.request.timedomain import transient_request
    from vifpk.harness.workflows.transient import _relaxation, run

    scene = prepare.concrete("paper-base", [])
    kw = {"start": 0.2, "times": (20, 50, 100, 200), "models": ("exact",), "sde": False,
          "max_paths": 4096}
    grown = run(transient_request(scene, **kw))
    prec = grown.metrics["precision"]
    first = prec["history"][0]  # unit 0: exactly the fixed 1024-path run of this seed
    rel = grown.metrics["models"]["exact"]["relaxation"]
    old = _relaxation(rel["predicted"], {"value": rel["fitted"]}, first)
    assert first["paths"] == 1024
    assert old["class"] == "moderate" and old["error"]["value"] > 0.2, old  # the issue's
    assert prec["paths"] == 4096, prec
    tau = grown.metrics["relaxation"]["original_system"]
    assert abs(tau["value"] - 91.2) < 2 * math.hypot(tau["err"], 8.2)
    assert abs(first["value"] - 91.2) < 2 * math.hypot(first["err"], 8.2)  # both: noise


# ------------------------------------------------------------ the workflows, on doubles
@pytest.fixture
def doubles(monkeypatch):
    from tests import time_doubles as td

    td.install(monkeypatch)
    return td


def test_api_passage_grows_its_paths_to_the_target(doubles):
    """vifpk.passage without paths: units of the scene's 64 paths until the MFPT's relative
    SE (exponential FPTs: about 1/sqrt(N)) is at most 5%; the original system's record, the
    plan and the averaged SDE all use the pooled paths."""
    import vifpk
    from tests.conftest import TINY

    res = vifpk.passage(str(TINY), threshold=2.0, start=0.5, models=("exact",))
    p = res.metrics["precision"]
    assert p["stopped"] == "target met" and p["achieved_rel_se"] <= 0.05 < \
        p["history"][0]["err"] / p["history"][0]["value"]
    n = p["paths"]
    assert n % 64 == 0 and n > 64 and p["history"][0]["paths"] == 64
    assert res.metrics["mfpt"]["original_system"]["paths"] == n == res.metrics["plan"]["paths"]
    assert res.metrics["models"]["exact"]["sde"]["mfpt"]["paths"] == n
    fixed = vifpk.passage(str(TINY), threshold=2.0, start=0.5, models=("exact",), paths=64)
    assert fixed.metrics["precision"]["stopped"] == "paths given"
    assert fixed.metrics["mfpt"]["original_system"]["paths"] == 64


def test_the_plan_of_a_grown_run_counts_all_its_paths(doubles):
    """REVIEW1 finding 9: metrics' plan gives paths and expected_path_steps for the same
    paths (the grown total), first_paths the unit's."""
    import vifpk
    from tests.conftest import TINY

    kw = {"threshold": 2.0, "start": 0.5, "models": ("exact",), "sde": False}
    grown = vifpk.passage(str(TINY), **kw).metrics["plan"]
    one = vifpk.passage(str(TINY), paths=64, **kw).metrics["plan"]
    assert grown["first_paths"] == 64 < grown["paths"]
    assert grown["expected_path_steps"] == pytest.approx(
        one["expected_path_steps"] * grown["paths"] / 64, rel=1e-12)


def test_an_unmeasured_mfpt_does_not_grow(doubles, monkeypatch):
    """Every path censored (P49): more paths of the same question do not make an estimate."""
    import vifpk
    from tests.conftest import TINY

    monkeypatch.setattr(doubles, "T_ORIGINAL", 1e12)
    res = vifpk.passage(str(TINY), threshold=2.0, start=0.5, models=("exact",), horizon=5.0,
                        sde=False)
    assert res.metrics["precision"]["stopped"] == "not measured"
    assert res.metrics["precision"]["paths"] == 64


def test_the_guard_prices_the_growth_at_its_paths_cap(doubles):
    """Finding 2 of REVIEW1: with a precision target the workflow's price (the cost guard's
    and a sweep point's) sees the worst case, the paths cap, not the first unit: the grown
    paths run in the original system and in every averaged SDE."""
    from vifpk.harness.request.timedomain import passage_request
    from vifpk.harness.workflows.passage import run

    import vifpk
    from tests.conftest import TINY
    from vifpk.core.scene import load_scene

    seen = []
    req = passage_request(load_scene(TINY), threshold=2.0, start=0.5, models=("exact",),
                          max_paths=256)
    run(req, price=seen.append)
    fixed = vifpk.passage(str(TINY), threshold=2.0, start=0.5, models=("exact",), paths=64,
                          sde=False)  # one unit of 64 paths: its plan's path-steps
    assert seen[0]["paths"] == 256
    assert seen[0]["expected_path_steps"] == pytest.approx(
        4 * fixed.metrics["plan"]["expected_path_steps"])


def test_a_paths_cap_beyond_memory_is_refused(monkeypatch):
    """Finding 2 of REVIEW1: the memory check holds at --max-paths (the most any run of the
    growth holds), not only at the first unit; named by its option."""
    import os

    from vifpk.harness.request import cost
    from vifpk.harness.request.errors import InputError
    from vifpk.harness.request.timedomain import transient_request

    from tests.conftest import TINY
    from vifpk.core.scene import load_scene

    total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    monkeypatch.setattr(cost, "memory_bytes", lambda sc: total * sc.montecarlo.paths / 128)
    kw = {"start": 0.5, "times": (1, 2, 4)}
    sc = load_scene(TINY)  # 64 paths a unit: 128 fits exactly, 192 does not
    assert transient_request(sc, max_paths=128, **kw).max_paths == 128
    with pytest.raises(InputError, match="^--max-paths 192: the simulation needs"):
        transient_request(sc, max_paths=192, **kw)


def test_unit_zero_is_the_fixed_run_of_the_seed(doubles):
    """Finding 6 of REVIEW1: the grown run's first history entry is exactly the fixed
    --paths U run of the same seed (value and error bar, bit for bit), for the MFPT and for
    the relaxation time; the doubles draw from the seed they are given, as the doors do."""
    import vifpk
    from tests.conftest import TINY

    kw = {"threshold": 2.0, "start": 0.5, "models": ("exact",), "sde": False}
    grown = vifpk.passage(str(TINY), **kw).metrics
    fixed = vifpk.passage(str(TINY), paths=64, **kw).metrics["mfpt"]["original_system"]
    first = grown["precision"]["history"][0]
    assert grown["precision"]["paths"] > 64 and first["paths"] == 64
    assert (first["value"], first["err"]) == (fixed["value"], fixed["stderr"])
    kw = {"start": 0.5, "times": (2, 6, 12, 24), "models": ("exact",), "sde": False}
    grown = vifpk.transient(str(TINY), rel_se=0.01, max_paths=128, **kw).metrics
    fixed_run = vifpk.transient(str(TINY), paths=64, **kw).metrics
    fixed = fixed_run["relaxation"]["original_system"]
    first = grown["precision"]["history"][0]
    assert grown["precision"]["paths"] == 128 and first["paths"] == 64
    if fixed is None:  # its interval reaches 0 (issue 45): not reported, its fit in the warning
        said = f"its fit gives {first['value']:.4g} +/- {first['err']:.2g}"
        assert any(said in w for w in fixed_run["warnings"]), fixed_run["warnings"]
    else:
        assert (first["value"], first["err"]) == (fixed["value"], fixed["err"])
