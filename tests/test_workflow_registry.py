"""The workflow registry (issue 27): the command line's subcommands and the sweeps' workflows
are derived from the ``vifpk.workflows`` entry points, so a new workflow is one module plus one
entry-point line. Here a workflow registered from this test module appears in both."""

from __future__ import annotations

import pytest

from vifpk.core import registry
from vifpk.core.protocols import Ref, Workflow, WorkflowSpec, resolved


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
        registry.refresh()
        import vifpk.harness.sweeps.points as points

        monkeypatch.setattr(points, "WORKFLOW_FUNCTIONS", {})

    yield install
    registry.refresh()
    import vifpk

    for cached in ("hello", "assert_hello"):  # vifpk caches what it resolved
        vars(vifpk).pop(cached, None)


def test_builtin_workflows_are_workflows_and_drive_the_cli_and_sweeps():
    from vifpk.harness.cli.app import ORDER, build_parser
    from vifpk.harness.sweeps.points import sweep_functions

    ws = registry.workflows()
    assert all(isinstance(w, Workflow) for w in ws)
    sub = build_parser()._subparsers._group_actions[0]
    assert list(sub.choices) == [n for n in ORDER if n in {w.name for w in ws if w.command}]
    assert list(sweep_functions()) == [w.name for w in ws if w.sweep_point is not None]
    assert {"check", "averaging", "bifurcation", "passage", "transient"} <= set(sweep_functions())


def test_a_registered_workflow_appears_in_the_cli_and_in_sweeps(with_entry, capsys):
    from vifpk.harness.cli.app import main
    from vifpk.harness.sweeps.points import sweep_functions

    with_entry("tests.test_workflow_registry:HELLO")
    assert main(["hello", "paper-base"]) == 0
    assert capsys.readouterr().out.strip() == "hello paper-base"
    # another distribution's sweep_point comes with its record checked (issue 39, W13/W14)
    assert sweep_functions()["hello"](None) == _point(None) == {"hello": True}


def test_the_python_and_testing_apis_are_the_registry_s(with_entry):
    """vifpk.<name>, vifpk.run(name, ...), vifpk.<assertion> and harness.testing.assertion(name)
    come from the registered workflows: the built-ins' and a new one's alike, no vifpk edit."""
    from vifpk.harness import testing

    import vifpk

    for w in registry.workflows():
        if w.api is not None:
            assert getattr(vifpk, w.name) is resolved(w.api) and w.name in vifpk.__all__
        if w.assertion is not None:
            fn = resolved(w.assertion)
            assert testing.assertion(w.name) is fn
            assert getattr(vifpk, fn.__name__) is fn
    assert {"solve", "check", "sweep", "passage", "transient"} <= set(vifpk.__all__)
    with_entry("tests.test_workflow_registry:HELLO")
    assert vifpk.hello("paper-base", loud=True) == "hello paper-base!"
    assert vifpk.run("hello", "paper-base") == "hello paper-base"
    vifpk.assert_hello("x", says="hello x")
    assert testing.assertion("hello") is assert_hello
    assert {"hello", "assert_hello"} <= set(vifpk.__all__)
    with pytest.raises(vifpk.core.result.BadInput,
                       match="allowed: check, passage, solve, sweep, transient"):
        vifpk.run("models")


def test_a_broken_workflow_entry_is_one_line_naming_it(with_entry, capsys):
    """It blocks none of vifpk's own commands (issue 39, W01); asked for, it fails in one line
    naming it, exit 3."""
    from vifpk.harness.cli.app import main

    with_entry("tests.test_workflow_registry:NOT_A_WORKFLOW")
    assert main(["models"]) == 0
    capsys.readouterr()
    assert main(["hello", "paper-base"]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "workflow 'hello'" in err, err


def test_every_builtin_reference_names_a_function():
    """The built-in records name their parts by Ref (a string): each must import and be
    callable, and its ``name`` is the function's own (vifpk.<name> for an assertion)."""
    refs = [(w.name, k, getattr(w, k)) for w in registry.workflows() if w.name != "hello"
            for k in ("add_arguments", "command", "sweep_point", "api", "assertion")
            if isinstance(getattr(w, k), Ref)]
    assert len(refs) >= 20
    for name, k, ref in refs:
        fn = ref.load()
        assert callable(fn) and fn.__name__ == ref.name, (name, k, ref)


def test_the_registry_and_the_argument_builders_load_no_front_end():
    """Every built-in record lives in the workflows layer or below (tests/test_layers.py: no
    module there imports a layer above it, function-local imports included), so loading the
    registry imports no command line, sweep, Python or testing API; and the argparse builders
    import neither vifpk.api nor the testing API (issue 38: the records lived in harness/cli
    and imported vifpk.api, so vifpk.solve was reached by importing argparse builders). Static,
    by the AST scan: a fresh interpreter would cost ~1 s of imports."""
    from importlib import metadata

    from tests.conftest import ROOT
    from tests.test_architecture import imported_modules
    from tests.test_layers import LAYERS, package_of

    own = [ep.value.partition(":")[0] for ep in
           metadata.entry_points(group=registry.WORKFLOW_GROUP)
           if ep.dist is not None and ep.dist.metadata["Name"] == registry.DISTRIBUTION]
    assert len(own) >= 10
    assert all(LAYERS[package_of(m)] <= LAYERS["vifpk.harness.workflows"] for m in own), own
    builders = imported_modules(ROOT / "harness" / "cli" / "arguments.py")
    assert not {m for m in builders if m.startswith(("vifpk.api", "vifpk.harness.testing",
                                                     "vifpk.harness.sweeps"))}, builders


def test_the_help_order_does_not_depend_on_the_registry_order(monkeypatch):
    """vifpk's own subcommands keep cli/app.py's ORDER whatever order the installed metadata
    gives (an editable install and a wheel gave two orders, issue 38)."""
    from vifpk.harness.cli.app import ORDER, build_parser

    ws = registry.workflows()
    names = []
    for order in (ws, tuple(reversed(ws))):
        monkeypatch.setattr(registry, "workflows", lambda order=order: order)
        names.append(list(build_parser()._subparsers._group_actions[0].choices))
    assert names[0] == names[1] == [n for n in ORDER if n in names[0]]
