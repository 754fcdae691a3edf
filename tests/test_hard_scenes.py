"""The hard scenes of scenes/hard/: finite normalised densities, and the report says in words
when an averaging assumption fails. The cross-checks here run reduced Monte Carlo settings;
the full default-size check of every hard scene (minutes each) is a validation run,
benchmarks/validate_hard_scenes.py, whose results docs/report.md quotes."""

from __future__ import annotations

from pathlib import Path

import pytest
from vifpk.averaging import solve
from vifpk.harness.cli.app import main
from vifpk.harness.workflows.assumptions import WARNING_KINDS, assumption_warnings
from vifpk.harness.workflows.check import cross_check, output_problems

from tests.conftest import ROOT
from vifpk.core.scene import load_scene

HARD = sorted((ROOT / "scenes" / "hard").glob("*.toml"))
# What the warnings must say (one keyword a failed assumption). Each expectation comes from a
# back-of-envelope number independent of check.py's code ("strong damping": the energy lost or
# fed per period exceeds half of E; with x = |y| a y-period holds 2 impacts and 4A of travel):
# - alpha1-narrow: the scene's purpose: alpha1 = 0.05 against an oscillation frequency ~1;
# - c1-strong: on the limit cycle (A ~ 3.4, T ~ 2.5) the linear feed c1 <v^2> ~ c1 E and the
#   cubic damping each move ~c1 T E = 0.5 E per period, together ~E > E/2;
# - r-low: two impacts per period keep r^4 = 0.008 of E: 0.99 E lost > E/2;
# - mu-large, D-tiny, alpha1-wide: friction does 4 mu A of work per period against
#   E ~ A^2/2, i.e. 8 mu / A of E: > 1/2 below A = 16 mu; the closed forms' mean amplitudes
#   are 0.0077 (mu = 0.2: 208 E), 0.0015 and 0.0016 (mu = 0.001: ~5 E);
# - D-large: the scene's purpose: D = 1, 100x the base scene's noise, which moves the mass to
#   where cubic damping is strong: the strong-noise condition (sigma_E^2 T / E^2 = 0.80 at the
#   mean amplitude) is named after the losses that account for it (issue 45: strong
#   dissipation, mostly cubic damping); halving every loss lowers it to 0.52, halving D to 0.61
#   (closed forms, measured);
# - alpha-stiff, r-elastic, white: none of those numbers is near its limit (base-like scenes).
EXPECTED = {
    "alpha1-narrow": ["narrow-band"], "c1-strong": ["strong damping"],
    "r-low": ["strong damping"], "mu-large": ["strong damping"],
    "D-large": ["strong dissipation"], "D-tiny": ["strong damping"],
    "alpha1-wide": ["strong damping"], "alpha-stiff": [], "r-elastic": [], "white": [],
}


def test_there_are_enough_hard_scenes():
    names = {p.stem for p in HARD}
    assert len(names - {"no-noise"}) >= 10 and "no-noise" in names
    assert set(EXPECTED) <= names


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_assumption_warnings(name):
    scene = load_scene(ROOT / "scenes" / "hard" / f"{name}.toml")
    closed = {"exact": solve(scene, model="exact")}
    warnings = assumption_warnings(scene, closed, {})
    # every warning is a record of a known kind, and the expected keywords are among the kinds
    kinds = {w.kind for w in warnings}
    assert kinds <= set(WARNING_KINDS)
    assert {k.replace(" ", "_").replace("-", "_") for k in EXPECTED[name]} <= kinds
    text = " ".join(w.text for w in warnings)
    for key in EXPECTED[name]:
        assert key in text, warnings
    if not EXPECTED[name]:
        assert warnings == []


def test_base_scene_has_no_warning():
    scene = load_scene(ROOT / "scenes" / "paper-base.toml")
    assert assumption_warnings(scene, {"exact": solve(scene, model="exact")}, {}) == []


def test_sticking_is_reported_from_the_simulation():
    scene = load_scene(ROOT / "scenes" / "paper-base.toml")
    warnings = assumption_warnings(scene, {"exact": solve(scene, model="exact")},
                                   {"events": {"stuck_fraction": {"value": 0.5}}})
    assert any("sticking-dominated" in w.text for w in warnings)
    assert "sticking" in {w.kind for w in warnings}


@pytest.mark.slow
def test_unconverged_simulation_is_reported():
    """Too short a burn-in at D = 1e-5: check's own evidence (the certificate, the averaged-SDE
    runs against their closed forms) sees it. With a budget it extends the Monte Carlo until the
    evidence passes; with no budget left the verdict says the simulation has not converged."""
    scene = load_scene(ROOT / "scenes" / "hard" / "D-tiny.toml").with_values(
        {"montecarlo.paths": 32, "montecarlo.blocks": 16, "montecarlo.time": 20.0,
         "montecarlo.burn_in": 10.0})
    # the FPK plays no part in the convergence evidence: skipped (fpk=False)
    result = cross_check(scene, quiet=True, fpk=False)
    conv = result.metrics["monte_carlo"]["convergence"]
    assert conv["extensions"] >= 1
    assert conv["equilibrated"] or all("has not converged" in v for v in result.verdicts)
    tight = cross_check(scene.with_values({"montecarlo.budget": 1e-3}), quiet=True, fpk=False)
    conv = tight.metrics["monte_carlo"]["convergence"]
    assert conv["extensions"] == 0 and conv["equilibrated"] is False and conv["reason"]
    assert all("the simulation has not converged" in v for v in tight.verdicts)


def test_no_noise_scene_is_a_clear_message(tmp_path: Path, capsys):
    assert main(["check", str(ROOT / "scenes/hard/no-noise.toml"), "--out", str(tmp_path / "o"),
                 "--quiet"]) == 3
    assert "no stationary density" in capsys.readouterr().err


@pytest.mark.slow
@pytest.mark.parametrize("name", ["alpha1-narrow", "r-low", "D-tiny"])
def test_hard_scene_cross_check_small(name):
    scene = load_scene(ROOT / "scenes" / "hard" / f"{name}.toml")
    scene = scene.with_values({"montecarlo.paths": 64, "montecarlo.blocks": 16,
                               "montecarlo.time": 100.0})
    result = cross_check(scene, quiet=True)
    assert output_problems(result) == []
    assert result.warnings and all("NOT an estimate" in v for v in result.verdicts)
