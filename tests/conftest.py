"""Shared fixtures: the paper's base scene and helpers to vary it.

In the style of py-pde's conftest: every test runs with numpy floating-point errors raised
(``divide``, ``over``, ``invalid``; underflow ignored), so a NaN or inf that nobody expects
fails the test where it is made instead of travelling into a density. A test that expects them
says so with ``@pytest.mark.numpy_errors_ok`` (with the reason in its docstring). Matplotlib
figures left open by a test are closed after it.

The fast tier tests output writing, interruption, rendering and sweeps on canned input: one
cross-check of the tiny scene (``tiny_check``, tests/data/tiny.toml: small, not physics) is
computed once a session, and ``canned_check`` makes every ``cross_check`` return it.
"""

from __future__ import annotations

import copy
import os
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import settings as hypothesis_settings

from vifpk.core.scene import Scene, load_scene

ROOT = Path(__file__).resolve().parent.parent
TINY = ROOT / "tests" / "data" / "tiny.toml"

# Property tests explore new random examples on every local run (that is how they find cases);
# in CI (CI=true) they draw a fixed sequence, so a landing is judged on the same examples every
# time and a new counterexample shows up first where someone can look at it.
hypothesis_settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    hypothesis_settings.load_profile("ci")
# The canned check is not extended: check doubles a run the evidence calls too short only
# while three times the time spent fits montecarlo.budget (harness/workflows/check.py), so a budget
# of
# 1 ms stops it on any machine (with floor = 0 the budget bounds nothing else).
TINY_CHECK_SET = ["montecarlo.budget=0.001"]


@pytest.fixture(autouse=True)
def _numpy_errors_raise_and_figures_close(request: pytest.FixtureRequest):
    if request.node.get_closest_marker("numpy_errors_ok") is not None:
        yield
    else:
        with np.errstate(all="raise", under="ignore"):
            yield
    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")


@pytest.fixture(scope="session")
def base() -> Scene:
    return load_scene(ROOT / "scenes" / "paper-base.toml")


@pytest.fixture(scope="session")
def tiny_check():
    """One cross-check (harness.workflows.check.cross_check) of the tiny scene, computed once a
    session: the canned input of the tests of writing, interruption, rendering and sweeps."""
    from vifpk.harness.cli.options import concrete_scene
    from vifpk.harness.workflows.check import cross_check

    return cross_check(concrete_scene(str(TINY), TINY_CHECK_SET), quiet=True)


@pytest.fixture
def canned_check(tiny_check, monkeypatch):
    """``harness.workflows.check.cross_check`` replaced by the tiny check, its scene swapped for
    the one asked (so titles, folders and sweep coordinates follow the request); ``models`` keeps
    only the models asked (their solutions, metrics and verdict lines; a model the canned check did
    not compute fails the test) and ``tolerance`` the question asked (the tolerance verdicts
    and the recommendation made again from the canned numbers); ``sde=False`` drops the
    averaged SDEs' runs as cross_check does. Commands that check then write, interrupt and
    render without computing. Returns the canned result."""
    import vifpk.harness.workflows.check

    def canned(scene, *, quiet=False, fpk=True, sde=True, tail_mass=True, models=None,
               tolerance=None, run=None, warm=None):  # run: no Monte Carlo runs, its state
        # stays None; warm: the caller's preparation beside the SDEs, none here
        res = replace(tiny_check, scene=scene, metrics=copy.deepcopy(tiny_check.metrics))
        if models is not None:
            keep = tuple(dict.fromkeys(models))
            missing = [m for m in keep if m not in res.models]
            assert not missing, f"the canned check has no model {missing}"
            drop = [m for m in res.models if m not in keep]
            res = replace(res, models=keep, solutions={
                k: v for k, v in res.solutions.items()
                if not any(k.endswith(f":{m}") for m in drop)})
            for m in drop:
                res.metrics["models"].pop(m)
            res.metrics["verdicts"] = [v for v in res.metrics["verdicts"]
                                       if not any(v.startswith(f"{m} model") for m in drop)]
            res = replace(res, verdicts=list(res.metrics["verdicts"]))
        if models is not None or tolerance is not None:  # the verdicts of what was asked
            from vifpk.harness.request.tolerance import Tolerance
            from vifpk.harness.workflows.tolerance import line, model_verdicts
            from vifpk.harness.workflows.verdict import recommend

            met = res.metrics
            tol = tolerance or Tolerance(**met["tolerance"])
            met["tolerance"] = tol.record()
            tv = model_verdicts(met, tol)
            for m, v in tv.items():
                met["models"][m]["tolerance"] = v
            met["tolerance_verdicts"] = [line(m, v) for m, v in tv.items()]
            rec = recommend(met, res.warnings, met["validity"],
                            convergence=met["monte_carlo"]["convergence"])
            met["recommended_model"], met["recommendation"] = rec
            res = replace(res, recommendation=rec[1],
                          tolerance_lines=tuple(met["tolerance_verdicts"]))
        if not fpk or not sde:
            drop = ([f"fpk:{m}" for m in res.models] if not fpk else []) + \
                   ([f"mc:{m}" for m in res.models] if not sde else [])
            res = replace(res, solutions={k: v for k, v in res.solutions.items()
                                          if k not in drop})
            for entry in res.metrics["models"].values():
                if not fpk:
                    entry.pop("discretisation_error", None)
                if not sde:
                    entry.pop("sampling_error", None)
                    entry["sampling_ok"] = None
        return res

    monkeypatch.setattr(vifpk.harness.workflows.check, "cross_check", canned)
    return tiny_check


def vary(scene: Scene, **kw: float | str | bool) -> Scene:
    """A copy of ``scene`` with system/noise/averaging fields replaced by name (the noise: its
    ``kind`` and that kind's declared parameters, the others kept or defaulted; a parameter of
    another kind only, e.g. alpha1 with kind = "white", does not apply and is dropped)."""
    from vifpk.core import registry
    from vifpk.core.scene import Noise

    parts: dict = {}
    used = set()
    for sec in ("system", "averaging"):
        obj = getattr(scene, sec)
        mine = {k: v for k, v in kw.items() if k in obj.__dict__}
        used |= set(mine)
        parts[sec] = replace(obj, **mine)
    kind = kw.get("kind", scene.noise.kind)
    declared = registry.noise_kind(kind).params
    parts["noise"] = Noise(kind=kind, params=tuple(
        (p.name, float(kw.get(p.name, scene.noise.values.get(p.name, p.default))))
        for p in declared))
    used |= {"kind", *(p.name for p in declared)}
    from vifpk.core.sections import noise_fields

    unknown = set(kw) - used - set(noise_fields())  # another kind's parameter: not this one's
    assert not unknown, unknown
    return replace(scene, **parts)


def phase_mass_gap(scene: Scene, result, model: str) -> float:
    """Largest relative gap between the phase-space masses an averaged solution had BEFORE its
    normalisation and their exact value.

    The phase densities are p(y, y') = p_A / (g T_model) (paper eq. 15-16). The orbit of
    amplitude A fills dy dy' = dE dt = g dA dt over its true period T, so their mass is
    int p_A T / T_model dA, computed here with the independent period quadrature of
    averaging.geometry (1 for the exact model; for the paper model T_model = 2 pi / b0). A
    wrong fold, Jacobian or period in the mapping shows up here; after normalisation it would
    not.
    """
    from vifpk.averaging import build_model
    from vifpk.averaging.geometry import period

    s = scene.system
    A, p = np.asarray(result.data["A"]["x"]), np.asarray(result.data["A"]["p"])
    Ai = np.maximum(A, 1e-12)  # T and T_model are regular at A = 0
    ratio = period(Ai, s.omega0, s.alpha) / build_model(scene, model).period(Ai)
    expect = float(np.trapezoid(p * ratio, A))
    raw = result.info["diagnostics"]["phase_mass_before_normalisation"]
    return max(abs(raw[k] / expect - 1.0) for k in ("x1", "x2", "joint"))


pytest_plugins = ["pytester"]


@pytest.fixture
def pytester(pytester, monkeypatch):
    """pytester, keeping the modules its in-process runs import. pytester restores
    ``sys.modules`` after each inline run (and at teardown), unloading what the run imported; a
    C extension or numba's registries imported first inside one (numpy.fft, scipy's, numba's
    typing of np.polynomial) then cannot be imported again in this worker ("cannot load module
    more than once per process", "duplicate registration"), and a later test fails depending
    on the order xdist gives. Only the inner runs' own test modules and conftests are dropped."""
    from _pytest.pytester import SysModulesSnapshot

    def keep(name: str) -> bool:
        return not name.startswith(("test_", "conftest"))

    monkeypatch.setattr(pytester, "_Pytester__take_sys_modules_snapshot",
                        lambda: SysModulesSnapshot(preserve=keep))
    monkeypatch.setattr(pytester, "_sys_modules_snapshot", SysModulesSnapshot(preserve=keep))
    return pytester


@pytest.fixture
def register_physics(monkeypatch):
    """``add(group, name, "module:attribute")``: registers one more entry point (as another
    distribution "someone" would, e.g. a noise kind in ``vifpk.noise_kinds``) for this test;
    the registry is read afresh on both sides of the test."""
    from vifpk.core import registry

    orig = registry._group
    extra: dict[str, list] = {}

    def group(g):
        entries, conflicts = orig(g)
        return (*entries, *extra.get(g, ())), conflicts

    def add(group_name: str, name: str, target: str, dist: str = "someone") -> None:
        extra.setdefault(group_name, []).append(registry.ModelEntry(name, target, dist))
        registry.refresh()

    monkeypatch.setattr(registry, "_group", group)
    yield add
    monkeypatch.undo()
    registry.refresh()


@pytest.fixture
def no_computation(monkeypatch):
    """Replace every entry point of real work by one that fails the test (the catalogues of
    bad input in test_cli_validation.py and test_edges.py: refused before any work)."""
    import importlib
    import sys

    def forbidden(*a, **k):
        raise AssertionError("computation started before the input was checked")

    # every harness module is loaded, then each entry point is replaced wherever a module
    # holds it (its home and every module that imported it by name)
    for p in (ROOT / "harness").rglob("*.py"):
        parts = ("vifpk", *p.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] not in ("__init__", "__main__", "pytest_plugin"):
            importlib.import_module(".".join(parts))
    homes = {"door.solvers": ("run_solver", "montecarlo_solution", "fpk_solution",
                              "model_solution"),
             "door.timedomain": ("passage_averaged", "passage_montecarlo", "passage_sde",
                                 "transient_averaged", "transient_montecarlo",
                                 "transient_sde"),
             "workflows.check": ("cross_check",), "workflows.bifurcation": ("bifurcation",),
             "workflows.figures": ("draw_figures",), "sweeps.points": ("run_point",),
             "workflows.workprecision": ("run_workprecision",),
             "workflows.passage": ("passage",), "workflows.transient": ("transient",)}
    targets = {id(getattr(sys.modules[f"vifpk.harness.{m}"], n)) for m, ns in homes.items()
               for n in ns}
    for modname, mod in list(sys.modules.items()):
        if modname.startswith("vifpk.harness"):
            for name, value in list(vars(mod).items()):
                if id(value) in targets:
                    monkeypatch.setattr(mod, name, forbidden)


def blank_png(res=None, text: dict[str, str] | None = None) -> bytes:
    """A 1 x 1 PNG carrying the text chunks a report figure carries (its run id): stands in
    for harness/outputs/report.py's figures where their drawing is not the subject (drawing
    both costs ~2 s of CPU; tests/test_report_output.py reads the real ones)."""
    import io

    from PIL import Image, PngImagePlugin

    info = PngImagePlugin.PngInfo()
    for k, v in (text or {}).items():
        info.add_text(k, v)
    buf = io.BytesIO()
    Image.new("L", (1, 1)).save(buf, format="PNG", pnginfo=info)
    return buf.getvalue()


@pytest.fixture
def blank_figures(monkeypatch):
    """The check report's two figures replaced by :func:`blank_png` (tests of options, folders
    and interruption, which do not look at the figures)."""
    from vifpk.harness.outputs import report

    monkeypatch.setattr(report, "_figure_densities", blank_png)
    monkeypatch.setattr(report, "_figure_decomposition", blank_png)
