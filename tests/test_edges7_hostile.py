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
    from vifpk.core.result import BadInput
    from vifpk.core.scene import load_scene
    from vifpk.harness.workflows.bifurcation import bifurcation

    with pytest.raises(BadInput, match="--vary r"):
        bifurcation(load_scene(BD), "r", mc=False)
