"""The error report as a researcher reads it: verdict classes, table formats, CLI help."""

from __future__ import annotations

import argparse

import pytest
from vifpk.harness.cli.app import build_parser, main
from vifpk.harness.outputs.report import _column_format, _format_columns
from vifpk.harness.workflows.verdict import LARGE_L1, SMALL_L1, verdict, verdict_class


def _entry(l1: float, floor: float = 0.01, disc: float = 1e-4, samp: float = 0.008,
           sampling_ok: bool = True) -> dict:
    hist = {"L1": l1, "L1_err": 0.002, "L1_floor": floor, "ks": l1 / 2, "mean_diff": 0.01}
    return {"averaging_error": {"A": hist},
            "discretisation_error": {"A": {"L1": disc, "L1_floor": 0.0}},
            "sampling_error": {"A": {"L1": samp, "L1_floor": floor}},
            "sampling_ok": sampling_ok}


@pytest.mark.parametrize(("l1", "cls"), [(0.015, "indistinguishable"), (0.05, "small"),
                                         (0.2, "moderate"), (0.48, "large")])
def test_verdict_classes_follow_the_stated_thresholds(l1, cls):
    # thresholds: 2 x floor (noise), SMALL_L1 = 0.1, LARGE_L1 = 0.3 (docs/report.md)
    assert (SMALL_L1, LARGE_L1) == (0.1, 0.3)
    assert verdict_class(_entry(l1), [])[0] == cls


def test_verdict_names_the_dominant_cause_and_the_scale():
    cls, cause = verdict_class(_entry(0.48), [])
    assert cls == "large" and cause.startswith("the averaged model itself")
    line = verdict("paper", _entry(0.48), [])
    assert line.startswith("paper model: LARGE")
    assert "48.0 x its MC noise floor" in line and "24.0% of the probability mass" in line
    # the numerics, not the model, when the FPK discretisation is as large as the distance
    assert verdict_class(_entry(0.2, disc=0.15), [])[1] != "none dominant"
    assert "averaged model" not in verdict_class(_entry(0.2, disc=0.15), [])[1]


def test_not_an_estimate_keeps_the_convergence_wording():
    conv = {"equilibrated": False, "reason": "R-hat 1.2 > 1.01"}
    assert verdict_class(_entry(0.3), [], convergence=conv)[0] == "not an estimate"
    line = verdict("exact", _entry(0.3), [], convergence=conv)
    assert "the simulation has not converged" in line and "R-hat 1.2" in line
    line = verdict("exact", _entry(0.3, sampling_ok=False), [])
    assert "the simulation has not converged" in line
    # the run's own checks: the distance would be the run's, not the model's
    from vifpk.core.result import WarningRecord

    step = [WarningRecord("dt_bias", "the step check failed ...")]
    assert verdict_class(_entry(0.3), step)[0] == "not an estimate"
    assert "dt bias" in verdict("exact", _entry(0.3), step)


def test_a_failing_assumption_keeps_the_class_and_the_number_and_names_it():
    """Issue 45, item 4: a failing averaging assumption no longer turns the class into NOT AN
    ESTIMATE: the distance is measured (held-out simulations of three wall scenes agreed with
    it); the class and the number stay and the assumption is said beside them. An advisory
    warning adds nothing there."""
    from vifpk.core.result import WarningRecord

    w = [WarningRecord("strong_dissipation", "strong dissipation: the losses take ...")]
    for l1, cls in ((0.3, "large"), (0.05, "small"), (0.015, "indistinguishable")):
        assert verdict_class(_entry(l1), w)[0] == cls
        line = verdict("exact", _entry(l1), w)
        assert line.startswith(f"exact model: {cls.upper()} -- L1(A) = {l1:.3f}")
        assert "NOT" not in line
        assert line.endswith("measured where an averaging assumption fails (strong "
                             "dissipation, see warnings): this is the model's error on this "
                             "scene, not a trend beyond it")
    adv = [WarningRecord("correlated_noise", "correlated noise: ...")]
    assert "assumption" not in verdict("exact", _entry(0.05), adv)
    two = w + [WarningRecord("narrow_band", "narrow-band noise: ...")]
    assert "averaging assumptions fail (strong dissipation, narrow band" in verdict(
        "exact", _entry(0.05), two)


def test_table_columns_have_one_format_and_hide_values_below_the_floor():
    assert _column_format([0.48, 0.073, 0.05]) == "fixed"
    assert _column_format([0.48, 6.2e-4]) == "sci"
    raw = [["a", 0.48, 0.01, -2.78e-17], ["b", 6.2e-4, 0.01, 0.0012], ["c", 1e-5, None, 0.3]]
    spec = [{"text": True}, {"floor": 2}, {}, {"signed": True}]
    rows = _format_columns(raw, spec)
    assert rows[0][1] == "4.80e-01" and rows[1][1] == "< floor" and rows[2][1] == "1.00e-05"
    assert rows[2][2] == "–"  # no floor for a deterministic comparison
    assert rows[0][3] == "0 (< 1e-12)" and rows[1][3] == "+1.20e-03"
    # an error bar of a value below its floor is not shown either
    spec = [{"floor": 2}, {"err_of": 0}, {}]
    rows = _format_columns([[0.02, 0.003, 0.05], [0.5, 0.003, 0.05]], spec)
    assert rows[0][:2] == ["< floor", "–"] and rows[1][:2] == ["0.500", "3.00e-03"]


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            return dict(a.choices)
    return {}


def test_every_option_has_help_showing_its_default():
    parser = build_parser()
    for name, sub in _subparsers(parser).items():
        for a in sub._actions:
            if isinstance(a, argparse._HelpAction):
                continue
            assert a.help, (name, a.dest)
            if a.help == argparse.SUPPRESS:  # parsed, not listed: refused where it does not
                continue  # apply (workprecision's --paths, issue 45; tests/test_edges8_open.py)
            if a.option_strings and not a.required:
                assert "default" in a.help, (name, a.option_strings)


def test_version_and_bare_usage(capsys):
    from vifpk.core.provenance import vifpk_version

    # answered before the parser is built (a hanging workflow plugin cannot hang it, issue 45)
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"vifpk {vifpk_version()}"
    assert main([]) == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: vifpk") and "check" in err and "workprecision" in err
