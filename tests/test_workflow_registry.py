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


def hello(scene, *, loud=False):
    return f"hello {scene}" + ("!" if loud else "")


def assert_hello(scene, *, says):
    assert hello(scene) == says


HELLO = WorkflowSpec("hello", "say hello to a scene", add_arguments=_args, command=_run,
                     sweep_point=_point, api=hello, assertion=assert_hello)
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
    import vifpk

    for cached in ("hello", "assert_hello"):  # vifpk caches what it resolved
        vars(vifpk).pop(cached, None)


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


def test_the_python_and_testing_apis_are_the_registry_s(with_entry):
    """vifpk.<name>, vifpk.run(name, ...), vifpk.<assertion> and harness.testing.assertion(name)
    come from the registered workflows: the built-ins' and a new one's alike, no vifpk edit."""
    from vifpk.harness import testing

    import vifpk

    for w in registry.workflows():
        if w.api is not None:
            assert getattr(vifpk, w.name) is w.api and w.name in vifpk.__all__
        if w.assertion is not None:
            assert testing.assertion(w.name) is w.assertion
            assert getattr(vifpk, w.assertion.__name__) is w.assertion
    assert {"solve", "check", "sweep", "passage", "transient"} <= set(vifpk.__all__)
    with_entry("tests.test_workflow_registry:HELLO")
    assert vifpk.hello("paper-base", loud=True) == "hello paper-base!"
    assert vifpk.run("hello", "paper-base") == "hello paper-base"
    vifpk.assert_hello("x", says="hello x")
    assert testing.assertion("hello") is assert_hello
    assert {"hello", "assert_hello"} <= set(vifpk.__all__)
    with pytest.raises(vifpk.core.result.BadInput, match="allowed: solve, check"):
        vifpk.run("models")


def test_a_broken_workflow_entry_is_one_line_naming_it(with_entry, capsys):
    from vifpk.harness.cli.app import main

    with_entry("tests.test_workflow_registry:NOT_A_WORKFLOW")
    assert main(["models"]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "workflow 'hello'" in err, err
