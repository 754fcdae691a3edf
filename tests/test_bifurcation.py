"""The P-bifurcation finder against the closed form for alpha = 0, and the command."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from vifpk.harness.cli.app import main
from vifpk.harness.workflows.bifurcation import critical_value, mc_shape, with_param

from tests.conftest import ROOT, vary


def mu_critical(c1: float, c2: float, w0: float, loss: float) -> float:
    """alpha = 0: h' ~ A [(w0^2/2) A (c - c2 A^2/4) - 2 mu w0/pi] (energy form) changes sign
    when mu = (pi w0 c / 6) sqrt(4c / (3 c2)), c = c1 - impact loss rate."""
    c = c1 - loss
    return math.pi * w0 * c / 6 * math.sqrt(4 * c / (3 * c2))


@pytest.mark.parametrize(("model", "r"), [("paper", 1.0), ("paper", 0.98), ("exact", 0.98)])
def test_critical_mu_matches_closed_form(base, model, r):
    sc = vary(base, alpha=0.0, r=r)
    loss = (1 - r * r) / math.pi if model == "exact" else 2 * (1 - r) / math.pi
    expect = mu_critical(0.025, 0.05, 1.0, loss)
    got = critical_value(sc, model, "mu", 0.0, 0.05)
    # the max of h' is taken on the 801-point grid: relative error ~(h/A*)^2 ~ 1e-5
    assert got == pytest.approx(expect, rel=1e-4)


def test_no_root_in_range_is_none(base):
    assert critical_value(vary(base, alpha=0.0, r=1.0), "paper", "mu", 0.02, 0.05) is None


def test_paper_model_reproduces_the_papers_critical_r(base):
    """Section 5.2: P-bifurcation near r = 0.968 at mu = 0.001 (our paper model: 0.9681)."""
    # the paper prints 3 decimals: 5e-4 is the precision of its claim
    assert critical_value(base, "paper", "r", 0.9, 1.0) == pytest.approx(0.968, abs=5e-4)


@pytest.mark.slow
def test_mc_shape_sees_crater_and_peak(base):
    small = {"montecarlo.paths": 128, "montecarlo.blocks": 16, "montecarlo.time": 400.0}
    crater = mc_shape(with_param(base, "r", 0.995).with_values(small))
    peak = mc_shape(with_param(base, "r", 0.94).with_values(small))
    assert crater["shape"] == "crater" and peak["shape"] == "single peak"


def test_bifurcation_command_json(tmp_path: Path, capsys):
    out = tmp_path / "b.json"
    assert main(["bifurcation", str(ROOT / "scenes" / "paper-base.toml"), "--vary", "r",
                 "--no-mc", "--json", str(out), "--quiet"]) == 0
    d = json.loads(out.read_text())
    assert d["vary"] == "r" and set(d["critical"]) == {"paper", "exact"}
    assert d["provenance"]["command"].startswith("vifpk bifurcation")  # issue 13.2
    assert 0.96 < d["critical"]["paper"] < 0.975
    assert "critical r" in capsys.readouterr().out


@pytest.mark.slow
def test_bifurcation_command_takes_the_corrected_model(tmp_path: Path, base):
    """--model picks the models (issue 15: the corrected model too); its critical r is a sign
    change of its own shape index F, checked 1e-4 either side of the root (brentq's xtol is
    1e-6; the exact model's root, 0.96867, is 9.6e-4 away, so it would fail this check)."""
    from vifpk.harness.workflows.bifurcation import shape_index

    out = tmp_path / "b.json"
    assert main(["bifurcation", "paper-base", "--vary", "r", "--range", "0.96", "0.98",
                 "--model", "corrected", "--no-mc", "--json", str(out), "--quiet"]) == 0
    crit = json.loads(out.read_text())["critical"]
    assert set(crit) == {"corrected"}
    c = crit["corrected"]
    assert shape_index(with_param(base, "r", c - 1e-4), "corrected") < 0
    assert shape_index(with_param(base, "r", c + 1e-4), "corrected") > 0


def test_mc_checks_sit_on_both_sides_of_each_critical_value_never_at_the_ends():
    from vifpk.harness.workflows.bifurcation import check_points

    # the paper's critical mu at the base scene is 0.0025, close to the range's lower end 0
    pts = check_points([0.0025, None], 0.0, 0.05, 0.1)
    assert len(pts) == 2 and pts[0] < 0.0025 < pts[1]
    assert 0.0 < pts[0] and pts[1] < 0.05
    # two critical values far apart: four points, two around each
    pts = check_points([0.91, 0.97], 0.9, 1.0, 0.1)
    assert len(pts) == 4 and pts[0] < 0.91 < pts[1] <= pts[2] < 0.97 < pts[3] < 1.0


def test_bifurcation_names_fixed_parameters_and_flags_disagreement(base, monkeypatch):
    """The output names what is held fixed, and a Monte Carlo shape that contradicts a model's
    prediction is flagged in words (the MC is replaced by a stub that always sees a crater, to
    test the wording, not the physics)."""
    import vifpk.harness.workflows.bifurcation as B

    monkeypatch.setattr(B, "mc_shape", lambda s: {"shape": "crater", "max_rise_in_se": 9.0,
                                                  "bins_used": 50})
    res = B.bifurcation(base, "r", lo=0.9, hi=1.0, models=("paper",))
    assert res["fixed"]["mu"] == base.system.mu and "r" not in res["fixed"]
    below = [c for c in res["mc_check"] if c["value"] < res["critical"]["paper"]]
    assert below and all(c["predicted"]["paper"] == "single peak" for c in below)
    assert all(c["agrees"]["paper"] is False and "DISAGREES with the paper model" in c["words"]
               for c in below)
    assert "DISAGREES" in res["mc_disagreement"] and "paper model predicts a single peak" in \
        res["mc_disagreement"]


def test_bifurcation_says_when_the_paper_claim_holds_other_parameters(base):
    """The paper's critical mu is at r = 0.975; the base scene holds r = 0.96: said in words."""
    import vifpk.harness.workflows.bifurcation as B

    res = B.bifurcation(base, "mu", models=("paper",), mc=False)
    assert res["paper_claim_fixed"] == {"r": 0.975}
    assert res["paper_claim_comparable"] is (base.system.r == 0.975)
    if base.system.r != 0.975:
        assert f"this run holds r = {base.system.r:g}" in res["paper_claim_note"]
        assert "--set system.r=0.975" in res["paper_claim_note"]
