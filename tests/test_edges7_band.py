"""Issue 39, round 7: the tolerance range (K05) and band sweeps with checkpoints (B39-B50):
refused in one line naming the input and its range, or recomputed and said; never a false
message. docs/edges.md ("Round 7 ... helper edges39") lists them."""

from __future__ import annotations

import pytest

from tests import test_edges7_plugins


@pytest.fixture
def workflow_plugin(monkeypatch):
    """tests/test_edges7_plugins.py's ``hello`` fixture: a plugin workflow misbehaving on
    demand."""
    gen = test_edges7_plugins.hello.__wrapped__(monkeypatch)
    yield next(gen)
    next(gen, None)


def _main(args):
    from vifpk.harness.cli.app import main

    try:
        return main(args)
    except SystemExit as exc:
        return exc.code


# ------------------------------------------------------------ K05: the tolerance's range
@pytest.mark.parametrize(("metric", "value", "top"), [
    ("L1", "5", "2"), ("L1", "2", "2"), ("ks", "1", "1"), ("hellinger", "1.5", "1")])
def test_k05_a_tolerance_at_or_above_the_metric_s_maximum_is_refused(no_computation, capsys,
                                                                     tmp_path, metric, value,
                                                                     top):
    """L1 <= 2, KS <= 1, Hellinger <= 1 between any two densities (harness/workflows/
    compare.py's definitions): such a tolerance can never fail, so it is not a question."""
    out = tmp_path / "o"
    assert _main(["check", "paper-base", "--tolerance", value, "--tolerance-metric", metric,
                  "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--tolerance" in err[0] and f"< {top} for" in err[0], err
    assert metric in err[0] and not out.exists()


def test_k05_a_tolerance_below_the_maximum_and_any_w1_are_accepted():
    from vifpk.harness.request.tolerance import Tolerance

    assert Tolerance(value=1.99, metric="L1").value == 1.99
    assert Tolerance(value=0.99, metric="ks").value == 0.99
    assert Tolerance(value=50.0, metric="w1").value == 50.0  # W1 is unbounded


# ------------------------------------------------------------ issue 38's leftovers
def test_the_monte_carlo_takes_the_scene_s_default_observables():
    """One default of ``joint`` (issue 38): montecarlo.Settings records what a scene's
    [observables] records by default (the 2-D histogram only when asked for)."""
    from dataclasses import fields

    from vifpk import montecarlo as mc
    from vifpk.core.sections import Observables

    default = next(f.default for f in fields(mc.Settings) if f.name == "observables")
    assert default == Observables().names()
    assert "joint" not in default and {"A", "x1", "x2"} <= set(default)


def test_transient_metrics_json_holds_the_run_s_runtime_warnings(monkeypatch, tmp_path, capsys):
    """The command's counted RuntimeWarnings (harness/outputs/runwarnings.py, as `vifpk check`
    stores them) reach the time-domain report's metrics.json: the workflow is replaced by one
    that warns (numpy's nanmean of no number) and returns a result, the writer by one that
    keeps what it is given; metrics_document puts them before ``timings``."""
    import warnings
    from types import SimpleNamespace

    import numpy as np
    from vifpk.harness.outputs import timereport
    from vifpk.harness.workflows import transient

    def run(req, *, quiet):
        np.nanmean(np.array([np.nan]))  # RuntimeWarning: Mean of empty slice
        return SimpleNamespace(metrics={}, verdicts=["ok"], recommendation="", warnings=[],
                               scene=req.scene)

    given = {}

    def write(res, out, *, prov, runtime_warnings=None):
        given["warnings"] = runtime_warnings
        return {"report.html": out}

    monkeypatch.setattr(transient, "run", run)
    monkeypatch.setattr(timereport, "write_time_report", write)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the tally, not the test, must catch it
        assert _main(["transient", "paper-base", "--start", "0.5", "--times", "10,20,30",
                      "--out", str(tmp_path / "t"), "--yes"]) == 0
    recs = given["warnings"]
    assert len(recs) == 1 and recs[0]["category"] == "RuntimeWarning", recs
    assert "Mean of empty slice" in recs[0]["message"] and recs[0]["count"] == 1
    res = SimpleNamespace(metrics={"workflow": "transient", "timings": {"s": 1}},
                          scene=SimpleNamespace(to_dict=lambda: {}))
    doc = timereport.metrics_document(res, {"run_id": "x"}, recs)
    assert list(doc) == ["workflow", "scene", "runtime_warnings", "timings", "provenance"]
    assert "runtime_warnings" not in timereport.metrics_document(res, {"run_id": "x"})


# ------------------------------------------------------------ band sweeps: checkpoints
def _band(tmp_path):
    """The test band sweep (tests/data/sweep-band.toml) and its first point's state: its
    stage-0 record taken (canned numbers: no Monte Carlo runs here)."""
    from vifpk.harness.sweeps.adaptive import initial_design
    from vifpk.harness.sweeps.bandrun import _State
    from vifpk.harness.sweeps.spec import load_sweep

    from tests.conftest import ROOT

    sweep = load_sweep(ROOT / "tests" / "data" / "sweep-band.toml")
    st = _State(sweep, "exact")
    unit = initial_design(len(sweep.vary), 16)[0]
    rec, job = st.prepare(unit, None, 0, tmp_path)
    assert rec is None and job.stage == 0
    return sweep, st, unit, job.key


def _take(st, key, state: bytes | None):
    import hashlib

    rec = {"key": key, "stage": 0, "status": "ok", "fingerprint": "f",
           "result": {"mc_path_steps_run": 1.0, "models": {"exact": {"L1_floor_A": 0.02}}}}
    if state is not None:
        rec["state_sha256"] = hashlib.sha256(state).hexdigest()
    st.take(rec)


def _npz() -> bytes:
    import io

    import numpy as np

    buf = io.BytesIO()
    np.savez(buf, meta=np.frombuffer(b'{"key": "k"}', dtype=np.uint8))
    return buf.getvalue()


@pytest.mark.parametrize("case", ["deleted", "truncated", "another run's", "kept"])
def test_b46_b49_an_unusable_checkpoint_is_detected_and_the_extension_runs_afresh(
        tmp_path, case):
    """The checkpoint an extension continues from is used only when it is the file its record
    names (sha256); else the extension's Monte Carlo runs afresh to its floor, said in one line
    (it was an OSError read as "cannot write ...state0.npz (No such file or directory)")."""
    from vifpk.harness.sweeps.store import state_name

    sweep, st, unit, key = _band(tmp_path)
    good = _npz()
    _take(st, key, good)
    (tmp_path / "points").mkdir()
    path = tmp_path / "points" / state_name(key, 0)
    if case != "deleted":
        path.write_bytes({"truncated": good[:40], "another run's": _npz() + b"x",
                          "kept": good}[case])
    rec, job = st.prepare(unit, key, 1, tmp_path)
    assert rec is None and job.stage == 1
    if case == "kept":
        assert job.state == good and st.notes == []
    else:
        assert job.state is None
        assert len(st.notes) == 1 and "runs afresh" in st.notes[0] and path.name in st.notes[0]


def test_b48_a_checkpoint_without_a_recorded_hash_must_be_a_whole_archive(tmp_path):
    from vifpk.harness.sweeps.bandrun import _usable_state

    p = tmp_path / "k.state0.npz"
    p.write_bytes(_npz())
    assert _usable_state(p, {}) == p.read_bytes()
    p.write_bytes(_npz()[:-30])  # truncated: its zip directory is gone
    assert _usable_state(p, {}) is None
    assert _usable_state(tmp_path / "gone.npz", {}) is None


def test_b50_a_resume_with_another_tolerance_is_refused_in_one_line(tmp_path):
    import json

    from vifpk.harness.sweeps.bandrun import resume_conflict, run_band
    from vifpk.harness.sweeps.errors import SweepError
    from vifpk.harness.sweeps.executors import parse_executor

    sweep, *_ = _band(tmp_path)
    (tmp_path / "points").mkdir()
    (tmp_path / "points" / "k.json").write_text(json.dumps({"key": "k", "tolerance": 0.05}))
    assert resume_conflict(tmp_path, 0.05) is None
    with pytest.raises(SweepError) as exc:  # before any work: no executor started
        run_band(sweep, tmp_path, executor=parse_executor("serial"), quiet=True)
    line = str(exc.value)
    assert "\n" not in line and "tolerance = 0.05" in line and "tolerance = 0.03" in line


def test_band_messages_count_points_and_runs_right(tmp_path):
    """The end line counts points (a point is computed when any of its runs was); Ctrl-C
    counts runs and names no negative rest (it read "compute the other -7")."""
    from vifpk.harness.sweeps.bandrun import point_counts
    from vifpk.harness.sweeps.store import _kept_message

    keys, before = point_counts(["a", "b", "c", "d"], ["b:0", "c:1", "b:1", "c:2"])
    assert keys == ("b", "c") and before == 2
    line = _kept_message(tmp_path, 7, ["b:0", "c:1"], None)
    assert "9 finished Monte Carlo runs (2 from this run)" in line and "-" not in line.split(
        "kept")[0] and "other -" not in line


def test_b43_an_overspent_budget_is_said_with_its_rule():
    from vifpk.harness.sweeps.bandrun import overspent

    assert overspent(8.0 * 1e6, 1e6, 8) is None
    line = overspent(8.9e6, 1e6, 8)
    assert "spent 8.9 of the budget's 8 points (11% over)" in line


# ------------------------------------------------------------ B39: a full disk
def test_b39_a_full_disk_names_the_sweep_file_not_the_standard_output(tmp_path, monkeypatch):
    import errno

    from vifpk.harness.sweeps import bandrun

    from vifpk.core import io

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(io.os, "fsync", full)
    target = tmp_path / "points" / "k.json"
    target.parent.mkdir()
    with pytest.raises(OSError) as exc:
        io.write_json(target, {"a": 1})
    assert exc.value.filename == str(target) and exc.value.errno == errno.ENOSPC
    assert not target.exists() and list(target.parent.iterdir()) == []  # no temporary left

    def no_name(path, obj):
        raise OSError(errno.ENOSPC, "No space left on device")

    rec = {"key": "k", "stage": 1, "status": "ok", "result": {"state": b"x"}}
    monkeypatch.undo()
    with pytest.raises(OSError) as exc:
        bandrun._store(tmp_path, rec, no_name, 0.03)
    assert exc.value.filename == str(tmp_path / "points" / "k.ext1.json")


def test_b39_the_command_line_says_which_file(workflow_plugin, tmp_path, monkeypatch, capsys):
    """`vifpk sweep` of a trivial plugin workflow (tests/test_edges7_plugins.py's ``hello``,
    no computation) whose first point record meets a full disk (fsync raises ENOSPC): exit 3,
    one line naming the record's file (it said "the standard output")."""
    import errno

    from tests.test_edges7_plugins import _sweep
    from vifpk.core import io

    workflow_plugin(point={"x": 1.0})
    args = _sweep(tmp_path)

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(io.os, "fsync", full)
    assert _main(args) == 3
    err = capsys.readouterr().err.strip().splitlines()
    points = tmp_path / "out" / "points"
    assert err[-1].startswith(f"vifpk: cannot write {points}/"), err
    assert "(No space left on device)" in err[-1] and "standard output" not in err[-1]
