"""The registries (vifpk.core.registry) and model plugins by entry point (docs/plugins.md).

A plugin is made visible without pip: a ``*.dist-info`` folder (METADATA + entry_points.txt)
on ``sys.path`` is what an installed distribution is to ``importlib.metadata``, so a
subprocess with that folder on PYTHONPATH sees the example plugin
(docs/examples/plugin/) exactly as after ``pip install``. tests/test_wheel.py installs it
with pip into a fresh virtual environment (slow tier).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import ROOT
from vifpk.core import registry

PLUGIN = ROOT / "docs" / "examples" / "plugin"


def test_builtin_models_are_the_pyproject_entry_points_by_name():
    """The registry (which reads the installed metadata only, in every install) against
    pyproject.toml, the declaration the install was made from (CI's editable install, the wheel
    tests' wheel): the same entries, vifpk's own first, by name."""
    from importlib import metadata

    table = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    declared = tuple(table[registry.MODEL_GROUP])
    installed = {ep.name: ep.value for ep in metadata.entry_points(group=registry.MODEL_GROUP)
                 if ep.dist is not None and ep.dist.metadata["Name"] == registry.DISTRIBUTION}
    assert installed == dict(table[registry.MODEL_GROUP])
    assert registry.model_names()[:len(declared)] == tuple(sorted(declared))
    assert {"paper", "exact", "corrected"} <= set(declared)
    assert all(registry.model_entry(n).builtin for n in declared)
    for name in declared:  # each entry point loads to a factory that builds a model
        assert callable(registry.model_entry(name).load())


def test_check_and_bifurcation_defaults_are_registered_models():
    from vifpk.core.defaults import BIFURCATION_MODELS, CHECK_MODELS

    assert set(CHECK_MODELS) | set(BIFURCATION_MODELS) <= set(registry.model_names())


def test_unknown_model_names_the_registered_ones(base):
    with pytest.raises(registry.UnknownName) as err:
        registry.build_model(base, "no-such-model")
    msg = str(err.value)
    assert "\n" not in msg and "'no-such-model'" in msg
    assert all(repr(n) in msg for n in registry.model_names())


def test_a_registered_factory_that_cannot_load_is_named(monkeypatch, base):
    bad = registry.ModelEntry("broken", "no_such_module_xyz:build", "someone")
    monkeypatch.setattr(registry, "_entries", lambda: ((bad,), ()))
    with pytest.raises(registry.UnknownName, match="'broken'.*no_such_module_xyz:build.*"
                                                    "someone"):
        registry.build_model(base, "broken")


def test_one_of_is_the_one_wording():
    assert registry.one_of("noise kind", "ou", registry.noise_kind_names()) == "ou"
    # the registered kinds as the registry holds them (a third kind must not edit this test)
    with pytest.raises(ValueError, match=re.escape(
            f"noise kind must be one of {tuple(registry.noise_kind_names())}, not 'pink'")):
        registry.one_of("noise kind", "pink", registry.noise_kind_names())


def test_status_members_carry_their_messages():
    from vifpk.core.result import Status

    rec = Status.NOT_FINITE.record("x2")
    assert rec == {"ok": False, "message": "density is negative or not finite (x2)",
                   "code": "not_finite"}
    assert all(s.message and s.code for s in Status)
    assert len({s.code for s in Status}) == len(Status)


# ------------------------------------------------------------------ a plugin, end to end
@pytest.fixture(scope="module")
def plugin_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder that makes the example plugin 'installed' for importlib.metadata: its module
    and a dist-info with the entry points of its pyproject.toml."""
    where = tmp_path_factory.mktemp("plugin")
    meta = tomllib.loads((PLUGIN / "pyproject.toml").read_text())
    project = meta["project"]
    info = where / f"{project['name'].replace('-', '_')}-{project['version']}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\n"
                                   f"Version: {project['version']}\n")
    lines = [f"[{group}]"] if (group := registry.MODEL_GROUP) else []
    lines += [f"{k} = {v}" for k, v in project["entry-points"][group].items()]
    (info / "entry_points.txt").write_text("\n".join(lines) + "\n")
    (where / "vifpk_white_envelope.py").write_text(
        (PLUGIN / "vifpk_white_envelope.py").read_text())
    return where


def _cli(plugin_path: Path, *args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(plugin_path), str(ROOT)]),
               NUMBA_NUM_THREADS="1")
    return subprocess.run([sys.executable, "-m", "vifpk", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


@pytest.mark.slow
def test_a_plugin_is_listed_and_solved_like_a_builtin(plugin_path: Path, tmp_path: Path):
    res = _cli(plugin_path, "models")
    assert res.returncode == 0, res.stderr
    line = next(ln for ln in res.stdout.splitlines() if ln.startswith("white-envelope"))
    assert "vifpk_white_envelope:WhiteNoiseEnvelope" in line and "vifpk-white-envelope" in line
    for solver in ("averaging", "fpk"):
        out = tmp_path / f"{solver}.json"
        res = _cli(plugin_path, "solve", "paper-base", "--model", "white-envelope",
                   "--solver", solver, "--json", str(out))
        assert res.returncode == 0, res.stderr
        rec = json.loads(out.read_text())
        assert rec["model"] == "white-envelope"
        for obs in ("A", "x1", "x2"):
            x, p = np.asarray(rec["pdf"][obs]["x"]), np.asarray(rec["pdf"][obs]["p"])
            assert np.all(np.isfinite(p)) and p.min() >= 0
            assert abs(np.trapezoid(p, x) - 1) < 1e-6
        # no closed form and no period: the record says what it used instead
        assert rec["info"]["period"].startswith("exact orbit")
    assert rec["info"]["status"]["ok"]
    res = _cli(plugin_path, "solve", "paper-base", "--model", "white-envelope")
    assert res.returncode == 0, res.stderr
    assert "FPK direct solve, 800 cells" in res.stdout and "period T(A): exact orbit" in res.stdout


@pytest.mark.slow
def test_an_unknown_model_exits_2_listing_the_plugins_too(plugin_path: Path):
    for cmd in ("solve", "check", "bifurcation"):
        extra = ["--vary", "mu"] if cmd == "bifurcation" else []
        res = _cli(plugin_path, cmd, "paper-base", "--model", "nope", *extra)
        assert res.returncode == 2
        assert res.stderr.count("\n") == 1, res.stderr
        assert "white-envelope" in res.stderr and "corrected" in res.stderr


def test_the_plugin_model_in_harness_testing_and_bifurcation(plugin_path: Path):
    """In-process: the registry read again with the plugin on sys.path."""
    sys.path.insert(0, str(plugin_path))
    registry.refresh()
    try:
        from vifpk.harness.testing import model_densities
        from vifpk.harness.workflows.bifurcation import shape_index

        from vifpk.core.scene import load_scene

        scene = load_scene("paper-base")
        d = model_densities(scene, "white-envelope")
        assert abs(np.trapezoid(d["A"]["p"], d["A"]["x"]) - 1) < 1e-9
        assert np.isfinite(shape_index(scene, "white-envelope"))
    finally:
        sys.path.remove(str(plugin_path))
        registry.refresh()


def test_finding_a_plugins_source_runs_none_of_its_code(tmp_path, monkeypatch):
    """Issue 38: input validation named each plugin's source with importlib.util.find_spec
    under suppress(Exception), and find_spec("pkg.mod") imports pkg: a plugin's code ran
    during validation, unguarded. Its file is found without importing anything."""
    import sys
    from types import SimpleNamespace

    from vifpk.harness.request import validate

    pkg = tmp_path / "vifpk_sidefx_pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("raise RuntimeError('plugin code ran')\n")
    (pkg / "model.py").write_text("def build(scene, **o):\n    return None\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    entry = registry.ModelEntry("sidefx", "vifpk_sidefx_pkg.model:build", "tests")
    monkeypatch.setattr(registry, "models", lambda: (*registry._entries()[0], entry))
    found = validate.run_inputs(SimpleNamespace())
    assert ("the source of model plugin 'sidefx'", (pkg / "model.py").resolve()) in found
    assert "vifpk_sidefx_pkg" not in sys.modules
    gone = registry.ModelEntry("gone", "vifpk_no_such_pkg.model:build", "tests")
    monkeypatch.setattr(registry, "models", lambda: (*registry._entries()[0], gone))
    assert not [w for w, _ in validate.run_inputs(SimpleNamespace()) if "'gone'" in w]
