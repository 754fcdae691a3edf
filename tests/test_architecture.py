"""The rooms and the one-way flow (docs/architecture.md), checked on the source by an AST scan:

- ``harness/door/`` is the only harness package that imports a solver package (``averaging``,
  ``fpk``, ``montecarlo``): every workflow reaches the solvers through it, and it imports no
  harness module outside itself;
- no module of any package of ours over ``MAX_LINES`` lines (the numba-kernel modules
  included: the last exemption ended with issue 44);
- the harness is in layers: no import cycle between its modules (imports inside functions
  count), every sub-package named in docs/architecture.md;
- a solver package imports neither ``harness`` nor another solver package: of ours, only
  ``vifpk.core`` (the shared vocabulary);
- ``vifpk.core`` imports no solver, no ``harness`` and nothing of ``vifpk`` outside itself;
  ``import vifpk`` / ``import vifpk.core`` in a fresh interpreter load no solver and no harness.

Imports anywhere in a module count (inside functions too), so a lazy import cannot hide.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from functools import cache
from pathlib import Path

import pytest

from tests.conftest import ROOT

SOLVERS = ("averaging", "fpk", "fpk2d", "montecarlo")
DOOR = Path("harness") / "door"
MAX_LINES = 500  # issue 27: "no module over ~500 lines except the numba kernel"
#: every package of ours: the line rule holds in each (issue 38: not the harness only)
PACKAGES = ("vifpk", "averaging", "fpk", "fpk2d", "montecarlo", "harness")
CORE = "vifpk.core"
PHYSICS = "vifpk.physics"  # issue 37: the physics every solver reads, on the core only


def parsed(path: Path) -> ast.Module:
    """The syntax tree of a source file, parsed once a session per text (every scan here and
    in tests/test_layers.py reads the same ~100 files; parsing them is ~0.4 s)."""
    return _parse(path.read_text(encoding="utf-8"), str(path))


@cache
def _parse(text: str, filename: str) -> ast.Module:
    return ast.parse(text, filename=filename)


def nodes(path: Path) -> tuple[ast.AST, ...]:
    """Every node of a source file's tree (``ast.walk``), listed once a session per text."""
    return _nodes(path.read_text(encoding="utf-8"), str(path))


@cache
def _nodes(text: str, filename: str) -> tuple[ast.AST, ...]:
    return tuple(ast.walk(_parse(text, filename)))


@cache
def _imported(text: str, filename: str) -> frozenset[str]:
    found: set[str] = set()
    for node in _nodes(text, filename):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module)
            if node.module.startswith("vifpk"):  # from vifpk.x import y: y may be a module
                found.update(f"{node.module}.{a.name}" for a in node.names)
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and node.func.attr == "import_module" and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            found.add(node.args[0].value)
    return frozenset(found)


def imported_modules(path: Path) -> set[str]:
    """Dotted names of the modules a module imports (absolute imports; relative ones stay in
    their own package)."""
    return set(_imported(path.read_text(encoding="utf-8"), str(path)))


def imported_packages(path: Path) -> set[str]:
    """Packages of ours a module imports: a solver, ``harness``, ``vifpk.core`` (the shared
    vocabulary) or ``vifpk`` (the public API, anything of vifpk outside its core)."""
    found: set[str] = set()
    for name in imported_modules(path):
        parts = name.split(".")
        if parts[0] in {*SOLVERS, "harness"}:
            raise AssertionError(f"{path}: imports {name}; every module of ours is vifpk.*")
        if parts[0] != "vifpk":
            continue
        if len(parts) > 1 and parts[1] in {*SOLVERS, "harness"}:
            found.add(parts[1])
        elif name == CORE or name.startswith(CORE + "."):
            found.add(CORE)
        elif name == PHYSICS or name.startswith(PHYSICS + "."):
            found.add(PHYSICS)
        else:
            found.add("vifpk")
    return found


def modules(package: str) -> list[Path]:
    return sorted((ROOT / package).rglob("*.py"))


def test_the_scan_sees_imports(tmp_path: Path):
    """The scanner itself: plain, from-, nested and importlib imports are all found."""
    src = tmp_path / "m.py"
    src.write_text("import vifpk.fpk.scheme\nfrom . import x\n"
                   "def f():\n    from vifpk.montecarlo.kernels import k\n"
                   "    import importlib\n    importlib.import_module('vifpk.averaging.exact')\n")
    assert imported_packages(src) == {"fpk", "montecarlo", "averaging"}
    src.write_text("from vifpk import harness, solve\n")
    assert imported_packages(src) == {"harness", "vifpk"}
    src.write_text("import averaging\n")
    with pytest.raises(AssertionError, match="every module of ours is vifpk"):
        imported_packages(src)
    src.write_text("import vifpk.core.scene\nfrom vifpk import solve\nimport numpy\n")
    assert imported_packages(src) == {CORE, "vifpk"}


@pytest.mark.parametrize("path", modules("harness"), ids=lambda p: str(p.relative_to(ROOT)))
def test_only_the_door_imports_the_solvers(path: Path):
    rel = path.relative_to(ROOT)
    solvers = imported_packages(path) & set(SOLVERS)
    if DOOR not in rel.parents:
        assert not solvers, f"{rel} imports {sorted(solvers)}: go through harness/door/"


def test_the_door_knows_every_solver():
    found = set().union(*(imported_packages(p) for p in modules(str(DOOR))))
    assert found & set(SOLVERS) == set(SOLVERS)


@pytest.mark.parametrize("package", SOLVERS)
def test_solvers_import_neither_the_harness_nor_each_other(package: str):
    """Of ours, a solver imports only itself, the shared vocabulary ``vifpk.core`` and the
    physics ``vifpk.physics``."""
    bad = {str(p.relative_to(ROOT)): sorted(imported_packages(p) - {package, CORE, PHYSICS})
           for p in modules(package)}
    bad = {k: v for k, v in bad.items() if v}
    assert not bad, bad


def test_the_physics_imports_only_the_core_and_no_numba():
    """vifpk.physics sits on the core alone (docs/architecture.md), plain Python: the Monte
    Carlo compiles its pieces with its own jit."""
    paths = modules("vifpk/physics")
    bad = {str(p.relative_to(ROOT)): sorted(imported_packages(p) - {CORE, PHYSICS})
           for p in paths}
    bad = {k: v for k, v in bad.items() if v}
    assert not bad, bad
    assert not [p for p in paths if "numba" in imported_modules(p)]


def test_the_core_imports_nothing_above_it():
    bad = {str(p.relative_to(ROOT)): sorted(imported_packages(p) - {CORE})
           for p in modules("vifpk/core")}
    bad = {k: v for k, v in bad.items() if v}
    assert not bad, bad


@pytest.mark.parametrize("statement", ["import vifpk.core", "import vifpk",
                                       "import vifpk.core.scene"])
def test_importing_the_core_or_the_api_loads_no_solver_and_no_harness(statement: str):
    """In a fresh interpreter: the public API is lazy (module ``__getattr__``)."""
    code = (f"{statement}; import sys; "
            "print(' '.join(sorted({'.'.join(m.split('.')[:2]) if m.startswith('vifpk.') else "
            "m.split('.')[0] for m in sys.modules})))")
    res = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, timeout=120, check=True)
    loaded = set(res.stdout.split())
    assert "vifpk" in loaded
    ours = {f"vifpk.{p}" for p in (*SOLVERS, "harness")}
    assert not loaded & {*SOLVERS, "harness", *ours, "numba", "pde", "matplotlib"}, loaded


# ------------------------------------------------- unknown kinds raise: no silent fallbacks
def _pink(base):
    from dataclasses import replace
    from types import SimpleNamespace

    noise = SimpleNamespace(kind="pink", params=base.noise.params, values=base.noise.values)
    return replace(base, noise=noise)


@pytest.mark.parametrize("model", ["paper", "exact"])
def test_averaging_rejects_an_unknown_noise_kind(base, model):
    from vifpk import averaging

    with pytest.raises(ValueError, match="noise kind must be one of .* not 'pink'"):
        averaging.solve(_pink(base), model=model)


def test_averaging_rejects_unknown_options(base):
    from vifpk.averaging.exact import ExactModel

    from vifpk import averaging

    with pytest.raises(ValueError, match="model must be one of"):
        averaging.solve(base, model="corrected-by-magic")
    with pytest.raises(ValueError, match="impact must be one of"):
        averaging.solve(base, model="exact", impact="plastic")
    with pytest.raises(ValueError, match="noise must be one of"):
        averaging.solve(base, model="exact", noise="multiplicative")
    with pytest.raises(ValueError, match="b6 must be one of"):
        averaging.solve(base, model="paper", b6="guessed")
    good = ExactModel.from_scene(base)
    with pytest.raises(ValueError, match="impact must be one of"):
        type(good)(**{**good.__dict__, "impact": "plastic"})


def test_fpk_rejects_unknown_methods_and_steppers():
    import numpy as np

    from vifpk import fpk

    def m(A):
        return 1.0 / A - A

    def s2(A):
        return 2.0 + 0.0 * A

    with pytest.raises(ValueError, match="method must be"):
        fpk.stationary(m, s2, cells=50, method="guess", lo=0.0, hi=4.0)
    with pytest.raises(ValueError, match="stepper must be one of"):
        fpk.stationary(m, s2, cells=50, method="stepping", stepper="euler", lo=0.0, hi=4.0)
    assert np.isfinite(fpk.stationary(m, s2, cells=50, method="direct", lo=0.0,
                                      hi=4.0).data["A"]["p"]).all()


def test_montecarlo_rejects_an_unknown_noise_kind(base):
    """(The Monte Carlo's own test is tests/test_montecarlo.py::test_unknown_noise_kind_raises;
    here through the door, as every workflow calls it.)"""
    from vifpk.harness.door.solvers import run_solver

    with pytest.raises(ValueError, match="noise kind must be one of"):
        run_solver(_pink(base), "montecarlo")


def test_run_rejects_an_unknown_solver(base):
    from vifpk.harness.door.solvers import run_solver

    with pytest.raises(ValueError, match="solver must be one of"):
        run_solver(base, "oracle")


# ------------------------------------------------- docs/architecture.md names every module
def _rooms() -> dict[str, set[str]]:
    """room -> the module file names its table row in docs/architecture.md names."""
    import re

    rows = {}
    for line in (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8").splitlines():
        m = re.match(r"\| `([\w/]+)/` \| (.*?) \|", line)
        if m:
            rows[m.group(1)] = set(re.findall(r"`(?:[\w/]+/)?(\w+\.py)`", m.group(2)))
    return rows


HARNESS_ROOMS = ["harness", *sorted(str(p.parent.relative_to(ROOT))
                                      for p in (ROOT / "harness").glob("*/__init__.py"))]


@pytest.mark.parametrize("room", ["vifpk", "vifpk/core", "vifpk/physics", *SOLVERS,
                                  *HARNESS_ROOMS])
def test_architecture_names_every_module_and_no_other(room: str):
    """vifpk/physics is named with its sub-packages (noise/, impact/: their ``__init__.py``
    included); every other room by its own files."""
    named = _rooms()[room]
    if room == "vifpk/physics":
        actual = {p.name for p in (ROOT / room).rglob("*.py")
                  if p.parent != ROOT / room or p.name != "__init__.py"}
    else:
        actual = {p.name for p in (ROOT / room).glob("*.py")} - {"__init__.py"} | (
            {"__init__.py"} if room == "vifpk" else set())
    assert named == actual, (f"docs/architecture.md, room {room}/: missing "
                             f"{sorted(actual - named)}, not existing {sorted(named - actual)}")


def test_the_door_imports_no_harness_module():
    """harness/door/, the door to the solvers, is called by every workflow and calls none of
    them: of ours it imports the solvers, vifpk.core and its own modules only (issue 27:
    run.py and validate.py imported each other; the cost guard's words now wrap the door from
    the request layer)."""
    for path in modules(str(DOOR)):
        relative = [n.module for n in nodes(path) if isinstance(n, ast.ImportFrom) and n.level]
        assert not relative, (path, relative)
        outside = {m for m in imported_modules(path)
                   if m.startswith("vifpk.harness") and not m.startswith("vifpk.harness.door")}
        assert not outside, (path, outside)


def _harness_modules() -> dict[str, Path]:
    out = {}
    for p in modules("harness"):
        parts = ("vifpk", *p.relative_to(ROOT).with_suffix("").parts)
        out[".".join(parts).removesuffix(".__init__")] = p
    return out


def test_no_module_over_the_line_limit():
    """Every module of every package of ours (vifpk/, averaging/, fpk/, fpk2d/, montecarlo/,
    harness/) has at most MAX_LINES lines, numba kernels included (splitting_kernels.py, the
    last exempt one, split into splitting_lanes.py in issue 44)."""
    over = {}
    for package in PACKAGES:
        for path in modules(package):
            name = path.relative_to(ROOT).as_posix()
            n = len(path.read_text(encoding="utf-8").splitlines())
            if n > MAX_LINES:
                over[name] = n
    assert not over, f"over {MAX_LINES} lines, split them: {over}"


def test_no_import_cycles_in_the_harness():
    """Tarjan's strongly connected components of the harness's import graph (every import,
    inside functions too): none larger than one module."""
    mods = _harness_modules()
    graph = {m: {d for d in imported_modules(p) if d in mods} for m, p in mods.items()}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    assert not cycles, cycles


def test_the_cycle_check_sees_a_cycle(tmp_path: Path):
    """The scanner the cycle test relies on finds a function-local import."""
    src = tmp_path / "m.py"
    src.write_text("def f():\n    from vifpk.harness.sweeps import spec\n")
    assert "vifpk.harness.sweeps.spec" in imported_modules(src)


@pytest.mark.parametrize("path", modules("harness"), ids=lambda p: str(p.relative_to(ROOT)))
def test_harness_imports_are_absolute_and_resolve(path: Path):
    """Every harness import of ours is written vifpk.harness.<layer>.<module> and names a
    module that exists (a relative import inside a function survived the move to layers and
    failed only when a slow test reached it: the fresh-clone CI's three failures at 49a2b7c)."""
    relative = [n.module for n in nodes(path) if isinstance(n, ast.ImportFrom) and n.level]
    assert not relative, relative
    mods = set(_harness_modules())
    packages = {m.rsplit(".", 1)[0] for m in mods} | {"vifpk.harness"}
    for node in nodes(path):
        if isinstance(node, ast.ImportFrom) and node.module and \
                node.module.startswith("vifpk.harness"):
            assert node.module in mods or node.module in packages, node.module
            if node.module in packages:  # from vifpk.harness.sweeps import spec: a module
                for a in node.names:
                    assert f"{node.module}.{a.name}" in mods, f"{node.module}.{a.name}"


def test_door_results_do_not_depend_on_the_blas_thread_count(base):
    """The exact model's closed form at the point where a dask sweep and a serial one differed
    (1e-15, tests/test_adaptive.py): the same bits whatever BLAS thread count the caller's
    process has (dask workers run with 1, a serial run with the machine's cores): the door
    pins BLAS to one thread (harness/door/boundary.py: one_blas_thread)."""
    import numpy as np
    from threadpoolctl import threadpool_limits
    from vifpk.harness.door.solvers import closed_form

    sc = base.with_values({"system.r": 0.99, "system.mu": 0.0, "averaging.harmonics": 8,
                           "averaging.theta_nodes": 16, "averaging.points": 101,
                           "averaging.phase_points": 41})
    out = []
    for threads in (1, 2):
        with threadpool_limits(limits=threads, user_api="blas"):
            out.append(closed_form(sc, model="exact", tail_mass=False))
    for o in ("A", "x1", "x2"):
        assert np.array_equal(out[0].data[o]["p"], out[1].data[o]["p"]), o


# ------------------------------------------------- the rest of docs/architecture.md's rules
#: trees of ours and the packages in them where a relative import is written (level 1 only,
#: a sibling module of the same package): the core and the three solvers
RELATIVE_OK = ("vifpk/core", *SOLVERS)


def _all_sources() -> list[Path]:
    return sorted(p for t in ("vifpk", *SOLVERS, "harness") for p in (ROOT / t).rglob("*.py"))


def test_relative_imports_stay_in_their_own_package():
    """docs/architecture.md, "One installed name": across packages every import of ours is
    written vifpk.<package>; a relative import is a sibling of the same package (level 1),
    written only in the core and the solvers (the harness, the physics and the API have none).
    The layer scans read absolute imports only, so this is what keeps them complete."""
    bad = []
    for p in _all_sources():
        rel = str(p.relative_to(ROOT))
        for n in nodes(p):
            if isinstance(n, ast.ImportFrom) and n.level and (
                    n.level > 1 or not rel.startswith(tuple(r + "/" for r in RELATIVE_OK))):
                bad.append(f"{rel}:{n.lineno} {'.' * n.level}{n.module or ''}")
    assert not bad, bad


def test_no_branch_on_a_noise_kind_or_an_impact_law_name():
    """docs/architecture.md, "Unknown kinds raise" and the recipes: no ``kind == "ou"`` (or
    ``!=``, ``in``) on a registered noise kind's or impact law's name outside the core's
    schema: a kind's behaviour is its module's pieces (vifpk.physics), so a third kind edits
    no solver. Allowed: vifpk/core (the scene's defaults and the paper's own wall: Newton's
    law at x = 0) and montecarlo/reference.py (the NumPy reference of the two kinds, a test
    double)."""
    from vifpk.core.registry import impact_law_names, noise_kind_names

    names = {*noise_kind_names(), *impact_law_names()}
    allowed = ("vifpk/core/", "montecarlo/reference.py")
    bad = []
    for p in _all_sources():
        rel = str(p.relative_to(ROOT))
        if rel.startswith(allowed):
            continue
        for n in nodes(p):
            if not isinstance(n, ast.Compare):
                continue
            consts = [c for side in (n.left, *n.comparators)
                      for c in ([side] if not isinstance(side, (ast.Tuple, ast.List, ast.Set))
                                else side.elts)]
            if any(isinstance(c, ast.Constant) and c.value in names for c in consts):
                bad.append(f"{rel}:{n.lineno}")
    assert not bad, bad


def _architecture() -> str:
    return (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")


def test_architecture_names_every_shared_default():
    """"One home for every shared word": the sentence lists every constant of
    vifpk/core/defaults.py."""
    import vifpk.core.defaults as d

    text = _architecture()
    missing = [n for n in vars(d) if n.isupper() and f"`{n}`" not in text]
    assert not missing, missing


def test_the_door_functions_named_exist():
    """The door's functions docs/architecture.md names (the rule "harness/door/ is the only
    harness package that imports a solver") are functions of harness/door/."""
    import re

    text = _architecture()
    listed = text.split("call its functions", 1)[1].split(").", 1)[0]
    names = re.findall(r"`(\w+)`", listed)
    defined = {n.name for p in modules(str(DOOR)) for n in nodes(p)
               if isinstance(n, ast.FunctionDef)}
    assert len(names) >= 10 and not set(names) - defined, set(names) - defined


def test_no_module_reads_pyproject_at_run_time():
    """The registries come from the installed metadata only, the same in an editable install
    and a wheel (issue 38 item 4: vifpk/core/registry.py read vifpk's own entry points from
    pyproject.toml in a source checkout, so the two gave two orders): no code of ours names
    pyproject.toml outside docstrings and comments."""
    bad = []
    for p in _all_sources():
        if "pyproject" not in p.read_text(encoding="utf-8"):
            continue
        docs = {id(n.body[0].value) for n in nodes(p)
                if isinstance(n, (ast.Module, ast.FunctionDef, ast.ClassDef,
                                  ast.AsyncFunctionDef))
                and n.body and isinstance(n.body[0], ast.Expr)
                and isinstance(n.body[0].value, ast.Constant)}
        bad += [f"{p.relative_to(ROOT)}:{n.lineno}" for n in nodes(p)
                if isinstance(n, ast.Constant) and isinstance(n.value, str)
                and "pyproject" in n.value and id(n) not in docs]
    assert not bad, bad


def test_the_api_doc_names_every_status():
    """docs/api.md's table names every member of vifpk.core.result.Status (it had lost one)."""
    from vifpk.core.result import Status

    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    row = next(line for line in text.splitlines() if line.startswith("| `vifpk.Status`"))
    missing = [m.name for m in Status if f"`{m.name}`" not in row and f"`Status.{m.name}`"
               not in row]
    assert not missing, missing


@pytest.mark.parametrize("package", SOLVERS)
def test_solvers_read_the_scene_duck_typed(package: str):
    """docs/architecture.md: a solver reads plain numbers from the scene it is given
    (duck-typed): it never imports ``Scene`` and never asks ``isinstance`` of a scene class,
    so any object with the attributes will do (the core's schema functions, ``no_noise``, and
    a section's defaults, ``Observables().names()``, are used as such)."""
    classes = {"Scene", "Noise", "AveragingSettings", "MonteCarloSettings", "Observables",
               "System", "Wall", "Parametric", "Sweep"}
    bad = [f"{p.relative_to(ROOT)}:{n.lineno} imports Scene" for p in modules(package)
           for n in nodes(p) if isinstance(n, ast.ImportFrom)
           and (n.module or "").startswith(CORE) and any(a.name == "Scene" for a in n.names)]
    bad += [f"{p.relative_to(ROOT)}:{n.lineno} isinstance" for p in modules(package)
            for n in nodes(p) if isinstance(n, ast.Call) and getattr(n.func, "id", "") ==
            "isinstance" and len(n.args) == 2 and any(
                isinstance(c, ast.Name) and c.id in classes
                for c in ([n.args[1]] if not isinstance(n.args[1], ast.Tuple)
                          else n.args[1].elts))]
    assert not bad, bad
