"""Issue 39, plugins (W01-W14, G05-G09): a workflow or model plugin that misbehaves is named
as the plugin's failure in one line, never blamed on vifpk ("internal error ... please report
it"), never exit 0, and vifpk's own commands are unharmed by it. The workflow ``hello`` is
registered in-process as another distribution's (tests/test_edges6.py's pattern); what it
does is set per test through ``MODE``. docs/edges.md ("Round 7") lists the cases."""

from __future__ import annotations

import json
import math

import pytest

from vifpk.core import registry
from vifpk.core.protocols import WorkflowSpec

#: what the plugin workflow does, per test (monkeypatched)
MODE = {"args": "ok", "command": 0, "point": {"hello": 1.0}}


def _args(parser):
    if MODE["args"] == "raises":
        raise RuntimeError("no options today")
    if MODE["args"] == "help":
        parser.add_argument("--help")  # argparse: conflicting option string
    parser.add_argument("scene")


def _command(args):
    what = MODE["command"]
    if what == "raises":
        raise KeyError("oops")
    return what


def _point(job):
    return MODE["point"]


HELLO = WorkflowSpec("hello", "a workflow that misbehaves on demand", add_arguments=_args,
                     command=_command, sweep_point=_point)
NOT_A_WORKFLOW = object()


@pytest.fixture
def hello(monkeypatch):
    """Register ``tests.test_edges7_plugins:<attr>`` as the workflow ``hello`` of the
    distribution 'plug'; ``MODE`` entries given set what it does."""
    import vifpk.harness.sweeps.points as points

    def install(attr: str = "HELLO", **mode):
        monkeypatch.setattr(__import__(__name__, fromlist=["MODE"]), "MODE",
                            {**MODE, **mode})
        real = registry._group

        def group(g):
            entries, conflicts = real(g)
            if g == registry.WORKFLOW_GROUP:
                entries = (*entries, registry.ModelEntry("hello", f"{__name__}:{attr}", "plug"))
            return entries, conflicts

        monkeypatch.setattr(registry, "_group", group)
        monkeypatch.setattr(points, "WORKFLOW_FUNCTIONS", {})
        registry.refresh()

    yield install
    registry.refresh()


def _main(args):
    from vifpk.harness.cli.app import main

    try:
        return main(args)
    except SystemExit as exc:
        return exc.code


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "internal error" not in err[0] and "please report" not in err[0], err
    return err[0]


# ------------------------------------------------------------ W01/W02: import fails
def test_w01_a_workflow_that_does_not_load_blocks_no_vifpk_command(hello, capsys):
    hello("NO_SUCH_ATTRIBUTE")
    assert _main(["check", "-h"]) == 0
    assert "usage: vifpk check" in capsys.readouterr().out


def test_w02_a_workflow_that_does_not_load_fails_in_one_line_when_asked_for(hello, capsys):
    hello("NO_SUCH_ATTRIBUTE")
    assert _main(["hello", "paper-base"]) == 3
    line = _one_line(capsys)
    assert "workflow 'hello'" in line and "from plug" in line and "did not load" in line


# ------------------------------------------------------------ W04/W05: add_arguments
@pytest.mark.parametrize(("mode", "says"), [("raises", "raised RuntimeError: no options"),
                                            ("help", "raised ArgumentError")])
def test_w04_w05_add_arguments_that_fails_harms_no_vifpk_command(hello, capsys, mode, says):
    hello(args=mode)
    assert _main(["passage", "-h"]) == 0
    assert "usage: vifpk passage" in capsys.readouterr().out
    assert _main(["hello", "paper-base"]) == 3
    line = _one_line(capsys)
    assert "workflow 'hello'" in line and "its add_arguments" in line and says in line, line


# ------------------------------------------------------------ W06-W09: the command
@pytest.mark.parametrize(("returns", "says"), [
    (None, "returned None"), ("oops", "returned 'oops'"), (256, "returned 256"),
    (True, "returned True"), ("raises", "its command raised KeyError: 'oops'")])
def test_w06_to_w09_a_command_that_misbehaves_is_the_plugin_s_failure(hello, capsys, returns,
                                                                       says):
    hello(command=returns)
    assert _main(["hello", "paper-base"]) == 3
    line = _one_line(capsys)
    assert "workflow 'hello'" in line and "from plug" in line and says in line, line


def test_a_plugin_command_s_own_exit_code_is_kept(hello, capsys):
    hello(command=4)
    assert _main(["hello", "paper-base"]) == 4


# ------------------------------------------------------------ W13/W14: sweep_point
def _sweep(tmp_path):
    from tests.conftest import ROOT

    (tmp_path / "tiny.toml").write_text((ROOT / "tests" / "data" / "tiny.toml").read_text())
    (tmp_path / "s.toml").write_text('scene = "tiny.toml"\nworkflow = "hello"\n'
                                     '[vary]\n"system.r" = [0.95, 0.96]\n')
    return ["sweep", str(tmp_path / "s.toml"), "--out", str(tmp_path / "out")]


@pytest.mark.parametrize(("point", "says"), [
    ([1.0, 2.0], "returned list"), ({"hello": math.nan}, "hello = nan"),
    ({"hello": [1.0, math.inf]}, "hello = [1.0, inf]")])
def test_w13_w14_a_sweep_point_out_of_protocol_is_named_and_flagged(hello, capsys, tmp_path,
                                                                    point, says):
    hello(point=point)
    code = _main(_sweep(tmp_path))
    err = capsys.readouterr().err
    assert code == 3, err
    assert "internal error" not in err
    recs = [json.loads(p.read_text()) for p in sorted((tmp_path / "out").rglob("*.json"))
            if "key" in json.loads(p.read_text())]
    assert len(recs) == 2 and all(r["status"] == "failed" for r in recs), recs
    assert all("workflow 'hello'" in r["message"] and says in r["message"] for r in recs), recs


# ------------------------------------------------------------ G05-G09: a model plugin
MODEL = '''
import numpy as np


class Model:
    """dA = (-0.1 A + 0.005 / A) dt + 0.1 dB: p(A) ~ A exp(-10 A^2) (test_edges5's GOOD)."""

    def __init__(self, scene):
        self.scene = scene

    def drift(self, A):
        {drift}
        return {sign}0.1 * A + 0.005 / A

    def diffusion(self, A):
        return {sigma2} + 0 * A


def build(scene, **options):
    {build}
    return Model(scene)
'''


def _model(tmp_path, monkeypatch, *, drift="pass", sign="-", sigma2="0.01", build="pass"):
    from tests.test_edges5 import _plugin

    return _plugin(tmp_path / "plug", monkeypatch,
                   MODEL.format(drift=drift, sign=sign, sigma2=sigma2, build=build))


def test_g05_a_model_plugin_that_prints_leaves_the_standard_output_to_vifpk(
        tmp_path, monkeypatch, capfd):
    """What the plugin prints (on import, in its factory, in drift) goes to the standard
    error; the standard output holds vifpk's own lines alone (a pipe reading them, e.g. the
    summary or ``--json`` to a pipe, is not corrupted). capfd: the file descriptors."""
    _model(tmp_path, monkeypatch, drift="print('drift called')",
           build="print('building')")
    monkeypatch.chdir(tmp_path)
    assert _main(["solve", "paper-base", "--model", "mine"]) == 0
    out, err = capfd.readouterr()
    assert out.strip() and "drift called" not in out and "building" not in out, out
    assert "drift called" in err and "building" in err


@pytest.mark.parametrize(("kw", "says"), [
    ({"sign": "+"}, "no stationary law"),
    ({"sigma2": "0.0"}, "diffusion(A) is zero"),
])
def test_g08_g09_a_model_without_a_stationary_law_is_the_plugin_s_failure(
        tmp_path, monkeypatch, capsys, kw, says):
    src = _model(tmp_path, monkeypatch, **kw)
    monkeypatch.chdir(tmp_path)
    assert _main(["solve", "paper-base", "--model", "mine"]) == 3
    line = _one_line(capsys)
    assert f"model plugin 'mine' (from edge-plugin, {src})" in line and says in line, line
