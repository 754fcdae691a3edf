"""The cross-check: metrics on hand-computed cases, the report end to end on the canned check
of a tiny scene (tests/conftest.py)."""

from __future__ import annotations

import json
import math
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from vifpk.harness.cli.app import main
from vifpk.harness.workflows.compare import bin_average, compare

from tests.conftest import ROOT

TINY = str(ROOT / "tests" / "data" / "tiny.toml")


def uniform(lo, hi, n=2001):
    x = np.linspace(lo - 1e-9, hi + 1e-9, n)
    return {"x": x, "p": np.where((x >= lo) & (x <= hi), 1.0 / (hi - lo), 0.0)}


def test_metrics_of_two_shifted_uniforms():
    """U[0,1] against U[0.5,1.5]: L1 = 1, Bhattacharyya 1/2 so H = sqrt(1/2), KS = 1/2,
    mean shift -1/2 (grid error of the step edges ~1e-3)."""
    m = compare(uniform(0, 1), uniform(0.5, 1.5))
    assert m["L1"] == pytest.approx(1.0, abs=2e-3)
    assert m["hellinger"] == pytest.approx(math.sqrt(0.5), abs=2e-3)
    assert m["ks"] == pytest.approx(0.5, abs=2e-3)
    assert m["mean_diff"] == pytest.approx(-0.5, abs=2e-3)
    assert compare(uniform(0, 1), uniform(0, 1))["L1"] == pytest.approx(0, abs=1e-12)


def test_gaussians_against_closed_forms():
    """N(0,1) against N(d,1): L1 = 2 (2 Phi(d/2) - 1), H^2 = 1 - exp(-d^2/8), KS = 2Phi(d/2)-1."""
    from scipy.stats import norm

    x = np.linspace(-12, 12, 20001)
    d = 0.7
    a = {"x": x, "p": norm.pdf(x)}
    b = {"x": x, "p": norm.pdf(x, loc=d)}
    m = compare(a, b)
    tv = 2 * norm.cdf(d / 2) - 1
    assert m["L1"] == pytest.approx(2 * tv, rel=1e-6)
    assert m["hellinger"] == pytest.approx(math.sqrt(1 - math.exp(-d * d / 8)), rel=1e-6)
    assert m["ks"] == pytest.approx(tv, rel=1e-4)
    assert m["mean_diff"] == pytest.approx(-d, abs=1e-9)


def test_histogram_noise_floor_matches_theory():
    """With Gaussian bin errors the L1 floor is sum sqrt(2/pi) se w (bootstrap: 400 draws,
    relative noise ~1/sqrt(400 n_bins))."""
    edges = np.linspace(0, 1, 51)
    w = np.diff(edges)
    se = np.full(50, 0.05)
    hist = {"x": 0.5 * (edges[1:] + edges[:-1]), "p": np.ones(50), "edges": edges, "err": se}
    m = compare({"x": np.linspace(0, 1, 11), "p": np.ones(11)}, hist)
    assert m["L1"] == pytest.approx(0.0, abs=1e-12)
    assert m["L1_floor"] == pytest.approx(np.sum(math.sqrt(2 / math.pi) * se * w), rel=0.03)
    assert m["ks_floor"] > 0 and m["hellinger_floor"] > 0


def test_bin_average_is_exact_for_piecewise_linear():
    x = np.linspace(0, 2, 5)
    d = {"x": x, "p": x / 2}  # density p = x / 2 on [0, 2]
    edges = np.array([0.0, 1.0, 2.0])
    np.testing.assert_allclose(bin_average(d, edges), [0.25, 0.75])


def test_two_histograms_need_the_same_edges():
    e1, e2 = np.linspace(0, 1, 5), np.linspace(0, 1, 6)
    h1 = {"x": e1[:-1], "p": np.ones(4), "edges": e1, "err": np.ones(4) * 0.1}
    h2 = {"x": e2[:-1], "p": np.ones(5), "edges": e2, "err": np.ones(5) * 0.1}
    with pytest.raises(ValueError, match="share their edges"):
        compare(h1, h2)


class _Collect(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tags: list[str] = []
        self.imgs: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        if tag == "img":
            self.imgs.append(dict(attrs)["src"])


def test_check_end_to_end(tmp_path: Path, capsys, canned_check, monkeypatch):
    """`vifpk check` from the command line to the report folder, on the canned tiny check.

    Issue 38: the command line dropped every RuntimeWarning of a run that ended finite. Three
    overflows and one invalid division raised during the (canned) check's computation are
    counted in metrics.json ``runtime_warnings``, and none is printed."""
    import warnings

    import vifpk.harness.workflows.check as check

    canned = check.cross_check

    def noisy(scene, **kw):
        with np.errstate(over="warn"):
            for _ in range(3):
                np.exp(np.array([1000.0]))
        warnings.warn("invalid value encountered in divide", RuntimeWarning, stacklevel=1)
        return canned(scene, **kw)

    monkeypatch.setattr(check, "cross_check", noisy)
    out = tmp_path / "rep"
    assert main(["check", TINY, "--out", str(out), "--quiet"]) == 0
    printed, err = capsys.readouterr()
    assert "overflow" not in printed + err
    got = json.loads((out / "metrics.json").read_text())["runtime_warnings"]
    assert [(w["category"], w["message"], w["count"]) for w in got] == [
        ("RuntimeWarning", "overflow encountered in exp", 3),
        ("RuntimeWarning", "invalid value encountered in divide", 1)], got
    assert all(w["where"].startswith("tests/test_harness.py:") for w in got), got
    assert "paper model: " in printed and "exact model: " in printed and "L1(A) =" in printed
    for name in ("report.html", "report.md", "metrics.json", "arrays.npz",
                 "figures/densities.png", "figures/decomposition.png"):
        assert (out / name).is_file(), name
    assert not list(out.glob(".partial-*"))
    m = json.loads((out / "metrics.json").read_text())
    for model in ("paper", "exact", "corrected"):
        for kind in ("averaging_error", "discretisation_error", "sampling_error"):
            for obs in ("A", "x1", "x2"):
                e = m["models"][model][kind][obs]
                for key in ("L1", "L1_floor", "hellinger", "ks"):
                    assert math.isfinite(e[key]), (model, kind, obs, key)
    assert m["scene"]["name"] == "tiny" and len(m["verdicts"]) == 3
    assert m["recommended_model"] in ("exact", "corrected", "none")  # public contract
    assert m["recommendation"].startswith("recommended model: ")
    assert m["recommendation"] in printed
    parser = _Collect()
    parser.feed((out / "report.html").read_text())
    assert "table" in parser.tags and len(parser.imgs) == 2
    assert all(src.startswith("data:image/png;base64,") for src in parser.imgs)  # offline
    with np.load(out / "arrays.npz") as z:
        assert "mc_original__A__err" in z and "closed_paper__A__p" in z


def test_interrupted_report_leaves_no_complete_looking_file(tmp_path: Path, monkeypatch,
                                                           canned_check, blank_figures):
    """Interrupted while writing report.html (report.md written in the partial folder): no
    file of the set in the folder. Figures blank (tests/conftest.py ``blank_png``): drawing
    them is not the subject."""
    from vifpk.harness.outputs import report

    def boom(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "render_html", boom)
    out = tmp_path / "rep"
    assert main(["check", TINY, "--out", str(out), "--quiet"]) == 130
    assert not (out / "metrics.json").exists() and not (out / "report.md").exists()
    assert not list(out.glob(".partial-*"))


def test_check_f_zero_is_a_clear_message(tmp_path: Path, capsys):
    assert main(["check", TINY, "--set", "system.f=0", "--out", str(tmp_path / "o"),
                 "--quiet"]) == 3
    err = capsys.readouterr().err
    assert "no stationary density" in err and not (tmp_path / "o").exists()


# ------------------------------------------------- which model to trust (issues 23 and 29)
def _canned(l1: dict[str, float], floor: float = 0.005, err: float = 0.002) -> dict:
    return {"models": {m: {"averaging_error": {"A": {"L1": v, "L1_floor": floor,
                                                     "L1_err": err}},
                           "sampling_ok": True} for m, v in l1.items()}}


VAL = {"wall": [0.05, 0.01, 0.0], "band": [2.0, 1.9, 1.8]}


def test_recommend_takes_the_model_within_the_tolerance():
    """Default tolerance L1(A) <= 0.02 at 95%: the model inside it with the lower error
    estimate, and the line names the tolerance."""
    from vifpk.harness.workflows.verdict import recommend

    m, line = recommend(_canned({"exact": 0.08, "corrected": 0.015}), [], VAL)
    assert m == "corrected" and line.startswith("recommended model: corrected -- within the")
    assert "L1(A) <= 0.02 at 95% confidence" in line
    m, _ = recommend(_canned({"exact": 0.012, "corrected": 0.06}), [], VAL)
    assert m == "exact"
    # a looser tolerance asked: both inside, the lower estimate wins
    loose = dict(_canned({"exact": 0.08, "corrected": 0.04}),
                 tolerance={"value": 0.1, "metric": "L1", "observable": "A",
                            "confidence": 0.95})
    m, line = recommend(loose, [], VAL)
    assert m == "corrected" and "<= 0.1 at 95%" in line


def test_recommend_within_the_noise_follows_the_wall_term_validity():
    """Both inside and their estimates within the floor: corrected unless its wall term is
    outside its derivation (delta/E above WALL_MAX at the 10% energy), then exact."""
    from vifpk.harness.workflows.assumptions import WALL_MAX
    from vifpk.harness.workflows.verdict import recommend

    tie = _canned({"exact": 0.011, "corrected": 0.013})
    assert recommend(tie, [], VAL)[0] == "corrected"
    m, line = recommend(tie, [], {"wall": [2 * WALL_MAX, 0.05, 0.01], "band": [0.7] * 3})
    assert m == "exact" and "energy-at-the-wall" in line


def test_recommend_none_only_when_no_model_is_within_the_tolerance():
    from vifpk.harness.workflows.verdict import recommend

    m, line = recommend(_canned({"exact": 0.01, "corrected": 0.01}), [], VAL,
                        convergence={"equilibrated": False})
    assert m == "none" and "not converged" in line
    m, line = recommend(_canned({"exact": 0.15, "corrected": 0.30}), [], VAL)
    assert m == "none" and "no model is within the tolerance" in line and "outside" in line


def test_failing_assumptions_are_advice_not_a_veto():
    """Issue 29: a strong-noise or narrow-band warning no longer vetoes a model whose measured
    error is small; the warning stays in the line as advice."""
    from vifpk.harness.workflows.verdict import recommend

    from vifpk.core.result import WarningRecord

    narrow = WarningRecord("narrow_band", "narrow-band noise: bandwidth alpha1 = 0.2 is 0.2-0.2 x "
                           "the oscillation frequency over the bulk of p(E)")
    m, line = recommend(_canned({"exact": 0.01, "corrected": 0.03}), [narrow], VAL)
    assert m == "exact" and "advice: narrow band" in line


def test_an_undecided_model_is_recommended_only_provisionally():
    """Estimate below the tolerance but not at 95%: named provisionally (P >= 1/2); a model
    more likely outside than inside is not."""
    from vifpk.harness.workflows.verdict import recommend

    m, line = recommend(_canned({"exact": 0.019, "corrected": 0.06}, err=0.004), [], VAL)
    assert m == "exact" and "provisionally" in line and "longer run" in line
    m, line = recommend(_canned({"exact": 0.026, "corrected": 0.06}, err=0.004), [], VAL)
    assert m == "none" and "exact undecided" in line


def test_advisory_warning_keeps_the_recommendation_and_the_estimate():
    """correlated noise is advisory: the verdict stays an estimate and a model is named."""
    from vifpk.harness.workflows.assumptions import ADVISORY
    from vifpk.harness.workflows.verdict import recommend, verdict_class

    from vifpk.core.result import WarningRecord

    w = WarningRecord("correlated_noise", "correlated noise: over one correlation time 1/alpha1 "
                      "the noise changes the energy")
    assert w.kind in ADVISORY
    m, line = recommend(_canned({"exact": 0.05, "corrected": 0.02}), [w], VAL)
    assert m == "corrected" and "correlated-noise regime" in line
    entry = {"averaging_error": {"A": {"L1": 0.05, "L1_floor": 0.01, "L1_err": 0.001}},
             "sampling_error": {"A": {"L1": 0.01, "L1_floor": 0.01}}, "sampling_ok": True}
    assert verdict_class(entry, [w])[0] == "small"


@pytest.mark.slow
def test_passage_splitting_door_gives_the_mfpt_layout():
    """harness.door.timedomain.passage_splitting: info["mfpt"] with value, stderr and a 95%
    interval that holds the value; default levels from the exact model's quartile and median, below
    the threshold."""
    from vifpk.harness.door.timedomain import passage_splitting

    from vifpk.core.scene import load_scene

    sc = load_scene("paper-base")
    r = passage_splitting(sc, threshold=0.9, start=0.4, groups=4, particles=30, levels=40,
                          paths=4, cycles=10)
    m = r.info["mfpt"]
    assert m["ci"][0] < m["value"] < m["ci"][1] and m["stderr"] > 0
    assert 0 < r.info["low"] < r.info["entry"] < 0.9
    assert "quantiles" in r.info["levels_source"]


def test_recommend_any_measured_model_by_its_error_not_its_name():
    """Issue 27/28: a check of the paper model alone, or of a plugin alone, crashed in
    recommend (min of an empty list); any model whose error is measured is a candidate, and
    among models tied within the noise the one with the most derived terms is preferred."""
    from vifpk.harness.workflows.verdict import recommend

    m, line = recommend(_canned({"paper": 0.5}), [], VAL)
    assert m == "none" and "paper 0.5" in line and "outside" in line
    m, line = recommend(_canned({"my-plugin": 0.004}), [], VAL)
    assert m == "my-plugin" and "within the tolerance" in line
    m, line = recommend(_canned({"paper": 0.010, "exact": 0.011, "my-plugin": 0.012}), [], VAL)
    assert m == "exact" and "agree within the noise" in line
    m, _ = recommend(_canned({"paper": 0.003, "exact": 0.016}), [], VAL)  # beyond the floor
    assert m == "paper"


@pytest.mark.slow
def test_passage_splitting_door_stationary_start_says_its_burn_in():
    from vifpk.harness.door.timedomain import passage_splitting

    from vifpk.core.scene import load_scene

    sc = load_scene("paper-base")
    r = passage_splitting(sc, threshold=0.9, start="stationary", groups=3, particles=20,
                          levels=30, paths=4, cycles=6)
    assert r.info["burn_in"] > 0 and "relaxation time" in r.info["burn_in_rule"]
    assert r.info["mfpt"]["value"] > 0


@pytest.mark.slow
def test_cli_passage_method_splitting_writes_the_mfpt(tmp_path):
    """vifpk passage --method splitting: metrics.json with the original system's MFPT by
    splitting (value, stderr, 95% interval within 10% or the budget said), each model's
    MFPT and relative error, and report.md."""
    out = tmp_path / "p"
    code = main(["passage", "paper-base", "--threshold", "0.9", "--start", "0.4", "--method",
                 "splitting", "--out", str(out), "--quiet"])
    assert code == 0
    met = json.loads((out / "metrics.json").read_text())
    o = met["mfpt"]["original_system"]
    assert met["method"] == "splitting" and o["method"] == "splitting"
    assert o["ci"][0] < o["value"] < o["ci"][1]
    assert "reached" in met["splitting"]["target"]
    assert set(met["models"]) >= {"exact"} and "mfpt_error" in met["models"]["exact"]
    assert (out / "report.md").exists()



def test_runtime_warnings_key_says_whether_they_were_recorded(canned_check):
    """metrics.json has ``runtime_warnings`` when the run's warnings were recorded (an empty
    list: none raised), no key when they were not (a report written from the Python API),
    and it comes before ``timings`` and ``provenance`` (the machine-dependent tail)."""
    from vifpk.harness.outputs.report import metrics_document
    from vifpk.harness.outputs.runwarnings import RunWarnings

    tally = RunWarnings()
    with tally.recording():
        pass
    assert tally.records() == [] and tally.first() == ""
    assert "runtime_warnings" not in metrics_document(canned_check, {})
    doc = metrics_document(canned_check, {}, tally.records())
    assert doc["runtime_warnings"] == [] and list(doc)[-3:] == ["runtime_warnings", "timings",
                                                                 "provenance"]


def test_drawing_changes_no_matplotlib_state_and_closes_on_every_path(monkeypatch):
    """Issue 38: vifpk/core/io.py called matplotlib.use("Agg") on every plot (a notebook
    user's backend switched by a library call) and left a figure open when savefig raised.
    Figures are drawn on their own Agg canvas: matplotlib.use is never called, pyplot never
    imported by it (tests/test_layers.py scans for both); png_bytes closes a (pyplot) figure
    even when savefig raises."""
    import matplotlib

    from vifpk.core.io import figures, png_bytes

    def refuse(*a, **k):
        raise AssertionError("matplotlib.use called")

    monkeypatch.setattr(matplotlib, "use", refuse)
    fig, ax = figures().subplots(1, 2, figsize=(2, 1))
    ax[0].plot([0, 1], [0, 1])
    assert png_bytes(fig, text={"vifpk run id": "x"}).startswith(b"\x89PNG")
    import matplotlib.pyplot as plt

    opened = plt.figure()

    def broken(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(opened, "savefig", broken)
    with pytest.raises(OSError, match="disk full"):
        png_bytes(opened)
    assert opened.number not in plt.get_fignums()
