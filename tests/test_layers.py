"""Layers that hold, checked on packages (issue 38): an AST scan of every module of ours,
imports inside functions included (tests/test_architecture.py's scanner).

The order, lowest first (docs/architecture.md, "The one-way flow")::

    vifpk.core < vifpk.physics < the solvers (averaging, fpk, montecarlo)
      < harness.door < harness.request < harness.workflows < harness.outputs
      < (harness.sweeps, harness.testing + harness.pytest_plugin, vifpk.api, harness.cli)

A module may import its own layer and the layers below; never one above. Inside the top
layer, the Python API, the testing API and the command line are front ends beside each other:
none of the three imports another (the command line and the sweeps may share the sweeps), and
the sweeps do not import the command line. The solvers of layer 1 never import
each other (tests/test_architecture.py checks that too); ``vifpk.physics`` (what the system
is, written once for every solver) sits on the core alone. ``vifpk/__init__.py``,
``vifpk/__main__.py``, ``harness/__init__.py`` and ``harness/__main__.py`` are entry points
above every layer.

Private names stay in their package: ``from x import _y`` and ``x._y`` of a module of ours
outside the package ``_y`` is defined in are counted, and none is allowed.
"""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

import pytest

from tests.conftest import ROOT
from tests.test_architecture import imported_modules, nodes

#: package -> its layer (lowest 0); a module belongs to the longest package prefix of its name.
LAYERS: dict[str, int] = {
    "vifpk.core": 0,
    "vifpk.physics": 1,
    "vifpk.averaging": 2, "vifpk.fpk": 2, "vifpk.fpk2d": 2, "vifpk.montecarlo": 2,
    "vifpk.harness.door": 3,
    "vifpk.harness.request": 4,
    "vifpk.harness.workflows": 5,
    "vifpk.harness.outputs": 6,
    "vifpk.harness.sweeps": 7, "vifpk.harness.testing": 7, "vifpk.harness.pytest_plugin": 7,
    "vifpk.api": 7, "vifpk.harness.cli": 7,
}
SOLVERS = 2
#: Inside the top layer: who must not import whom.
TOP_FORBIDDEN = {
    ("vifpk.api", "vifpk.harness.cli"),
    ("vifpk.harness.testing", "vifpk.harness.cli"),
    ("vifpk.harness.pytest_plugin", "vifpk.harness.cli"),
    ("vifpk.harness.sweeps", "vifpk.harness.cli"),
    ("vifpk.harness.cli", "vifpk.api"),
    ("vifpk.harness.cli", "vifpk.harness.testing"),
    ("vifpk.api", "vifpk.harness.testing"),
    ("vifpk.harness.testing", "vifpk.api"),
    ("vifpk.harness.pytest_plugin", "vifpk.api"),
}
#: Edges still waiting for their owner's change, each with the reason. Only shrinks: an entry
#: that no longer occurs fails test_pending_edges_still_exist (delete it then).
PENDING: dict[tuple[str, str], str] = {}
#: Private names still used across packages, with the reason; only shrinks, as PENDING.
PENDING_PRIVATE: dict[str, str] = {
    "from vifpk.harness.workflows.passage import _fpt": "outputs/timereport.py; both modules "
    "belong to the time domain's rework (helper timedomain)",
}
TREES = ("vifpk", "averaging", "fpk", "fpk2d", "montecarlo", "harness")


def module_name(path: Path) -> str:
    """The installed dotted name of a source file (harness/x.py -> vifpk.harness.x)."""
    parts = path.relative_to(ROOT).with_suffix("").parts
    if parts[0] != "vifpk":
        parts = ("vifpk", *parts)
    return ".".join(parts).removesuffix(".__init__")


def package_of(name: str) -> str | None:
    """The layered package a dotted name belongs to (longest prefix), None if none."""
    best = None
    for pkg in LAYERS:
        if (name == pkg or name.startswith(pkg + ".")) and (best is None or len(pkg) > len(best)):
            best = pkg
    return best


def sources() -> list[Path]:
    return sorted(p for t in TREES for p in (ROOT / t).rglob("*.py"))


def violations(path: Path) -> set[tuple[str, str]]:
    """(package, imported package) of every import of ``path`` that climbs, or crosses a
    forbidden edge of the top layer or between solvers."""
    src = package_of(module_name(path))
    if src is None:
        return set()
    out = set()
    for name in imported_modules(path):
        dst = package_of(name)
        if dst is None or dst == src:
            continue
        if (LAYERS[dst] > LAYERS[src] or (src, dst) in TOP_FORBIDDEN
                or LAYERS[src] == LAYERS[dst] == SOLVERS):
            out.add((src, dst))
    return out


@cache
def edges() -> dict[tuple[str, str], list[str]]:
    """Every violating package edge -> the modules that make it."""
    found: dict[tuple[str, str], list[str]] = {}
    for p in sources():
        for e in violations(p):
            found.setdefault(e, []).append(str(p.relative_to(ROOT)))
    return found


def test_the_scan_sees_a_climbing_import(tmp_path: Path, monkeypatch):
    """The scanner itself, on a file placed as harness/workflows/x.py: a function-local import
    of outputs climbs; one of the door does not."""
    import tests.test_layers as me

    (tmp_path / "harness" / "workflows").mkdir(parents=True)
    src = tmp_path / "harness" / "workflows" / "x.py"
    src.write_text("from vifpk.harness.door import solvers\n"
                   "def f():\n    from vifpk.harness.outputs.report import write\n")
    monkeypatch.setattr(me, "ROOT", tmp_path)
    assert violations(src) == {("vifpk.harness.workflows", "vifpk.harness.outputs")}
    src.write_text("import vifpk.harness.cli.app\n")
    assert violations(src) == {("vifpk.harness.workflows", "vifpk.harness.cli")}
    api = tmp_path / "vifpk" / "api.py"
    api.parent.mkdir()
    api.write_text("def f():\n    from vifpk.harness.cli.timedomain import g\n")
    assert violations(api) == {("vifpk.api", "vifpk.harness.cli")}


def test_every_module_is_in_a_layer_or_an_entry_point():
    """A new package must be given its layer here (else the test above would not see it)."""
    entry = {"vifpk", "vifpk.__main__", "vifpk.harness", "vifpk.harness.__main__"}
    loose = [module_name(p) for p in sources()
             if package_of(module_name(p)) is None and module_name(p) not in entry]
    assert not loose, loose


def test_no_package_imports_a_layer_above_it():
    bad = {f"{a} -> {b}": mods for (a, b), mods in edges().items() if (a, b) not in PENDING}
    assert not bad, bad


def test_pending_edges_still_exist():
    found = edges()
    stale = [e for e in PENDING if e not in found]
    assert not stale, f"fixed, delete from PENDING: {stale}"


# ------------------------------------------------------------ private names stay home
def _private_uses(path: Path) -> list[str]:
    """``from vifpk.x import _y`` and ``vifpk.x._y`` (through an alias of an imported module
    of ours) in ``path``, where vifpk.x is outside the package of ``path``."""
    me = module_name(path)
    home = me.rsplit(".", 1)[0] if path.name != "__init__.py" else me
    everything = nodes(path)
    out = []
    aliases: dict[str, str] = {}
    for node in everything:
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module and \
                node.module.startswith("vifpk"):
            for a in node.names:
                full = f"{node.module}.{a.name}"
                aliases[a.asname or a.name] = full
                if a.name.startswith("_") and not a.name.startswith("__") and \
                        not _inside(node.module, home):
                    out.append(f"from {node.module} import {a.name}")
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("vifpk"):
                    aliases[a.asname or a.name] = a.name
    for node in everything:
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") and \
                not node.attr.startswith("__"):
            base = node.value
            dotted = []
            while isinstance(base, ast.Attribute):
                dotted.append(base.attr)
                base = base.value
            if isinstance(base, ast.Name) and base.id in aliases:
                target = ".".join([aliases[base.id], *reversed(dotted)])
                if not _inside(target, home):
                    out.append(f"{target}.{node.attr}")
    return out


def _inside(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def test_the_private_scan_sees_both_forms(tmp_path: Path, monkeypatch):
    import tests.test_layers as me

    (tmp_path / "harness" / "cli").mkdir(parents=True)
    src = tmp_path / "harness" / "cli" / "x.py"
    src.write_text("from vifpk.harness.sweeps import points\n"
                   "from vifpk.harness.cli.options import _ok\n"
                   "from vifpk.core.scene import _bad\n"
                   "f = points._check_point\n")
    monkeypatch.setattr(me, "ROOT", tmp_path)
    assert sorted(_private_uses(src)) == ["from vifpk.core.scene import _bad",
                                          "vifpk.harness.sweeps.points._check_point"]


@cache
def _all_private_uses() -> dict[str, list[str]]:
    return {str(p.relative_to(ROOT)): u for p in sources() if (u := _private_uses(p))}


def test_no_private_name_is_used_outside_its_package():
    bad = {k: [x for x in u if x not in PENDING_PRIVATE]
           for k, u in _all_private_uses().items()}
    bad = {k: u for k, u in bad.items() if u}
    assert not bad, bad


def test_pending_private_uses_still_exist():
    found = {x for u in _all_private_uses().values() for x in u}
    stale = [x for x in PENDING_PRIVATE if x not in found]
    assert not stale, f"fixed, delete from PENDING_PRIVATE: {stale}"


# ------------------------------------------------------------ no hidden context
def test_no_context_variable_in_the_harness():
    """What a run needs (cost limit, checkpoint) is passed through the workflows' signatures
    (harness.door.solvers.MonteCarloRun), not carried by a ContextVar a thread pool would lose
    (issue 38: door/solvers.py had two, door/boundary.py one)."""
    found = [str(p.relative_to(ROOT)) for p in sorted((ROOT / "harness").rglob("*.py"))
             if "ContextVar" in p.read_text(encoding="utf-8") or
             "contextvars" in p.read_text(encoding="utf-8")]
    assert not found, found


def test_no_library_module_switches_matplotlib_state():
    """No module of ours calls ``matplotlib.use`` or imports ``matplotlib.pyplot`` (global
    state: the backend, the figure registry); figures are drawn on their own Agg canvas
    (vifpk/core/io.py: figures), issue 38."""
    bad = []
    for p in sources():
        for node in nodes(p):
            if isinstance(node, ast.Attribute) and node.attr == "use" and \
                    isinstance(node.value, ast.Name) and node.value.id == "matplotlib":
                bad.append(f"{p.relative_to(ROOT)}:{node.lineno} matplotlib.use")
        if "matplotlib.pyplot" in imported_modules(p):
            bad.append(f"{p.relative_to(ROOT)} imports matplotlib.pyplot")
    assert not bad, bad


def test_no_blanket_suppress():
    """No ``contextlib.suppress(Exception)`` (or BaseException) anywhere of ours: it hid a
    second parser of the sweep file and plugin code run during validation (issue 38)."""
    bad = []
    for p in sources():
        for node in nodes(p):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(
                    node.func, "id", None)) == "suppress" and any(
                    isinstance(a, ast.Name) and a.id in ("Exception", "BaseException")
                    for a in node.args):
                bad.append(f"{p.relative_to(ROOT)}:{node.lineno}")
    assert not bad, bad


@pytest.mark.slow
def test_loading_the_workflow_registry_imports_no_front_end():
    """docs/architecture.md: the built-in workflows' records name their command-line parts,
    sweep points and Python functions by ``Ref``, so loading the registry (every registered
    workflow's record) imports neither the command line nor the Python API nor the sweeps. A
    fresh interpreter (slow tier: ~1.5 s)."""
    import subprocess
    import sys

    code = ("import sys; from vifpk.core import registry; ws = registry.workflows(); "
            "print(len(ws)); print(' '.join(sorted(m for m in sys.modules "
            "if m.startswith(('vifpk.harness.cli', 'vifpk.api', 'vifpk.harness.sweeps')))))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, timeout=120, check=True).stdout.splitlines()
    assert int(out[0]) >= 9 and (out[1:] == [] or out[1] == ""), out
