"""Issue 28 (edges, round 5): output paths that collide with inputs, one rule for two
spellings of a coefficient in sweeps and on the command line, plugins that misbehave, whole
numbers too large to run, signals, progress into files.

Like tests/test_edges.py, the bad-input catalogue runs in-process with every entry point of
real work replaced by one that fails the test (``no_computation``): the input must be refused
first, in one line, exit 2, with nothing written.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from vifpk.core import registry

from .conftest import ROOT

DATA = ROOT / "tests" / "data"
SCENE = 'name = "s"\n[system]\nr = 0.95\n'
SWEEP = 'scene = "tiny"\nworkflow = "averaging"\n[vary]\n"system.r" = [0.95, 0.97]\n'


def _write(folder: Path, name: str, text: str) -> Path:
    p = folder / name
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(text)
    return p


def _plugin(folder: Path, monkeypatch: pytest.MonkeyPatch, source: str,
            name: str = "mine", module: str = "vifpk_edge_plugin") -> Path:
    """A model plugin registered in-process: ``module.py`` in ``folder`` on sys.path and an
    entry ``name = module:build`` from the distribution 'edge-plugin'."""
    path = _write(folder, f"{module}.py", source)
    monkeypatch.syspath_prepend(str(folder))
    entry = registry.ModelEntry(name, f"{module}:build", "edge-plugin")
    builtin = tuple(e for e in registry.models() if e.builtin)
    monkeypatch.setattr(registry, "_entries", lambda: ((*builtin, entry), ()))
    return path


# ------------------------------------------------------------- outputs that are inputs
def _collisions() -> list[tuple[str, Callable[..., list[str]], str]]:
    def solve_json_is_scene(tmp: Path, mp) -> list[str]:
        _write(tmp, "s.toml", SCENE)
        return ["solve", "s.toml", "--json", "s.toml"]

    def solve_json_other_spelling(tmp: Path, mp) -> list[str]:
        _write(tmp, "s.toml", SCENE)
        return ["solve", "./s.toml", "--json", str(tmp / ".." / tmp.name / "s.toml")]

    def solve_json_through_a_link(tmp: Path, mp) -> list[str]:
        _write(tmp, "s.toml", SCENE)
        (tmp / "d").mkdir()
        (tmp / "d" / "link").symlink_to(tmp)
        return ["solve", "s.toml", "--json", "d/link/s.toml"]

    def bifurcation_json_is_scene(tmp: Path, mp) -> list[str]:
        _write(tmp, "s.toml", SCENE)
        return ["bifurcation", "s.toml", "--vary", "mu", "--no-mc", "--json", "s.toml"]

    def check_out_holds_scene(tmp: Path, mp) -> list[str]:
        _write(tmp, "d/s.toml", SCENE)
        return ["check", "d/s.toml", "--out", "d"]

    def workprecision_out_holds_scene(tmp: Path, mp) -> list[str]:
        _write(tmp, "d/sub/s.toml", SCENE)
        return ["workprecision", "d/sub/s.toml", "--out", "d"]

    def sweep_out_holds_its_scene(tmp: Path, mp) -> list[str]:
        _write(tmp, "points/tiny.toml", (DATA / "tiny.toml").read_text())
        _write(tmp, "sw.toml", SWEEP.replace('"tiny"', '"points/tiny.toml"'))
        return ["sweep", "sw.toml", "--out", "."]

    def json_is_a_plugin_source(tmp: Path, mp) -> list[str]:
        _plugin(tmp / "plug", mp, "def build(scene, **o):\n    raise RuntimeError\n")
        return ["solve", "paper-base", "--json", "plug/vifpk_edge_plugin.py"]

    return [
        ("solve --json = the scene", solve_json_is_scene, "is the scene file this run reads"),
        ("solve --json = the scene, other spelling", solve_json_other_spelling,
         "is the scene file this run reads"),
        ("solve --json = the scene through a link", solve_json_through_a_link,
         "is the scene file this run reads"),
        ("bifurcation --json = the scene", bifurcation_json_is_scene,
         "is the scene file this run reads"),
        ("check --out holds the scene", check_out_holds_scene,
         "holds the scene file"),
        ("workprecision --out holds the scene", workprecision_out_holds_scene,
         "holds the scene file"),
        ("sweep --out holds its scene under points/", sweep_out_holds_its_scene,
         "holds the sweep's scene file"),
        ("solve --json = a plugin's source", json_is_a_plugin_source,
         "is the source of model plugin 'mine'"),
    ]


COLLISIONS = _collisions()


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else b"<dir>"
            for p in sorted(folder.rglob("*")) if not p.is_symlink()}


def _refused(args: list[str], tmp_path: Path, capsys, contains: str) -> None:
    from vifpk.harness.cli import main

    before = _snapshot(tmp_path)
    try:
        code = main(args)
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1 and contains in err[0], err
    assert _snapshot(tmp_path) == before


@pytest.mark.parametrize("case", COLLISIONS, ids=[c[0] for c in COLLISIONS])
def test_an_output_never_overwrites_an_input(case, no_computation, tmp_path, monkeypatch,
                                             capsys):
    monkeypatch.setenv("VIFPK_STEPS_PER_SECOND", "2e7")
    monkeypatch.chdir(tmp_path)
    _refused(case[1](tmp_path, monkeypatch), tmp_path, capsys, case[2])


# ------------------------------------------------ two spellings of one term: one rule
TWO_SPELLINGS = [
    ("vary damping[1] and c2", '[vary]\n"system.damping[1]" = [0.04, 0.05]\n'
                               '"system.c2" = [0.01, 0.02]\n', "[vary] 'system.c2'"),
    ("vary alpha, set restoring[1]", '[vary]\n"system.alpha" = [0.5, 0.6]\n'
                                     '[set]\n"system.restoring[1]" = 0.7\n',
     "[set] 'system.restoring[1]'"),
    ("vary omega0, set the whole restoring law", '[vary]\n"system.omega0" = [1.0, 1.1]\n'
                                                 '[set]\n"system.restoring" = [1.0, 0.6]\n',
     "[set] 'system.restoring'"),
]


@pytest.mark.parametrize("case", TWO_SPELLINGS, ids=[c[0] for c in TWO_SPELLINGS])
def test_a_sweep_refuses_two_spellings_of_one_term_as_set_does(case, no_computation, tmp_path,
                                                                monkeypatch, capsys):
    """It used to run with an axis that has no effect (the last spelling won); ``--set``
    refused the same pair: now both follow vifpk.core.scene.shared_term."""
    monkeypatch.chdir(tmp_path)
    _write(tmp_path, "sw.toml", 'scene = "paper-base"\nworkflow = "averaging"\n' + case[1])
    _refused(["sweep", "sw.toml", "--out", "o"], tmp_path, capsys,
             f"{case[2]}: sets the ")
    _refused(["solve", "paper-base", "--set", "system.c2=0.1", "--set", "system.damping[1]=0.2"],
             tmp_path, capsys, "two spellings of one term")
