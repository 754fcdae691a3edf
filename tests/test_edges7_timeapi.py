"""Issue 39 leftovers of the time domain (helper edges39b): the Python API at a threshold out
of direct reach (X12), splitting that dies out (X13), splitting's report (its files, runtime
warnings, progress). Fast tier on tests/time_doubles.py's known answers unless marked slow;
docs/edges.md round 7 names them."""

from __future__ import annotations

import pytest

from tests import time_doubles as td

# xdist_group: tests that run the same compiled kernel shape go to one worker (CI's --dist
# loadgroup), so it is compiled once rather than by both workers at the same time.

#: the models' MFPTs to Ac = 2.0 from the stationary law on paper-base, by their Pontryagin
#: quadratures (measured 2026-11-28, harness.request.timedomain.with_quadratures)
MFPT_AT_2 = {"paper": 1.18e46, "exact": 9.16e114, "corrected": 4.20e118}


@pytest.fixture
def far_tail(monkeypatch):
    """The doubles, with the quadratures of threshold 2.0 and a record of any real work."""
    import vifpk.harness.door.timedomain as door

    td.install(monkeypatch)
    work = []

    def mfpt(scene, model, *, threshold, start):
        return {"value": MFPT_AT_2[model], "error_estimate": 1e-9}

    def forbidden(name):
        def f(*a, **k):
            work.append(name)
            raise AssertionError(f"{name} ran")
        return f

    monkeypatch.setattr(door, "mfpt_averaged", mfpt)
    for name in ("passage_averaged", "passage_montecarlo", "passage_sde"):
        monkeypatch.setattr(door, name, forbidden(name))
    return work


def test_x12_api_passage_out_of_direct_reach_is_refused_in_one_line(far_tail, tmp_path):
    """``vifpk.passage("paper-base", threshold=2.0, start="stationary", out=...)`` ran the
    exact model's R(t) stepping for minutes, silently. Now the direct run is priced from the
    quadratures as the command prices it: BadInput, one line, naming method='splitting' and
    yes=True, before any R(t) stepping or Monte Carlo; nothing written."""
    import vifpk
    from vifpk.core.result import BadInput

    out = tmp_path / "p2"
    with pytest.raises(BadInput) as exc:
        vifpk.passage("paper-base", threshold=2.0, start="stationary", out=out)
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith("threshold 2: the averaged models put the MFPT")
    assert "method='splitting'" in msg and msg.endswith("allowed: up to 1 hour (or yes=True to "
                                                       "run it anyway)")
    assert far_tail == [] and not out.exists()


def _cli(args, capsys):
    from vifpk.harness.cli.app import main

    code = main(args)
    return code, capsys.readouterr()


DIED = "every AMS run died out (p = 0 in each group): use more particles"  # splitting.py's


@pytest.fixture
def split_doubles(monkeypatch):
    """The doubles, and door.timedomain.passage_splitting's solver call
    (montecarlo.splitting.passage_splitting) replaced: it raises montecarlo/splitting.py's
    extinction error below ``need`` particles, else returns the original system's MFPT
    T_ORIGINAL +- 2 (and raises a RuntimeWarning, as a numpy overflow would); the door's own
    code runs."""
    import warnings

    import vifpk.harness.door.timedomain as door
    import vifpk.montecarlo.splitting as splitting

    from vifpk.core.result import Result

    td.install(monkeypatch)
    calls = {"particles": [], "need": 10**9}

    def split(system, noise, s, **kw):
        calls["particles"].append(s.particles)
        if s.particles < calls["need"]:
            raise RuntimeError(DIED)
        warnings.warn("overflow encountered in exp", RuntimeWarning, stacklevel=1)
        T = td.T_ORIGINAL
        return Result(data={}, info={"mfpt": {"value": T, "stderr": 2.0, "ci": [T - 4, T + 4],
                                              "p": {"value": 0.1}, "mean_cycle": 12.0},
                                     "groups": s.groups, "target": "reached (double)",
                                     "low": kw["low"], "entry": kw["entry"]})

    monkeypatch.setattr(splitting, "passage_splitting", split)
    # the levels from the exact model's stationary law cost 0.4 s a call: fixed ones
    monkeypatch.setattr(door, "splitting_levels", lambda scene, *, start, threshold: {
        "low": 0.3 * threshold, "entry": 0.5 * threshold, "source": "a test's levels"})
    return calls


SPLIT = ["passage", "paper-base", "--threshold", "1.2", "--start", "0.1", "--method",
         "splitting", "--model", "exact"]


def test_x13_splitting_that_dies_out_is_a_numerical_failure_naming_particles(
        split_doubles, tmp_path, capsys):
    """X13: every AMS run dying out was "internal error: RuntimeError ... use more particles"
    (exit 1, "please report it"). Now exit 3, one line naming --particles and its value, the
    threshold, and nothing written; with --particles given it is not retried."""
    out = tmp_path / "s"
    code, cap = _cli([*SPLIT, "--particles", "50", "--groups", "4", "--out", str(out),
                      "--quiet"], capsys)
    lines = cap.err.strip().splitlines()
    assert code == 3 and len(lines) == 1, cap.err
    assert "every AMS run died out before reaching Ac = 1.2" in lines[0]
    assert "raise particles (--particles, now 50)" in lines[0]
    assert "internal error" not in lines[0] and split_doubles["particles"] == [50]
    assert not (out / "metrics.json").exists()
    # with progress lines: the splitting's line ends ("died out"), the failure is its own line
    code, cap = _cli([*SPLIT, "--particles", "50", "--out", str(out)], capsys)
    lines = cap.err.strip().splitlines()
    assert code == 3 and lines[-2].endswith("died out, 0.0 s"), cap.err
    assert lines[-1].startswith("vifpk: splitting: every AMS run died out")


def test_x13_splitting_retries_with_more_particles_within_the_budget(split_doubles, tmp_path,
                                                                     capsys):
    """At the default particles (200), a splitting that dies out runs again with twice as many
    while the next run fits in the budget (the double dies out below 800 particles: 200, 400,
    800); the report says so (a warning per retry, metrics.json splitting.attempts)."""
    import json

    split_doubles["need"] = 800
    out = tmp_path / "s"
    code, cap = _cli([*SPLIT, "--out", str(out), "--quiet"], capsys)
    assert code == 0, cap.err
    assert split_doubles["particles"] == [200, 400, 800]
    met = json.loads((out / "metrics.json").read_text())
    assert [a["outcome"] for a in met["splitting"]["attempts"]] == ["died out", "died out",
                                                                    "finished"]
    assert "warning: every AMS run died out with 200 particles: run again with 400" in cap.out


def test_splitting_report_is_a_direct_run_s_report(split_doubles, tmp_path, capsys):
    """`vifpk passage --method splitting` writes report.html beside report.md (verdict classes,
    percent errors, the recommendation), metrics.json with the run's counted
    ``runtime_warnings`` (the direct run's key, harness/outputs/runwarnings.py), and prints
    progress lines while it runs (it wrote report.md and metrics.json only, silently)."""
    import json

    split_doubles["need"] = 0
    out = tmp_path / "s"
    code, cap = _cli([*SPLIT, "--out", str(out)], capsys)
    assert code == 0, cap.err
    page = (out / "report.html").read_text()
    for text in ("exact model: MODERATE -- MFPT error -16.7% +/- ", "moderate",
                 "recommended model for first passage: none", "-16.7% +- "):
        assert text in page and text in (out / "report.md").read_text(), text
    met = json.loads((out / "metrics.json").read_text())
    assert [(w["message"], w["count"]) for w in met["runtime_warnings"]] == [
        ("overflow encountered in exp", 1)]
    assert "] splitting of the original system (200 particles x 20 groups" in cap.err
    assert "] MFPT of the exact model (quadrature) ..." in cap.err
    assert f"report: {out / 'report.html'}" in cap.out


def test_x12_assert_mfpt_close_out_of_direct_reach_is_a_usage_error(far_tail):
    """The testing API (``vifpk.assert_mfpt_close``, the ``vifpk_mfpt`` fixture) at the same
    threshold: BadInput in one line before any R(t) stepping or Monte Carlo, not hours."""
    from vifpk.harness.testing import assert_mfpt_close

    from vifpk.core.result import BadInput

    with pytest.raises(BadInput, match=r"out of reach as a direct simulation .*allowed: up to "
                                       r"1 hour \(or a lower threshold"):
        assert_mfpt_close("paper-base", "exact", 2.0, rtol=0.1)
    assert far_tail == []


@pytest.mark.xdist_group("splitting-paper-base")
@pytest.mark.slow
def test_x13_real_splitting_that_dies_out_exits_3(tmp_path, capsys):
    """X13 on the real splitting: two particles in two groups to Ac = 1.2 from A0 = 0.3 on
    paper-base die out (measured: within seconds); exit 3, the last line of the standard
    error names --particles (the progress lines come before it), nothing written."""
    out = tmp_path / "s"
    code, cap = _cli(["passage", "paper-base", "--threshold", "1.2", "--start", "0.3",
                      "--method", "splitting", "--particles", "2", "--groups", "2", "--out",
                      str(out), "--quiet"], capsys)
    lines = cap.err.strip().splitlines()
    assert code == 3 and len(lines) == 1, cap.err
    assert "every AMS run died out" in lines[0] and "(--particles, now 2)" in lines[0]
    assert not (out / "metrics.json").exists()


@pytest.mark.filterwarnings("ignore:overflow encountered in exp:RuntimeWarning")  # the double's
def test_api_splitting_out_writes_the_same_report_and_progress(split_doubles, tmp_path,
                                                               capsys):
    """``vifpk.passage(..., method="splitting", out=DIR, quiet=False)``: the report.html and
    report.md the command writes (no runtime_warnings key: the API records none, as for a
    direct run), and the progress lines (it printed nothing and wrote report.md only)."""
    import json

    import vifpk

    split_doubles["need"] = 0
    out = tmp_path / "api"
    vifpk.passage("paper-base", threshold=1.2, start=0.1, models=["exact"], method="splitting",
                  out=out, quiet=False)
    assert "exact model: MODERATE -- MFPT error -16.7%" in (out / "report.html").read_text()
    assert "runtime_warnings" not in json.loads((out / "metrics.json").read_text())
    assert "] splitting of the original system (200 particles" in capsys.readouterr().err
