"""Issue 39 item 6 (docs/edges.md round 7b, docs/scripts/hostile7.py): hostile cases on the
walls, the parametric noise and the typed time-domain requests that were not handled before
this round, run in-process (``main([...])``); each fails on the code before its fix. Fast:
every case is refused before any solver runs."""

from __future__ import annotations

import pytest
from vifpk.harness.cli.app import main

BD = "systems/bilateral-duffing"


@pytest.mark.parametrize("args, code, words", [
    # H009: a wall whose spring energy overflows a float failed in the solver (exit 3,
    # "(34, 'Numerical result out of range')") instead of being refused
    (["solve", BD, "--model", "exact", "--set", "system.lower_wall.at=-1e300"], 2,
     ("system.lower_wall.at = -1e+300", "energy", "overflows")),
    (["solve", BD, "--model", "exact", "--set", "system.upper_wall.at=1e100"], 2,
     ("system.upper_wall.at = 1e+100", "overflows")),
    # bifurcation --vary r on a scene whose walls are tables (or with no wall) varied nothing
    # (dataclasses.replace(system, r=...) is undone by System.__post_init__) and printed
    # "critical r = none in 0.9 to 1", exit 0
    (["bifurcation", BD, "--vary", "r", "--no-mc", "--quiet"], 2,
     ("--vary r", "system.lower_wall, system.upper_wall", "--vary mu")),
    (["bifurcation", "paper-base", "--set", "system.barrier=false", "--vary", "r", "--no-mc",
      "--quiet"], 2, ("--vary r", "barrier = false")),
    # H191, H192: a systems/ scene named without its folder got the list of the shipped
    # scenes without the systems/ ones (no way to learn the name)
    (["check", "bilateral-duffing"], 2, ("did you mean 'systems/bilateral-duffing'?",)),
    (["passage", "offset-parametric", "--threshold", "0.5"], 2,
     ("did you mean 'systems/offset-parametric'?",)),
    # H116: --at beyond a given --horizon was accepted and the run went on (R(T) of the
    # original system is not measured past the horizon)
    (["passage", BD, "--set", "parametric.stiffness=0", "--paths", "64", "--threshold", "0.5",
      "--horizon", "100", "--at", "200"], 2, ("--at 200: beyond --horizon 100",)),
])
def test_hostile7_refusals(capsys, args, code, words):
    assert main(args) == code
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    for w in words:
        assert w in err, err


def test_a_far_wall_of_finite_energy_is_still_a_scene():
    """The new check refuses only an overflowing energy: a wall at -1e50 (U = 1.25e199 for
    k = [1, 0.5]) stays a valid scene (it bounds nothing the averaged models reach)."""
    from vifpk.core.scene import load_scene

    s = load_scene(BD).with_values({"system.lower_wall.at": -1e50})
    assert s.system.walls[0].at == -1e50


def test_the_bifurcation_workflow_refuses_r_on_wall_tables_from_python():
    """The same refusal from the workflow function (vifpk.run("bifurcation", ...)), before
    any search."""
    from vifpk.harness.workflows.bifurcation import bifurcation

    from vifpk.core.result import BadInput
    from vifpk.core.scene import load_scene

    with pytest.raises(BadInput, match="--vary r"):
        bifurcation(load_scene(BD), "r", mc=False)


SWEEP = """scene = "systems/bilateral-duffing"
workflow = "check"
models = ["exact"]
[vary]
{vary}
[set]
{set}
"montecarlo.paths" = 64
"""


@pytest.mark.parametrize("vary, set_, words", [
    # H147, H150, H151, H164: every wall key was "unknown key; did you mean
    # 'system.upper_wall'?" in [vary] and [set], though --set takes them
    ('"system.upper_wall.r" = [0.9, 1.1]', "", "at the point system.upper_wall.r = 1.1"),
    ('"system.upper_wall.at" = [-0.2, 0.5]', "", "upper_wall.at = -0.2 is out of range"),
    ('"system.upper_wall.rr" = [0.9, 1.0]', "", "did you mean 'system.upper_wall.r'?"),
    ('"system.lower_wall.law" = [1, 2]', "", "only numeric parameters can vary"),
    ('"system.upper_wall.r" = [0.9, 0.95]', '"system.lower_wall.law" = "hertz"',
     "impact law must be one of"),
])
def test_sweeps_take_wall_keys_and_check_every_point(tmp_path, vary, set_, words):
    from vifpk.harness.sweeps.errors import SweepError
    from vifpk.harness.sweeps.spec import load_sweep

    p = tmp_path / "s.toml"
    p.write_text(SWEEP.format(vary=vary, set=set_))
    with pytest.raises(SweepError) as e:
        load_sweep(p)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_a_sweep_over_a_wall_key_builds_each_point_with_that_wall(tmp_path):
    """The points' scenes carry the varied wall (not the shipped one): the sweep moves the
    physics (the same scene as --set system.upper_wall.r=...)."""
    from vifpk.harness.sweeps.spec import load_sweep

    from vifpk.core.scene import load_scene

    p = tmp_path / "s.toml"
    p.write_text(SWEEP.format(vary='"system.upper_wall.r" = [0.9, 0.95]',
                              set='"system.lower_wall.at" = -0.5'))
    sw = load_sweep(p)
    assert [pt.params for pt in sw.points] == [(("system.upper_wall.r", 0.9),),
                                               (("system.upper_wall.r", 0.95),)]
    base = load_scene("systems/bilateral-duffing")
    want = base.with_values({"system.lower_wall.at": -0.5, "system.upper_wall.r": 0.95})
    assert sw.points[1].scene.system == want.system
