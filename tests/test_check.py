"""harness/workflows/check.py: a model's measured error belongs to the model (issue 29, item 0).

The simulation of the original system must not know which models are checked: its ranges,
burn-in, extensions and seeds, and each averaged SDE's seed and extensions, depend on the scene
and the model's own name only. So the same seed gives bit-identical numbers for ``exact``
whatever else is in the list: built-in models in any order, and a plugin (the example of
docs/plugins.md, registered in-process as an installed distribution would register it).
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import ROOT
from vifpk.core import registry

PLUGIN = ROOT / "docs" / "examples" / "plugin"


@pytest.fixture
def white_envelope(monkeypatch):
    """The example plugin ``white-envelope`` registered in this process."""
    monkeypatch.syspath_prepend(str(PLUGIN))
    own, conflicts = registry._entries()
    entry = registry.ModelEntry("white-envelope", "vifpk_white_envelope:WhiteNoiseEnvelope",
                                "vifpk-white-envelope")
    monkeypatch.setattr(registry, "_entries", lambda: ((*own, entry), conflicts))
    return entry.name


def test_the_sde_seed_follows_the_name_not_the_place():
    from vifpk.harness.workflows.checkruns import sde_seed

    assert sde_seed(7, "exact") == sde_seed(7, "exact")
    seeds = {sde_seed(7, m) for m in ("paper", "exact", "corrected", "white-envelope")}
    assert len(seeds) == 4 and sde_seed(8, "exact") != sde_seed(7, "exact")


@pytest.mark.slow
def test_exact_is_measured_the_same_whatever_else_is_checked(white_envelope):
    """Four model lists, one seed, an automatic burn-in (the relaxation pilot starts from the
    scale pilot's amplitude, which used to follow the models' supports): every number of
    ``exact`` (averaging and sampling errors, all observables and metrics) and the simulation
    itself (edges, densities, burn-in) are bit-identical. The plugin's support (2.3) is far
    beyond the others' (1.3-1.6): it used to stretch the range of every histogram."""
    from vifpk.harness.workflows.check import cross_check

    from vifpk.core.scene import load_scene

    # a budget of 1 ms: no extension (they are the model's own business, tested apart)
    scene = load_scene(ROOT / "scenes" / "paper-base.toml").with_values(
        {"montecarlo.paths": 64, "montecarlo.blocks": 16, "montecarlo.time": 200.0,
         "montecarlo.bins": 40, "montecarlo.budget": 0.001})
    lists = [("exact",), ("paper", "exact", "corrected"), ("corrected", "exact"),
             (white_envelope, "exact")]
    runs = [cross_check(scene, quiet=True, fpk=False, models=ms) for ms in lists]
    ref = runs[0]
    for ms, res in zip(lists[1:], runs[1:], strict=True):
        assert res.metrics["models"]["exact"]["averaging_error"] == \
            ref.metrics["models"]["exact"]["averaging_error"], ms
        assert res.metrics["models"]["exact"]["sampling_error"] == \
            ref.metrics["models"]["exact"]["sampling_error"], ms
        assert res.metrics["monte_carlo"]["settings"] == ref.metrics["monte_carlo"]["settings"]
        for key in ("mc:original", "mc:exact"):
            for obs in ("A", "x1", "x2"):
                a, b = ref.solutions[key].data[obs], res.solutions[key].data[obs]
                assert np.array_equal(a["edges"], b["edges"]) and np.array_equal(a["p"], b["p"])
    assert ref.metrics["monte_carlo"]["settings"]["burn_in_mode"] == "auto"
    # the binning-free distance is reported beside L1, with its floor and error bar
    e = ref.metrics["models"]["exact"]["averaging_error"]["A"]
    assert e["w1"] >= 0 and e["w1_floor"] > 0 and e["w1_err"] > 0


@pytest.mark.slow
def test_check_tolerance_verdict_end_to_end(tmp_path, capsys, canned_check, blank_figures):
    """`vifpk check --tolerance`: metrics.json keeps every old key and adds per model the
    tolerance verdict (estimate, interval, P, class), the question asked, and a recommendation
    that names it; a tolerance out of range exits 2 before any work. Figures blank
    (tests/conftest.py ``blank_png``): the tolerance does not draw."""
    import json

    from vifpk.harness.cli.app import main

    tiny = str(ROOT / "tests" / "data" / "tiny.toml")
    out = tmp_path / "rep"
    assert main(["check", tiny, "--out", str(out), "--quiet", "--tolerance", "0.05",
                 "--tolerance-metric", "w1"]) == 0
    printed = capsys.readouterr().out
    m = json.loads((out / "metrics.json").read_text())
    assert m["tolerance"] == {"value": 0.05, "metric": "w1", "observable": "A",
                              "confidence": 0.95}
    for model in ("paper", "exact", "corrected"):
        v = m["models"][model]["tolerance"]
        assert v["class"] in ("inside", "outside", "undecided")
        assert 0 <= v["p_within_tolerance"] <= 1 and v["error_estimate"] >= 0
        lo, hi = v["error_estimate_ci"]
        assert lo <= v["error_estimate"] <= hi
        assert "verdict_class" in m["models"][model] and "averaging_error" in m["models"][model]
    assert "w1(A) <= 0.05 at 95% confidence" in m["recommendation"]
    assert "error estimate" in printed and m["recommendation"] in printed
    assert "Tolerance verdict" in (out / "report.md").read_text()
    for bad in (["--tolerance", "-1"], ["--tolerance-metric", "L2"], ["--confidence", "1"]):
        assert main(["check", tiny, "--out", str(tmp_path / "no"), "--quiet", *bad]) == 2
        assert "--" in capsys.readouterr().err and not (tmp_path / "no").exists()
