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

from tests.conftest import ROOT
from vifpk.core import registry

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
    import sys

    path = _write(folder, f"{module}.py", source)
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.delitem(sys.modules, module, raising=False)  # each test its own module
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
    from vifpk.harness.cli.app import main

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


# ---------------------------------------------------------------- plugins that misbehave
GOOD = '''
import numpy as np


class Model:
    """dA = (-0.1 A + 0.005 / A) dt + 0.1 dB: p(A) ~ A exp(-10 A^2)."""

    def __init__(self, scene):
        self.scene = scene

    def drift(self, A):
        return -0.1 * A + 0.005 / A

    def diffusion(self, A):
        return 0.01 + 0 * A


def build(scene, **options):
    return Model(scene)
'''

PLUGINS = [
    ("import raises", "x = 1 / 0\n" + GOOD, "importing it raised ZeroDivisionError"),
    ("factory calls sys.exit(0)", GOOD + "\n\ndef build(scene, **options):\n    import sys\n"
                                         "    sys.exit(0)\n", "called sys.exit(0)"),
    ("factory raises", GOOD + "\n\ndef build(scene, **options):\n    return scene.nope\n",
     "its factory raised AttributeError"),
    ("factory returns no diffusion", GOOD + "\n\ndef build(scene, **options):\n"
                                            "    return object()\n",
     "returned object, which has no drift(A)"),
    ("drift raises", GOOD.replace("return -0.1 * A + 0.005 / A", "return {}['k']"),
     "drift(A) raised KeyError: 'k'"),
    ("drift returns a scalar", GOOD.replace("return -0.1 * A + 0.005 / A", "return 0.5"),
     "drift(A) returned a single value for"),
    ("diffusion NaN", GOOD.replace("return 0.01 + 0 * A", "return np.nan * A"),
     "diffusion(A) is nan at A = "),
    ("negative period", GOOD.replace("def build", "Model.period = lambda self, A: -1 + 0 * A"
                                                  "\n\n\ndef build"),
     "period(A) is not positive at A = "),
    ("NaN log_stationary_parts", GOOD.replace(
        "def build", "Model.period = lambda self, A: 6.0 + 0 * A\nModel.log_stationary_parts"
                     " = lambda self, A: (np.nan * A, 0 * A, 0 * A)\n\n\ndef build"),
     "log_stationary_parts(A)'s q is nan at A = "),
    ("drift returns complex numbers", GOOD.replace("return -0.1 * A + 0.005 / A",
                                                   "return -0.1 * A + 1j"),
     "drift(A) returned complex numbers"),
    ("drift returns a string", GOOD.replace("return -0.1 * A + 0.005 / A", "return 'x'"),
     "drift(A) returned str, not numbers"),
    ("drift recurses forever", GOOD.replace("return -0.1 * A + 0.005 / A",
                                            "return self.drift(A)"),
     "drift(A) raised RecursionError"),
    ("drift writes into vifpk's grid", GOOD.replace("return -0.1 * A + 0.005 / A",
                                                    "A *= 2\n        return A"),
     "drift(A) raised ValueError: output array is read-only"),
    ("drift inf for A > 0", GOOD.replace("return -0.1 * A + 0.005 / A",
                                         "return 0 * A + float('inf')"),
     "drift(A) is inf at A = "),
    ("applies returns a bool", GOOD + "\nbuild.applies = lambda scene: True\n",
     "applies(scene) returned bool"),
    ("applies raises", GOOD.replace("def build(scene, **options):\n    return Model(scene)",
                                    "def build(scene, **options):\n    return Model(scene)\n\n\n"
                                    "build.applies = lambda scene: scene.nope"),
     "applies(scene) raised AttributeError"),
]


@pytest.mark.parametrize("case", PLUGINS, ids=[c[0] for c in PLUGINS])
def test_a_misbehaving_plugin_is_named_with_its_file(case, tmp_path, monkeypatch, capsys):
    """Exit 3, one line naming the plugin, its distribution and file, and what it did --
    never a vifpk 'internal error', never 'the scene's magnitudes', never exit 0."""
    from vifpk.harness.cli.app import main

    src = _plugin(tmp_path, monkeypatch, case[1])
    monkeypatch.chdir(tmp_path)
    code = main(["solve", "paper-base", "--model", "mine"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 3, err
    assert len(err) == 1, err
    assert f"model plugin 'mine' (from edge-plugin, {src})" in err[0], err
    assert case[2] in err[0], err
    assert "internal error" not in err[0] and "magnitudes" not in err[0]


def test_a_good_plugin_solves_through_the_guard(tmp_path, monkeypatch, capsys):
    from vifpk.harness.cli.app import main

    _plugin(tmp_path, monkeypatch, GOOD)
    monkeypatch.chdir(tmp_path)
    for solver in ("averaging", "fpk"):
        assert main(["solve", "paper-base", "--model", "mine", "--solver", solver]) == 0, \
            capsys.readouterr().err


def test_models_lists_an_entry_point_to_a_missing_module_as_broken(monkeypatch, capsys):
    from vifpk.harness.cli.app import main

    entry = registry.ModelEntry("ghost", "no_such_module_xyz:build", "ghost-dist")
    builtin = tuple(e for e in registry.models() if e.builtin)
    monkeypatch.setattr(registry, "_entries", lambda: ((*builtin, entry), ()))
    assert main(["models"]) == 0
    out, err = capsys.readouterr()
    line = next(ln for ln in out.splitlines() if ln.startswith("ghost"))
    assert "CANNOT BE LOADED" in line
    assert "'ghost'" in err and "'no_such_module_xyz' is not installed" in err
    assert not any("CANNOT" in ln for ln in out.splitlines() if not ln.startswith("ghost"))


def test_the_example_plugin_runs_on_its_family_and_refuses_the_rest(monkeypatch, capsys):
    """docs/examples/plugin reads the law lists (it read s.omega0: TypeError on any scene
    written with law lists) and says where it applies: on every shipped scene either finite
    drift and positive diffusion, or one line; named on the command line where it does not
    apply: exit 2 with that line."""
    import sys

    import numpy as np
    from vifpk.harness.cli.app import main

    from vifpk.core.scene import load_scene, shipped_names

    folder = ROOT / "docs" / "examples" / "plugin"
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.delitem(sys.modules, "vifpk_white_envelope", raising=False)
    from vifpk_white_envelope import WhiteNoiseEnvelope

    entry = registry.ModelEntry("white-envelope", "vifpk_white_envelope:WhiteNoiseEnvelope",
                                "vifpk-white-envelope")
    builtin = tuple(e for e in registry.models() if e.builtin)
    monkeypatch.setattr(registry, "_entries", lambda: ((*builtin, entry), ()))
    A = np.linspace(0.05, 2.0, 40)
    runs = refused = 0
    for name in shipped_names():
        for sc in load_scene(name).variants():
            why = WhiteNoiseEnvelope.applies(sc)
            if why is None:
                m = WhiteNoiseEnvelope(sc)
                assert np.all(np.isfinite(m.drift(A))), name
                assert np.all(m.diffusion(A) > 0) or sc.system.f == 0, name
                runs += 1
            else:
                assert isinstance(why, str) and "\n" not in why, name
                refused += 1
    assert runs >= 10 and refused >= 3  # both sides exercised (quintic, rayleigh, degree9..)
    for name in ("systems/quintic", "systems/rayleigh"):
        assert main(["solve", name, "--model", "white-envelope"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "white-envelope covers" in err[0] or \
            "velocity-dependent" in err[0], err
    assert main(["solve", "systems/linear-ou", "--model", "white-envelope"]) == 0


def test_a_failing_plugin_in_a_sweep_keeps_the_other_models_numbers(tmp_path, monkeypatch):
    """It failed every point and lost the built-in models' numbers. The averaging workflow
    keeps each model that succeeded and records the plugin's one line as its 'failure'; the
    check workflow runs the cross-check again without the plugin."""
    from types import SimpleNamespace

    from vifpk.harness.sweeps import points as sweeps_points
    from vifpk.harness.workflows import check

    from vifpk.core.guard import PluginError
    from vifpk.core.scene import load_scene

    _plugin(tmp_path, monkeypatch, GOOD.replace("return -0.1 * A + 0.005 / A",
                                                "return {}['k']"))
    job = SimpleNamespace(scene=load_scene("paper-base"), models=("exact", "mine"))
    out = sweeps_points.averaging_point(job)
    assert out["models"]["exact"]["mean_A"] > 0
    assert "model plugin 'mine'" in out["models"]["mine"]["failure"]
    assert "drift(A) raised KeyError" in out["models"]["mine"]["failure"]

    seen = []

    def fake_cross_check(scene, *, models, **kw):
        seen.append(models)
        if "mine" in models:
            raise PluginError("model plugin 'mine' (...): drift(A) raised KeyError", "mine")
        raise RuntimeError("stop here")

    monkeypatch.setattr(check, "cross_check", fake_cross_check)
    with pytest.raises(RuntimeError, match="stop here"):
        sweeps_points.check_point(SimpleNamespace(scene=job.scene, models=("exact", "mine"),
                                           sde=False, tolerance=0.02, keep_state=False,
                                           tolerance_question=("L1", "A", 0.95)))
    assert seen == [("exact", "mine"), ("exact",)]


# ---------------------------------------------------------------------------- signals
def test_sighup_on_check_is_like_sigterm(tmp_path):
    """A closed terminal (SIGHUP) during check: exit 129 with the one message, no .lock left,
    nothing written (it exited 129 silently and left the lock)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    env = {**os.environ, "NUMBA_NUM_THREADS": "1", "PYTHONPATH": os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.Popen([sys.executable, "-m", "vifpk", "check", str(DATA / "tiny.toml"),
                             "--out", str(tmp_path / "c"), "--quiet"], env=env, cwd=tmp_path,
                            stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not (tmp_path / ".c.lock").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGHUP)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 129, err
    assert err.strip().splitlines() == [
        "vifpk: hung up (SIGHUP: the terminal closed); nothing was written"]
    assert sorted(os.listdir(tmp_path)) == []


def test_progress_into_a_file_is_plain_lines(monkeypatch):
    """Not a terminal: each redraw one line, no carriage-return runs (they filled log files)."""
    import importlib
    import io
    import sys

    progress = importlib.import_module("vifpk.montecarlo.progress")
    buf = io.StringIO()
    monkeypatch.setattr(sys, "stderr", buf)
    bar = progress.progress_bar(True)
    bar.total = 1000
    for _ in range(3):
        bar.update(100)
        bar.refresh()
    bar.close()
    text = buf.getvalue()
    assert "\r" not in text and text.count("\n") == 3, repr(text)
    assert all("monte carlo: pilot" in ln for ln in text.splitlines())


def test_the_papers_bifurcation_claim_only_for_the_papers_system(monkeypatch, capsys):
    """`bifurcation systems/quintic` printed 'paper claims: mu near 0.038 at r = 0.975'."""
    from vifpk.harness.workflows import bifurcation as bif

    from vifpk.core.scene import load_scene

    monkeypatch.setattr(bif, "critical_value", lambda *a, **k: 0.01)
    quintic = bif.bifurcation(load_scene("systems/quintic"), "mu", mc=False,
                              models=("exact",))
    assert quintic["paper_claim"] is None and not quintic["paper_claim_comparable"]
    assert "outside it" in quintic["paper_claim_note"]
    base = bif.bifurcation(load_scene("paper-base"), "mu", mc=False, models=("exact",))
    assert "0.975" in base["paper_claim"]


SIZES = [
    (["solve", "paper-base", "--set", "averaging.points=1e8"],
     "averaging.points x theta_nodes = 100000000 x 64"),
    (["solve", "paper-base", "--set", "averaging.theta_nodes=1e6"],
     "averaging.points x theta_nodes = 801 x 1000000"),
    (["solve", "paper-base", "--solver", "fpk", "--grid", "5e6"],
     "this solve: estimated at least"),
]


@pytest.mark.parametrize("case", SIZES, ids=[c[1][:40] for c in SIZES])
def test_sizes_are_refused_for_their_true_reason(case, no_computation, tmp_path, monkeypatch,
                                                 capsys):
    """1e8 is a whole number: refused for memory (points x theta_nodes) or cost (the FPK's
    stepping, priced as growing faster than the cells), not as 'not a whole number'."""
    monkeypatch.chdir(tmp_path)
    _refused(case[0], tmp_path, capsys, case[1])


def test_a_whole_number_with_an_exponent_is_taken(tmp_path):
    from vifpk.harness.request.prepare import concrete

    assert concrete("paper-base", ["averaging.points=1.5e3"]).averaging.points == 1500
