"""The Monte Carlo's default step (issue 44): a scene that gives no dt runs at the step rule's
step ("auto": montecarlo/tuning.py, the largest step whose predicted bias is half the target
floor, DEFAULT_FLOOR without one), with its run-time step check; a scene that gives a dt runs
at it as written. Small runs (64 paths, 64 time units): the kernels are the fast tier's."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from vifpk.harness.cli.app import main
from vifpk.montecarlo.plan import physics, step_size

import vifpk
from vifpk.core.sections import FIXED_DT, MonteCarloSettings

SMALL = ["--paths", "64", "--time", "64", "--set", "montecarlo.blocks=16",
         "--set", "montecarlo.burn_in=20", "--allow-unequilibrated"]


def _solve(tmp_path: Path, scene: str, *extra: str) -> dict:
    out = tmp_path / "mc.json"
    assert main(["solve", scene, "--solver", "montecarlo", *SMALL, *extra, "--json",
                 str(out)]) == 0
    return json.loads(out.read_text())["info"]


def test_the_default_step_is_the_rules(tmp_path):
    assert MonteCarloSettings().dt == "auto"
    info = _solve(tmp_path, "paper-base")
    st, rule = info["settings"], info["dt_rule"]
    assert st["dt_mode"] == "auto"
    sc = vifpk.scene("paper-base")
    # the rule's step at the scale pilot's amplitude, with no target floor (DEFAULT_FLOOR)
    want = step_size("auto", 0.0, physics(sc.system, sc.noise), sc.montecarlo.sample_every,
                     rule["amplitude"])
    assert st["dt"] == want
    assert st["dt"] != FIXED_DT  # not the old fixed default (0.038 on paper-base)
    assert "dt_check" in info  # the run-time step check runs with it


@pytest.mark.parametrize("how", ["file", "set"])
def test_a_step_the_scene_gives_stays_as_written(tmp_path, how):
    if how == "file":
        f = tmp_path / "s.toml"
        f.write_text((Path(__file__).parents[1] / "scenes" / "paper-base.toml").read_text()
                     + "\n[montecarlo]\ndt = 0.025\n")
        info = _solve(tmp_path, str(f))
    else:
        info = _solve(tmp_path, "paper-base", "--set", "montecarlo.dt=0.025")
    assert info["settings"]["dt"] == 0.025 and info["settings"]["dt_mode"] == "fixed"
    assert "dt_rule" not in info
