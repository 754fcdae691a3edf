"""The workflow registry (issue 27): the command line's subcommands and the sweeps' workflows
are derived from the ``vifpk.workflows`` entry points, so a new workflow is one module plus one
entry-point line. Here a workflow registered from this test module appears in both."""

from __future__ import annotations

import pytest

from vifpk.core import registry
from vifpk.core.protocols import Workflow, WorkflowSpec


def _args(p):
    p.add_argument("scene")


def _run(args):
    print(f"hello {args.scene}")
    return 0


def _point(job):
    return {"hello": True}


HELLO = WorkflowSpec("hello", "say hello to a scene", add_arguments=_args, command=_run,
                     sweep_point=_point)
NOT_A_WORKFLOW = object()


@pytest.fixture
def with_entry(monkeypatch):
    def install(value: str, name: str = "hello"):
        real = registry._group

        def group(g):
            entries, conflicts = real(g)
            if g == registry.WORKFLOW_GROUP:
                entries = (*entries, registry.ModelEntry(name, value, "tests"))
            return entries, conflicts

        monkeypatch.setattr(registry, "_group", group)
        registry.workflows.cache_clear()
        import vifpk.harness.sweeps.points as points

        monkeypatch.setattr(points, "WORKFLOW_FUNCTIONS", {})

    yield install
    registry.workflows.cache_clear()


def test_builtin_workflows_are_workflows_and_drive_the_cli_and_sweeps():
    from vifpk.harness.cli.app import build_parser
    from vifpk.harness.sweeps.points import sweep_functions

    ws = registry.workflows()
    assert all(isinstance(w, Workflow) for w in ws)
    sub = build_parser()._subparsers._group_actions[0]
    assert list(sub.choices) == [w.name for w in ws if w.command is not None]
    assert list(sweep_functions()) == [w.name for w in ws if w.sweep_point is not None]
    assert {"check", "averaging", "bifurcation", "passage", "transient"} <= set(sweep_functions())


def test_a_registered_workflow_appears_in_the_cli_and_in_sweeps(with_entry, capsys):
    from vifpk.harness.cli.app import main
    from vifpk.harness.sweeps.points import sweep_functions

    with_entry("tests.test_workflow_registry:HELLO")
    assert main(["hello", "paper-base"]) == 0
    assert capsys.readouterr().out.strip() == "hello paper-base"
    assert sweep_functions()["hello"] is _point


def test_a_broken_workflow_entry_is_one_line_naming_it(with_entry, capsys):
    from vifpk.harness.cli.app import main

    with_entry("tests.test_workflow_registry:NOT_A_WORKFLOW")
    assert main(["models"]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "workflow 'hello'" in err, err
