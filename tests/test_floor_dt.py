"""The time step follows the accuracy asked for (issue 22; issue 44 made it the default): with
no step given, dt is "auto", with or without a target floor; a step given on the command line,
by --set, in the scene file or in a sweep pins it."""

from __future__ import annotations

import argparse

from vifpk.harness.cli.options import _checked_scene
from vifpk.harness.sweeps.spec import load_sweep


def _args(**kw):
    d = dict(scene="paper-base", set=[], paths=None, dt=None, time=None, seed=None,
             floor=None, budget=None)
    d.update(kw)
    return argparse.Namespace(**d)


def test_the_step_follows_the_floor_unless_pinned(tmp_path):
    assert _checked_scene(_args(floor=0.005), mc=True).montecarlo.dt == "auto"
    assert _checked_scene(_args(), mc=True).montecarlo.dt == "auto"  # no floor: auto too
    assert _checked_scene(_args(floor=0.005, dt=0.02), mc=True).montecarlo.dt == 0.02
    pinned = _args(floor=0.005, set=["montecarlo.dt=0.02"])
    assert _checked_scene(pinned, mc=True).montecarlo.dt == 0.02
    scene = tmp_path / "s.toml"
    scene.write_text('[montecarlo]\ndt = 0.005\nfloor = 0.01\n')
    assert _checked_scene(_args(scene=str(scene)), mc=True).montecarlo.dt == 0.005
    scene.write_text('[montecarlo]\nfloor = 0.01\n')  # a floor in the file, no step
    assert _checked_scene(_args(scene=str(scene)), mc=True).montecarlo.dt == "auto"


def test_a_sweep_with_a_floor_follows_it_too(tmp_path):
    (tmp_path / "a.toml").write_text('scene = "paper-base"\n[vary]\n"system.r" = [0.95]\n'
                                     '[set]\n"montecarlo.floor" = 0.02\n')
    (tmp_path / "b.toml").write_text('scene = "paper-base"\n[vary]\n"system.r" = [0.95]\n'
                                     '[set]\n"montecarlo.floor" = 0.02\n'
                                     '"montecarlo.dt" = 0.01\n')
    (tmp_path / "c.toml").write_text('scene = "paper-base"\n[vary]\n"system.r" = [0.95]\n')
    assert load_sweep(tmp_path / "a.toml").points[0].scene.montecarlo.dt == "auto"
    assert load_sweep(tmp_path / "c.toml").points[0].scene.montecarlo.dt == "auto"
    assert load_sweep(tmp_path / "b.toml").points[0].scene.montecarlo.dt == 0.01
