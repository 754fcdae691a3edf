"""README and docs/report.md numbers: written by docs/scripts/doc_numbers.py from a recorded run
(docs/numbers.json), and that run agrees with a fresh small run within the stated noise."""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _script():
    spec = importlib.util.spec_from_file_location("numbers_script",
                                                  ROOT / "docs" / "scripts" / "doc_numbers.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _recorded() -> dict:
    return json.loads((ROOT / "docs" / "numbers.json").read_text())


def test_marked_blocks_are_what_the_recorded_run_renders():
    assert _script().stale(_recorded()) == []


@pytest.mark.slow
def test_readme_headline_numbers_agree_with_a_fresh_small_run():
    """The README's L1(A) of both models (2 decimals) against a fresh run with 256 paths x 500
    time units. Tolerance: each measured L1 is within its noise of the true one (triangle
    inequality: |L1(p, q*) - L1(p, q)| <= L1(q, q*), whose mean is the noise floor; 2 x the floor
    covers its spread), so the two runs agree within 2 x (floor_small + floor_recorded), plus
    0.005 for the README's rounding to 2 decimals."""
    from vifpk.harness.workflows.check import cross_check

    from vifpk.core.scene import load_scene

    readme = (ROOT / "README.md").read_text()
    block = re.search(r"<!-- numbers:finding -->(.*?)<!-- /numbers:finding -->", readme, re.S)
    assert block, "README has no numbers:finding block"
    text = " ".join(block.group(1).split())
    paper = float(re.search(r"off by L1 = ([0-9.]+) in p\(A\)", text).group(1))
    exact = float(re.search(r"kept is off by ([0-9.]+)", text).group(1))
    rec = _recorded()["models"]
    scene = load_scene(ROOT / "scenes" / "paper-base.toml").with_values(
        {"montecarlo.paths": 256, "montecarlo.time": 500.0, "montecarlo.budget": 1.0})
    res = cross_check(scene, quiet=True)
    for m, shown in (("paper", paper), ("exact", exact)):
        e = res.metrics["models"][m]["averaging_error"]["A"]
        tol = 2 * (e["L1_floor"] + rec[m]["L1_floor"]) + 0.005
        assert abs(e["L1"] - shown) <= tol, (m, e["L1"], shown, tol)


@pytest.mark.parametrize("name", ["finding", "verdicts", "check-time"])
def test_readme_has_every_generated_block(name):
    assert f"<!-- numbers:{name} -->" in (ROOT / "README.md").read_text()
