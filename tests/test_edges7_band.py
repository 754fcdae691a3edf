"""Issue 39, round 7: the tolerance range (K05) and band sweeps with checkpoints (B39-B50):
refused in one line naming the input and its range, or recomputed and said; never a false
message. docs/edges.md ("Round 7 ... helper edges39") lists them."""

from __future__ import annotations

import pytest


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
