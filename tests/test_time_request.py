"""The time domain's typed requests (harness/request/timedomain.py; issue 38 item 1) and the
issue 39 reproducers of the time domain and its Python/testing APIs (fast tier: refusals under
the no_computation fixture, the workflows on tests/time_doubles.py's known answers).

Each reproducer's id (issue 39's catalogue) is in its test's name or docstring; docs/edges.md
round 7 names them."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from tests import time_doubles as td
from tests.conftest import TINY

HUGE = "--threshold 1e+200: beyond the domain: its energy U(A) overflows a double"


@pytest.fixture
def doubles(monkeypatch):
    td.install(monkeypatch)


@pytest.fixture
def no_report(monkeypatch):
    """The report writer replaced by one that keeps the result (figures cost seconds; the
    reports have their own tests in test_passage.py)."""
    import vifpk.harness.outputs.timereport as timereport

    kept = []

    def write(res, out, prov=None, **_):  # runtime_warnings and what else the writer takes
        kept.append((res, out))
        return {"report.html": f"{out}/report.html"}

    monkeypatch.setattr(timereport, "write_time_report", write)
    return kept


@pytest.fixture
def tiny():
    from vifpk.core.scene import load_scene

    return load_scene(TINY).with_values({"montecarlo.paths": 1024, "montecarlo.blocks": 32})


def _cli(args, capsys):
    from vifpk.harness.cli.app import main

    code = main(args)
    return code, capsys.readouterr()


def _refused(args, capsys, needle):
    code, cap = _cli(args, capsys)
    lines = cap.err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and needle in lines[0], (code, cap.err)
    return lines[0]


# ------------------------------------------------------------------ one request, one line
def test_threshold_1e200_gets_the_same_line_from_every_door(no_computation, tmp_path, capsys,
                                                            monkeypatch):
    """Issue 38 item 1: `vifpk passage --threshold 1e200`, vifpk.passage(threshold=1e200)
    and a passage sweep with passage.threshold = 1e200 are refused before any work with the
    same line (the sweep's prefixed by the point it names)."""
    import vifpk
    from vifpk.core.result import BadInput

    monkeypatch.chdir(tmp_path)
    cli = _refused(["passage", "paper-base", "--threshold", "1e200"], capsys, HUGE)
    with pytest.raises(BadInput) as api:
        vifpk.passage("paper-base", threshold=1e200)
    p = tmp_path / "s.toml"
    p.write_text('scene = "paper-base"\nworkflow = "passage"\n[vary]\n'
                 '"passage.threshold" = [0.5, 1e200]\n')
    # the sweep names the key as its file writes it (issue 45): "[passage] threshold"
    named = HUGE.replace("--threshold", "[passage] threshold")
    sweep = _refused(["sweep", str(p), "--out", str(tmp_path / "o")], capsys, named)
    line = cli.removeprefix("vifpk: error: ")
    assert str(api.value) == line
    assert sweep.endswith(line.replace("--threshold", "[passage] threshold"))
    assert not (tmp_path / "o").exists() and not (tmp_path / "out").exists()


def test_threshold_nan_gets_the_same_line_from_the_cli_and_the_api(no_computation, capsys):
    import vifpk
    from vifpk.core.result import BadInput

    cli = _refused(["passage", "paper-base", "--threshold", "nan"], capsys, "--threshold nan")
    with pytest.raises(BadInput) as api:
        vifpk.passage("paper-base", threshold=float("nan"))
    assert str(api.value) == cli.removeprefix("vifpk: error: ")


def test_requests_are_frozen_and_carry_the_resolved_step():
    """One rule for the time domain's step (door.timedomain.time_step): a scene whose
    montecarlo.dt is "auto" (the default since issue 44) gets the fixed step FIXED_DT in the
    request, not a number of the request's own."""
    from vifpk.harness.door.timedomain import time_step
    from vifpk.harness.request.timedomain import passage_request, transient_request

    from vifpk.core.scene import load_scene
    from vifpk.core.sections import FIXED_DT

    sc = load_scene("paper-base").with_values({"montecarlo.dt": "auto"})
    req = passage_request(sc, threshold=0.6, start=0.3, models=["exact"])
    default = FIXED_DT
    assert req.dt == time_step(sc) == default and req.scene.montecarlo.dt == default
    assert req.models == ("exact",) and req.start == 0.3 and req.threshold == 0.6
    with pytest.raises(dataclasses.FrozenInstanceError):
        req.threshold = 1.0
    tr = transient_request(sc, start=1.0, times=[10, 20, 40])
    assert tr.times == (10.0, 20.0, 40.0) and tr.dt == default


def test_the_averaged_sde_falls_back_on_the_same_step_rule(monkeypatch):
    """door/timedomain.py's averaged-SDE step falls back on time_step (the scene's step),
    not on a second hard-coded 0.01 (issue 38 item 1)."""
    import vifpk.montecarlo.sde_time as sde_time
    from vifpk.harness.door import timedomain

    from vifpk.core.scene import load_scene

    seen = []

    def auto_dt(drift, diffusion, top, fallback):
        seen.append(fallback)
        return fallback, math.inf

    monkeypatch.setattr(sde_time, "auto_dt", auto_dt)
    for dt in (0.02, "auto"):
        sc = load_scene("paper-base").with_values({"montecarlo.dt": dt})
        _, h, *_ = timedomain._sde_run(sc, "exact", 2.0, None, None, None)
        assert h == seen[-1] == timedomain.time_step(sc)
    assert seen == [0.02, timedomain.time_step(load_scene("paper-base").with_values(
        {"montecarlo.dt": "auto"}))]


def test_the_mfpts_that_price_a_run_are_computed_once(doubles, no_report, tmp_path, capsys,
                                                      monkeypatch):
    """cli/timedomain.py priced with every model's quadrature and the workflow computed it
    again: now the request carries them (with_quadratures) and the door reuses them."""
    from vifpk.harness.door import timedomain

    calls, given = [], []
    mfpt, averaged = timedomain.mfpt_averaged, timedomain.passage_averaged

    def count(scene, model, **kw):
        calls.append(model)
        return mfpt(scene, model, **kw)

    def record(scene, model, **kw):
        given.append(kw.get("quadrature"))
        return averaged(scene, model, **kw)

    monkeypatch.setattr(timedomain, "mfpt_averaged", count)
    monkeypatch.setattr(timedomain, "passage_averaged", record)
    code, cap = _cli(["passage", str(TINY), "--threshold", "2", "--start", "0.5", "--model",
                      "exact", "--model", "corrected", "--quiet", "--paths", "256", "--out",
                      str(tmp_path / "p")], capsys)
    assert code == 0, cap.err
    assert calls == ["exact", "corrected"]
    assert [q["value"] for q in given] == [td.T_MODEL["exact"], td.T_MODEL["corrected"]]


def test_the_door_uses_a_given_quadrature_and_does_not_compute_it(monkeypatch):
    """door.timedomain.passage_averaged(quadrature=q) takes q as the MFPT (fpk.mfpt not
    called): the value it reports is q's."""
    import vifpk.fpk as fpk
    from vifpk.harness.door.timedomain import passage_averaged

    from vifpk.core.result import Result
    from vifpk.core.scene import load_scene

    def no_mfpt(*a, **k):
        raise AssertionError("the quadrature was computed again")

    def reliability(drift, diffusion, **kw):
        t = np.linspace(0, 10, 11)
        return Result(data={"R": {"t": t, "R": np.exp(-t)}},
                      info={"mfpt_integral": 1.0, "diagnostics": {}})

    monkeypatch.setattr(fpk, "mfpt", no_mfpt)
    monkeypatch.setattr(fpk, "reliability", reliability)
    q = {"value": 1.25, "error_estimate": 1e-6, "curve": {"A": [0.0], "T": [1.25]},
         **{k: 0 for k in ("value_coarse", "order", "intervals", "nodes", "evaluations",
                           "seconds", "method")}}
    r = passage_averaged(load_scene("paper-base"), "exact", threshold=0.6, start=0.3,
                         quadrature=q)
    assert r.info["mfpt"] == 1.25 and r.info["mfpt_error"] == 1e-6


# ------------------------------------------------------------- issue 39: the command line
@pytest.mark.parametrize(("case", "args", "needle"), [
    ("T24", ["transient", "paper-base", "--start", "1.0", "--times", "10,20"],
     "--times 10,20: 2 times; allowed: at least 3 times > 0"),
    ("T25", ["transient", "paper-base", "--start", "1.0", "--times", "5"],
     "--times 5: 1 time; allowed: at least 3 times > 0"),
    ("T01", ["transient", "paper-base", "--start", "1.0", "--times", "-5,10,20"],
     "--times: -5 is not > 0; allowed: at least 3 times > 0"),
    ("P41", ["passage", "paper-base", "--threshold", "0.6", "--horizon", "1e-300"],
     "--horizon 1e-300: shorter than one time step; allowed: a finite time >= dt = 0.01"),
    ("S02", ["passage", "paper-base", "--threshold", "0.6", "--method", "splitting",
             "--horizon", "50"], "--horizon: does not apply to --method splitting"),
    ("S03", ["passage", "paper-base", "--threshold", "0.6", "--method", "splitting",
             "--paths", "64"], "--paths: does not apply to --method splitting"),
    ("negative-threshold", ["passage", "paper-base", "--threshold", "-1e3"],
     "--threshold -1000: out of range; allowed: a finite amplitude > 0"),
    ("at-negative", ["passage", "paper-base", "--threshold", "0.6", "--at", "-3"],
     "--at -3: out of range; allowed: a finite time > 0"),
    ("at-splitting", ["passage", "paper-base", "--threshold", "0.6", "--method", "splitting",
                      "--at", "3"], "--at: does not apply to --method splitting"),
    ("rel-se-paths", ["passage", "paper-base", "--threshold", "0.6", "--paths", "64",
                      "--rel-se", "0.1"], "--rel-se: does not apply with --paths"),
    ("rel-se-range", ["transient", "paper-base", "--start", "1.0", "--times", "5,10,20",
                      "--rel-se", "-0.1"], "--rel-se -0.1: out of range; allowed: a number "
                                           "0 < R < 1"),
    ("max-paths-range", ["transient", "paper-base", "--start", "1.0", "--times", "5,10,20",
                         "--max-paths", "100"], "--max-paths 100: out of range; allowed: a "
                                                "whole number >= montecarlo.paths = 1024"),
    ("max-paths-units", ["transient", "paper-base", "--start", "1.0", "--times", "5,10,20",
                         "--max-paths", "1500"], "--max-paths 1500: not a whole number of "
                                                 "units; allowed: a multiple of "
                                                 "montecarlo.paths = 1024"),
    ("rel-se-splitting", ["passage", "paper-base", "--threshold", "0.6", "--method",
                          "splitting", "--rel-se", "0.1"],
     "--rel-se: does not apply to --method splitting"),
])
def test_issue39_cli_refusals(no_computation, capsys, case, args, needle):
    """T24, T25 (fewer than 3 times: the relaxation fit has two parameters), T01 (a negative
    list parsed as a value, refused with the range), P41 (the real allowed range of
    --horizon), S02, S03 (options that do not apply to splitting): one line, exit 2."""
    _refused(args, capsys, needle)


def test_x15_default_folders_name_the_question(doubles, no_report, tmp_path, capsys,
                                              monkeypatch):
    """X15: the default folder holds the start and the chosen models, so a passage at the
    same threshold from another start (or of other models) never replaces another's report."""
    monkeypatch.chdir(tmp_path)
    base = ["passage", str(TINY), "--threshold", "2", "--quiet", "--paths", "64"]
    for extra in (["--start", "0.5"], ["--start", "0.7"], ["--start", "0.5", "--model",
                                                              "exact"]):
        code, cap = _cli(base + extra, capsys)
        assert code == 0, cap.err
    code, cap = _cli(["transient", str(TINY), "--start", "2.5", "--times", "2,5,10",
                      "--quiet", "--paths", "64", "--model", "exact"], capsys)
    assert code == 0, cap.err
    assert [out for _, out in no_report] == [
        "out/tiny-passage-2-from-0.5", "out/tiny-passage-2-from-0.7",
        "out/tiny-passage-2-from-0.5-exact", "out/tiny-transient-2.5-at-2,5,10-exact"]


# ------------------------------------------------------------- issue 39: the Python APIs
def _api_cases():
    import vifpk

    return [
        ("A07", lambda: vifpk.passage("paper-base", threshold=0.6, models=[]),
         "no model given"),
        ("A08", lambda: vifpk.passage("paper-base", threshold=0.6, sde="no"),
         "sde 'no': not true or false"),
        ("A11", lambda: vifpk.passage("paper-base", threshold=0.6, out=123),
         "out 123: not a folder path"),
        ("A11-transient", lambda: vifpk.transient("paper-base", start=1.0, times=[5, 10, 20],
                                                   out=123), "out 123: not a folder path"),
        ("A31", lambda: vifpk.assert_mfpt_close("paper-base", "exact", 0.6, rtol=-0.1),
         "rtol -0.1: out of range; allowed: a finite number >= 0"),
        ("A32", lambda: vifpk.assert_mfpt_close("paper-base", "exact", 0.6, rtol=math.nan),
         "rtol nan: out of range"),
        ("A32-text", lambda: vifpk.assert_mfpt_close("paper-base", "exact", 0.6, rtol="0.1"),
         "rtol '0.1': not a number"),
        ("A34", lambda: vifpk.assert_relaxation_close("paper-base", "exact", start=1.0,
                                                       times=(5, 10), rtol=0.1),
         "--times 5,10: 2 times"),
        ("A34-rtol", lambda: vifpk.assert_relaxation_close("paper-base", "exact", start=1.0,
                                                            times=(5, 10, 20), rtol=-1),
         "rtol -1: out of range"),
        ("threshold-text", lambda: vifpk.passage("paper-base", threshold="0.6"),
         "--threshold '0.6': not a number"),
    ]


@pytest.mark.parametrize("k", range(10))
def test_issue39_api_refusals(no_computation, k):
    """A07, A08, A11 (refused before the run), A31, A32, A34 (a usage error, BadInput, not
    AssertionError, before any Monte Carlo)."""
    from vifpk.core.result import BadInput

    case, call, needle = _api_cases()[k]
    with pytest.raises(BadInput) as e:
        call()
    assert needle in str(e.value) and "\n" not in str(e.value), (case, str(e.value))
    assert not isinstance(e.value, AssertionError)


@pytest.mark.parametrize(("low", "entry", "needle"), [
    (0.5, 0.3, "low = 0.5, entry = 0.3 (given): allowed: 0 < low < entry < threshold = 0.9"),
    (0.3, 0.95, "low = 0.3, entry = 0.95 (given): allowed: 0 < low < entry < threshold"),
    (0.1, 0.2, "start 0.4: not below the entry level 0.2"),
])
def test_a25_a29_splitting_levels_misuse_is_bad_input(monkeypatch, low, entry, needle):
    """A25, A29: the door's passage_splitting with low >= entry, or entry above the threshold,
    is the caller's mistake (BadInput), not SolverFailure; refused before the splitting."""
    import vifpk.montecarlo.splitting as splitting
    from vifpk.harness.door.solvers import SolverFailure
    from vifpk.harness.door.timedomain import passage_splitting

    from vifpk.core.result import BadInput
    from vifpk.core.scene import load_scene

    def forbidden(*a, **k):
        raise AssertionError("splitting started")

    monkeypatch.setattr(splitting, "passage_splitting", forbidden)
    with pytest.raises(BadInput) as e:
        passage_splitting(load_scene("paper-base"), threshold=0.9, start=0.4, low=low,
                          entry=entry)
    assert needle in str(e.value) and not isinstance(e.value, SolverFailure)


def test_y06_assert_relaxation_close_takes_paths(doubles, tiny, monkeypatch):
    """Y06: assert_relaxation_close(..., paths=N) runs the Monte Carlo with N paths."""
    from vifpk.harness.door import timedomain
    from vifpk.harness.testing import assert_relaxation_close

    seen = []
    mc = timedomain.transient_montecarlo

    def record(scene, **kw):
        seen.append(kw["paths"])
        return mc(scene, **kw)

    monkeypatch.setattr(timedomain, "transient_montecarlo", record)
    assert_relaxation_close(tiny, "corrected", start=2.5, times=(2, 5, 10, 20, 40), rtol=0.1,
                            paths=512)
    assert seen == [512]


# ------------------------------------------------------ issue 39: answers that are not estimates
def test_p49_every_path_censored_is_not_an_estimate(doubles, tiny, monkeypatch):
    """P49: every path of the original system censored: NOT AN ESTIMATE for every model (not
    SMALL, LARGE, ...) and no recommendation."""
    from vifpk.harness.workflows.passage import passage

    monkeypatch.setattr(td, "T_ORIGINAL", 1e12)
    res = passage(tiny, threshold=2.0, start=0.5, models=("exact", "corrected"), horizon=5.0,
                  sde=False)
    assert res.metrics["mfpt"]["original_system"]["censored"] == 1024
    for m in ("exact", "corrected"):
        assert res.metrics["models"][m]["verdict_class"] == "not an estimate"
    assert all("NOT AN ESTIMATE" in v and "SMALL" not in v and "LARGE" not in v
               for v in res.verdicts), res.verdicts
    assert res.metrics["recommended_model"] == "none"
    assert "NOT AN ESTIMATE" in res.recommendation and "no path" in res.recommendation


def test_p48_every_passage_within_one_step_is_not_an_estimate(doubles, tiny, monkeypatch):
    """P48 (start just below the threshold): every path passes at the first step, the MFPT is
    below the step's resolution: NOT AN ESTIMATE, not "LARGE -- -100.0% +/- 0.0%"."""
    from vifpk.harness.door import timedomain
    from vifpk.harness.workflows.passage import passage

    from vifpk.core.result import Result

    def first_step(scene, *, paths, **kw):
        dt = timedomain.time_step(scene)  # the door's rule ("auto": its fixed step)
        return Result(data={"fpt": {"time": np.full(paths, dt),
                                    "censored": np.zeros(paths, bool)}}, info={"dt": dt})

    monkeypatch.setattr(timedomain, "passage_montecarlo", first_step)
    res = passage(tiny, threshold=2.0, start=1.99999999, models=("exact",), sde=False)
    assert res.metrics["models"]["exact"]["verdict_class"] == "not an estimate"
    assert "first time step" in res.verdicts[0] and "-100" not in res.verdicts[0]
    assert res.metrics["recommended_model"] == "none"


def test_t23_a_transient_with_no_measured_snapshot_prints_no_distances():
    """T23 (--start 1e6): every snapshot of the original system sits in fewer than 5 bins:
    the verdict says NOT AN ESTIMATE at every time and prints no L1 (it read "L1 0.000")."""
    from vifpk.harness.workflows.transient import transient_verdict

    rows = [{"t": t, "fpk": {"L1": 0.0, "L1_err": 0.0, "L1_floor": 0.0, "ks": 0.0},
             "class": "not an estimate"} for t in (10.0, 20.0, 40.0)]
    e = {"snapshots": rows, "verdict_class": "not an estimate", "worst_time": 10.0,
         "relaxation": {"predicted": 91.8, "fitted": None, "error": None}}
    line = transient_verdict("exact", e, None)
    assert "NOT AN ESTIMATE at every time" in line and "L1" not in line
    assert "not measured on the original system" in line


# ---------------------------------------------------------------- R(T) at a mission time
def test_at_prints_r_of_every_model_and_the_original_system(doubles, no_report, capsys):
    """--at T: R(T) of the original system with its interval and band, of every model, printed
    and in metrics.json's "at". With exponential FPTs R_M(T) = exp(-T / T_M) exactly, and the
    Kaplan-Meier R(T) within 4 of its Greenwood errors of exp(-T / T0) (1024 paths)."""
    code, cap = _cli(["passage", str(TINY), "--threshold", "2", "--start", "0.5", "--model",
                      "exact", "--at", "50", "--at", "100", "--quiet", "--paths", "1024",
                      "--out", "unused"], capsys)
    assert code == 0, cap.err
    rows = no_report[0][0].metrics["at"]
    assert [r["T"] for r in rows] == [50.0, 100.0]
    for r in rows:
        o = r["original_system"]
        assert r["exact"] == pytest.approx(math.exp(-r["T"] / td.T_MODEL["exact"]), rel=1e-3)
        assert abs(o["value"] - math.exp(-r["T"] / td.T_ORIGINAL)) < 4 * o["se"]
        assert o["band"][0] <= o["ci"][0] <= o["value"] <= o["ci"][1] <= o["band"][1]
        assert f"R({r['T']:g}): original system {o['value']:.4f}" in cap.out


def test_passage_csv_files_hold_r_and_the_fpt_density(doubles, tiny):
    """reliability.csv and fpt_density.csv (written beside passage.npz: test_passage.py's
    report test), with the columns docs/passage.md names: the original system's rows are the
    Kaplan-Meier steps (R = exp(-t/T0) within 4 Greenwood errors at every row with 100 or more
    paths at risk), each model's R_M(t) is its curve (exp(-t/T_M) exactly); each density
    integrates to the mass that passed (1 - R at the last bin edge)."""
    import csv
    import io

    from vifpk.harness.outputs.timereport import passage_csv
    from vifpk.harness.workflows.passage import passage

    res = passage(tiny.with_values({"montecarlo.paths": 256}), threshold=2.0, start=0.5,
                  models=("exact",))
    files = passage_csv(res)
    rel = list(csv.DictReader(io.StringIO(files["reliability.csv"])))
    dens = list(csv.DictReader(io.StringIO(files["fpt_density.csv"])))
    assert list(rel[0]) == ["curve", "t", "R", "se", "lower", "upper"]
    assert list(dens[0]) == ["curve", "t_lo", "t_hi", "density", "err"]
    assert {r["curve"] for r in rel} == {"original_system", "exact", "sde:exact"}
    km = [r for r in rel if r["curve"] == "original_system"]
    assert float(km[0]["t"]) == 0.0 and float(km[0]["R"]) == 1.0
    for r in km:
        t, R, se = float(r["t"]), float(r["R"]), float(r["se"])
        assert float(r["lower"]) <= R <= float(r["upper"])
        if R * 256 >= 100:
            assert abs(R - math.exp(-t / td.T_ORIGINAL)) <= 4 * se + 1e-12
    for r in (r for r in rel if r["curve"] == "exact"):
        assert float(r["R"]) == pytest.approx(math.exp(-float(r["t"]) / td.T_MODEL["exact"]),
                                              abs=1e-12)
        assert r["se"] == r["lower"] == r["upper"] == ""
    for curve in ("original_system", "exact"):
        rows = [r for r in dens if r["curve"] == curve]
        mass = sum(float(r["density"]) * (float(r["t_hi"]) - float(r["t_lo"])) for r in rows)
        last = float(rows[-1]["t_hi"])
        if curve == "exact":  # linear interpolation on the double's grid, h = 0.006 T_M:
            # error <= h^2 / 8 |R''| = 4.5e-6
            assert abs(mass - (1 - math.exp(-last / td.T_MODEL["exact"]))) < 5e-6
        else:
            below = [float(r["R"]) for r in km if float(r["t"]) <= last][-1]
            assert mass == pytest.approx(1 - below, abs=1e-12)


@pytest.mark.slow
def test_p49_real_run_every_path_censored_is_not_an_estimate():
    """P49 with the real solvers (slow tier, ~5 s CPU): `--threshold 0.6 --start 0.3
    --horizon 5 --model exact --paths 64` on paper-base censors every path (the exact model's
    MFPT is ~250, 50x the horizon): NOT AN ESTIMATE and no recommendation, not "SMALL -- -0.0%
    +/- 0.0%"."""
    import vifpk

    res = vifpk.passage("paper-base", threshold=0.6, start=0.3, horizon=5.0, models=["exact"],
                        paths=64, sde=False)
    o = res.metrics["mfpt"]["original_system"]
    assert o["censored"] == o["paths"] == 64
    assert res.metrics["models"]["exact"]["verdict_class"] == "not an estimate"
    assert res.verdicts[0].startswith("exact model: NOT AN ESTIMATE -- no path")
    assert res.metrics["recommended_model"] == "none"


# ------------------------------------------------- splitting: CLI knobs, the API, sweeps
@pytest.fixture
def split(monkeypatch):
    """door.timedomain.passage_splitting replaced by a double: the original system's MFPT is
    T_ORIGINAL +- 2 (95% interval +- 4); the settings it was called with are kept."""
    from vifpk.harness.door import timedomain

    from vifpk.core.result import Result

    calls = []

    def passage_splitting(scene, *, threshold, start, **kw):
        calls.append(kw)
        T = td.T_ORIGINAL
        return Result(data={}, info={"mfpt": {"value": T, "stderr": 2.0, "ci": [T - 4, T + 4],
                                              "p": {"value": 0.1}, "mean_cycle": 12.0},
                                     "groups": kw.get("groups", 20),
                                     "target": "reached (double)"})

    monkeypatch.setattr(timedomain, "passage_splitting", passage_splitting)
    # the double has no levels: the workflow's early check of them goes with it
    monkeypatch.setattr(timedomain, "checked_splitting_levels",
                        lambda scene, **kw: {"low": None, "entry": None, "source": "double"})
    return calls


@pytest.mark.parametrize(("args", "needle"), [
    (["--method", "splitting", "--particles", "1"],
     "--particles 1: out of range; allowed: a whole number >= 2"),
    (["--method", "splitting", "--groups", "401"],
     "--groups 401: out of range; allowed: a whole number from 2 to 400"),
    (["--method", "direct", "--particles", "50"], "--particles: does not apply to --method direct"),
    (["--method", "direct", "--groups", "4"], "--groups: does not apply to --method direct"),
])
def test_splitting_knobs_are_validated(no_computation, capsys, args, needle):
    _refused(["passage", "paper-base", "--threshold", "0.9", *args], capsys, needle)


def test_cli_splitting_takes_particles_and_groups_and_gives_verdict_classes(
        doubles, split, tmp_path, capsys):
    """--method splitting --particles N --groups G reach the door; the report has a verdict
    class per model (the direct run's classes: exact T = 100 against 120 +- 2 is -16.7%,
    moderate) and a recommendation (none: the best model misses by more than 10%)."""
    out = tmp_path / "s"
    code, cap = _cli(["passage", str(TINY), "--threshold", "2", "--start", "0.5", "--method",
                      "splitting", "--particles", "50", "--groups", "4", "--model", "exact",
                      "--out", str(out), "--quiet"], capsys)
    assert code == 0, cap.err
    assert split[0]["particles"] == 50 and split[0]["groups"] == 4
    met = json.loads((out / "metrics.json").read_text())
    e = met["models"]["exact"]
    assert e["mfpt_error"]["value"] == pytest.approx(td.T_MODEL["exact"] / td.T_ORIGINAL - 1)
    assert e["verdict_class"] == "moderate" and met["recommended_model"] == "none"
    assert "exact model: MODERATE -- MFPT error -16.7%" in cap.out
    assert "recommended model for first passage: none" in cap.out
    assert "moderate" in (out / "report.md").read_text()


def test_api_method_splitting(doubles, split, tiny):
    """vifpk.passage(method="splitting", groups=G): the splitting result with its verdicts;
    a method that is none of the command's and a horizon with splitting refused ("auto" is
    accepted since issue 45: tests/test_edges8_time.py)."""
    import vifpk
    from vifpk.core.result import BadInput

    res = vifpk.passage(tiny, threshold=2.0, start=0.5, models=["exact", "corrected"],
                        method="splitting", groups=6)
    assert split[-1]["groups"] == 6 and "particles" not in split[-1]
    assert res.metrics["method"] == "splitting"
    # 118 / 120 - 1 = -1.7% against an error bar of 1.6% (2 / 120): within 2 bars
    assert res.metrics["models"]["corrected"]["verdict_class"] == "indistinguishable"
    assert res.metrics["recommended_model"] == "corrected"
    with pytest.raises(BadInput, match="--method 'Auto': allowed: auto, direct, splitting"):
        vifpk.passage(tiny, threshold=2.0, method="Auto")
    with pytest.raises(BadInput, match="--horizon: does not apply to --method splitting"):
        vifpk.passage(tiny, threshold=2.0, method="splitting", horizon=10.0)


def test_sweep_passage_method_splitting(doubles, split, tmp_path, tiny):
    """[passage] method = "splitting" in a sweep file: accepted (an unknown method refused),
    and a point's record is the direct point's layout with the splitting MFPT."""
    from types import SimpleNamespace

    from vifpk.harness.sweeps.errors import SweepError
    from vifpk.harness.sweeps.spec import load_sweep
    from vifpk.harness.sweeps.timesweep import passage_point

    (tmp_path / "tiny.toml").write_text(TINY.read_text())
    p = tmp_path / "s.toml"
    body = ('scene = "tiny.toml"\nworkflow = "passage"\n[passage]\nstart = 0.5\n'
            'method = "{m}"\ngroups = 4\n[vary]\n"passage.threshold" = [1.5, 2.0]\n')
    p.write_text(body.format(m="splitting"))
    sw = load_sweep(p)
    assert len(sw.points) == 2
    p.write_text(body.format(m="nope"))
    with pytest.raises(SweepError, match="method = 'nope'"):
        load_sweep(p)
    job = SimpleNamespace(bifurcation={"start": 0.5, "method": "splitting", "groups": 4,
                                       "sde": False},
                          params=(("passage.threshold", 2.0),), scene=tiny, models=("exact",))
    rec = passage_point(job)
    assert rec["mfpt_original"] == td.T_ORIGINAL and split[-1]["groups"] == 4
    assert rec["models"]["exact"]["verdict_class"] == "moderate"
    assert math.isnan(rec["models"]["exact"]["R_sup"])


# ------------------------------------------------------------- own cases on the requests
@pytest.mark.parametrize(("case", "call", "needle"), [
    ("at-inf", lambda v: v.passage("paper-base", threshold=0.6, at=math.inf),
     "--at inf: out of range; allowed: a finite time > 0"),
    ("at-text", lambda v: v.passage("paper-base", threshold=0.6, at="10"), "--at '10'"),
    ("particles-float", lambda v: v.passage("paper-base", threshold=0.6, method="splitting",
                                            particles=50.0), "--particles 50.0"),
    ("groups-bool", lambda v: v.passage("paper-base", threshold=0.6, method="splitting",
                                        groups=True), "--groups True"),
    ("method-case", lambda v: v.passage("paper-base", threshold=0.6, method="Splitting"),
     "--method 'Splitting': allowed: auto, direct, splitting"),
    ("models-int", lambda v: v.passage("paper-base", threshold=0.6, models=[42]),
     "--model 42: not a model"),
    ("start-typo", lambda v: v.passage("paper-base", threshold=0.6, start="stationnary"),
     "--start 'stationnary'"),
    ("horizon-text", lambda v: v.passage("paper-base", threshold=0.6, horizon="5"),
     "--horizon '5': not a number"),
    ("paths-memory", lambda v: v.passage("paper-base", threshold=0.6, paths=10**9),
     "--paths 1000000000: the simulation needs at least"),
    ("transient-paths-memory", lambda v: v.transient("paper-base", start=1.0,
                                                     times=(10, 20, 40), paths=10**9),
     "--paths 1000000000: the simulation needs at least"),
    ("assert-paths-memory", lambda v: v.assert_mfpt_close("paper-base", "exact", 0.6, rtol=0.1,
                                                          paths=10**9),
     "--paths 1000000000: the simulation needs at least"),
    ("transient-sde-int", lambda v: v.transient("paper-base", start=1.0, times=(10, 20, 40),
                                                sde=1), "sde 1: not true or false"),
    ("transient-start-huge", lambda v: v.transient("paper-base", start=1e200,
                                                   times=(10, 20, 40)), "--start 1e+200"),
])
def test_own_request_cases(no_computation, case, call, needle):
    """Own hostile cases on the typed requests (docs/edges.md round 7): BadInput, one line,
    before any work (a model that is not one was a TypeError; 1e9 paths a MemoryError after
    the averaged models had run)."""
    import vifpk
    from vifpk.core.result import BadInput

    with pytest.raises(BadInput) as e:
        call(vifpk)
    assert needle in str(e.value) and "\n" not in str(e.value), (case, str(e.value))


@pytest.mark.slow
def test_s04_splitting_at_a_threshold_within_direct_reach(monkeypatch, tmp_path, capsys):
    """S04: `--threshold 0.3 --start 0.29 --method splitting` (the default levels fall below
    the start): exit 2, one line naming the entry level and --method direct, nothing written
    and no splitting run (it was an internal error). Slow tier: the exact model's quadrature
    and stationary density, a few seconds."""
    import vifpk.montecarlo.splitting as splitting

    def forbidden(*a, **k):
        raise AssertionError("splitting started")

    monkeypatch.setattr(splitting, "passage_splitting", forbidden)
    out = tmp_path / "s04"
    _refused(["passage", "paper-base", "--threshold", "0.3", "--start", "0.29", "--method",
              "splitting", "--model", "exact", "--out", str(out)], capsys,
             "passage_splitting start 0.29: not below the entry level 0.225")
    assert not out.exists()


def test_direct_is_priced_before_any_r_stepping(doubles, monkeypatch, tmp_path, capsys):
    """--method direct out of reach (a model MFPT of 1e9): refused by the cost guard from the
    quadratures alone, before any model's R(t) is time-stepped (X14 died inside that stepping
    at a threshold the guard would have refused)."""
    from vifpk.harness.door import timedomain

    def forbidden(*a, **k):
        raise AssertionError("R(t) stepped before the price")

    monkeypatch.setitem(td.T_MODEL, "exact", 1e9)
    monkeypatch.setattr(timedomain, "passage_averaged", forbidden)
    _refused(["passage", str(TINY), "--threshold", "2", "--model", "exact", "--method",
              "direct", "--quiet", "--out", str(tmp_path / "p")], capsys, "MFPT at up to 1e+09")


def test_every_request_field_is_an_option_of_every_front_end():
    """One request, every front end: each field of PassageRequest / TransientRequest is an
    option of the command (its flag), a parameter of vifpk.passage / vifpk.transient and a key
    of the sweep's [passage] / [transient] table (where it applies), so no front end drops a
    question the request can ask."""
    import argparse
    import inspect

    from vifpk.harness.cli.timedomain import passage_arguments, transient_arguments
    from vifpk.harness.request.timedomain import PassageRequest, TransientRequest
    from vifpk.harness.sweeps.timesweep import KEYS

    import vifpk

    def dests(build):
        p = argparse.ArgumentParser()
        build(p)
        return {a.dest for a in p._actions}

    own = {"scene", "quadratures"}  # the scene is the positional; quadratures are priced
    cli_name = {"models": "model", "sde": None}  # sde: the command always runs the SDEs
    sweep_only_not = {"models", "paths", "at"}  # a sweep's [models]/[montecarlo]; no --at
    for req, build, api, table in ((PassageRequest, passage_arguments, vifpk.passage,
                                    "passage"),
                                   (TransientRequest, transient_arguments, vifpk.transient,
                                    "transient")):
        fields = {f.name for f in dataclasses.fields(req)} - own
        cli = dests(build)
        for f in fields:
            name = cli_name.get(f, f)
            assert name is None or name in cli, (req.__name__, f)
        params = set(inspect.signature(api).parameters) | {"paths"}  # paths: **options
        assert fields <= params, (req.__name__, fields - params)
        missing = fields - sweep_only_not - set(KEYS[table])
        assert not missing, (req.__name__, missing)


def test_paths_dt_seed_are_declared_once_for_every_command():
    """Issue 38 item 1: --paths, --dt and --seed are declared once (cli/options.py
    _MC_DECLARED): solve/check and passage/transient take the same type (hence the same
    parsing and range checks); no module under harness/cli declares them a second time."""
    import argparse
    from pathlib import Path

    from vifpk.harness.cli import options
    from vifpk.harness.cli.timedomain import passage_arguments, transient_arguments

    for build in (options._add_mc_options, passage_arguments, transient_arguments):
        p = argparse.ArgumentParser()
        build(p)
        acts = {a.dest: a for a in p._actions}
        for name, decl in options._MC_DECLARED.items():
            assert acts[name].type is decl["type"], (build.__name__, name)
            assert acts[name].help, (build.__name__, name)
    cli = Path(options.__file__).parent
    for f in cli.glob("*.py"):
        text = f.read_text()
        for name in options._MC_DECLARED:
            assert f'add_argument("--{name}"' not in text, (f.name, name)
