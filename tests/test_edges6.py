"""Issue 28, my own cases (2026-11-25): the new doors of issue 27 tried as a hostile user
would: FPK solver plugins that misbehave, the registry-derived Python API with wrong names and
types, and `--solver` with options that do not apply. Each case: exit 2 or 3 (or BadInput /
PluginError from the API) in one line naming what is wrong; nothing written. docs/edges.md
("Round 6") lists them."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from vifpk.core import registry
from vifpk.core.protocols import SolverSpec, WorkflowSpec

GOOD_A = np.linspace(0.01, 3.0, 100)


def _good(drift, diffusion, *, cells):
    p = np.exp(-GOOD_A**2)
    return GOOD_A, p / np.trapezoid(p, GOOD_A)


def _raises(drift, diffusion, *, cells):
    raise KeyError("oops")


def _exits(drift, diffusion, *, cells):
    raise SystemExit(0)


SOLVERS = {
    "decreasing": lambda d, s, *, cells: (GOOD_A[::-1], np.ones(100) / 3),
    "nan": lambda d, s, *, cells: (GOOD_A, np.full(100, np.nan)),
    "negative-p": lambda d, s, *, cells: (GOOD_A, -np.ones(100)),
    "mass-two": lambda d, s, *, cells: (GOOD_A, 2 * _good(d, s, cells=cells)[1]),
    "scalar": lambda d, s, *, cells: 1.0,
    "shapes": lambda d, s, *, cells: (GOOD_A, np.ones(7)),
    "two-d": lambda d, s, *, cells: (np.ones((4, 4)), np.ones((4, 4))),
    "three-things": lambda d, s, *, cells: (GOOD_A, GOOD_A, GOOD_A),
    "too-short": lambda d, s, *, cells: (np.array([0.1, 0.2]), np.array([5.0, 5.0])),
    "negative-A": lambda d, s, *, cells: (GOOD_A - 1.0, _good(d, s, cells=cells)[1]),
    "inf-A": lambda d, s, *, cells: (np.r_[GOOD_A[:-1], np.inf], _good(d, s, cells=cells)[1]),
    "raises": _raises,
    "exits": _exits,
}
SAYS = {
    "decreasing": "not finite, non-negative and increasing",
    "nan": "not finite and non-negative",
    "negative-p": "not finite and non-negative",
    "mass-two": "mass 2",
    "scalar": "returned float",
    "shapes": "shapes (100,) and (7,)",
    "two-d": "one-dimensional",
    "three-things": "returned tuple",
    "too-short": "length >= 4",
    "negative-A": "not finite, non-negative and increasing",
    "inf-A": "not finite, non-negative and increasing",
    "raises": "raised KeyError",
    "exits": "called sys.exit(0)",
}
SPECS = {name: SolverSpec(name, "a broken solver", stationary=fn) for name, fn in SOLVERS.items()}
GOOD = SolverSpec("good", "a Gaussian, whatever the model", stationary=_good)
WRONG_NAME = SolverSpec("other", "registered under another name", stationary=_good)


@pytest.fixture
def extra_entry(monkeypatch):
    """Add ``tests.test_edges6:<attr>`` to a registry group as another distribution's."""
    import vifpk

    def install(group: str, name: str, attr: str):
        real = registry._group

        def grp(g):
            entries, conflicts = real(g)
            if g == group:
                entries = (*entries, registry.ModelEntry(name, f"{__name__}:{attr}", "edge6"))
            return entries, conflicts

        monkeypatch.setattr(registry, "_group", grp)
        registry.refresh()

    yield install
    registry.refresh()
    for cached in ("scene", "run", "partial"):
        if cached not in ("scene", "run"):
            vars(vifpk).pop(cached, None)


@pytest.fixture
def solver_plugin(monkeypatch, extra_entry):
    """Register ``SPECS[name]`` (or the spec ``attr`` of this module) as the solver ``name``."""
    import sys

    def install(name: str, attr: str | None = None):
        if attr is None:
            monkeypatch.setattr(sys.modules[__name__], "THE_SPEC", SPECS[name], raising=False)
            attr = "THE_SPEC"
        extra_entry(registry.SOLVER_GROUP, name, attr)

    return install


@pytest.mark.parametrize("name", sorted(SOLVERS))
def test_a_misbehaving_solver_plugin_is_named_in_one_line(solver_plugin, capsys, tmp_path,
                                                          name):
    from vifpk.harness.cli.app import main

    solver_plugin(name)
    out = tmp_path / "o.json"
    assert main(["solve", "paper-base", "--solver", name, "--model", "exact",
                 "--json", str(out)]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"'{name}'" in err[0] and SAYS[name] in err[0], err
    assert not out.exists()


def test_a_solver_registered_under_another_name_is_refused(solver_plugin, capsys):
    from vifpk.harness.cli.app import main

    solver_plugin("mine", "WRONG_NAME")
    assert main(["solve", "paper-base", "--solver", "mine", "--model", "exact"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is not a vifpk.core.protocols.Solver of that name" in err[0]


def test_a_plugin_solver_s_density_is_renormalised_and_mapped(solver_plugin):
    """A density of mass 1 within 1e-2 passes, renormalised exactly; the door maps it to
    p(x1), p(x2) like the closed form (both of mass 1)."""
    import vifpk

    solver_plugin("good", "GOOD")
    res = vifpk.solve("paper-base", "good", model="exact")
    for o in ("A", "x1", "x2"):
        d = res.data[o]
        assert abs(np.trapezoid(d["p"], d["x"]) - 1) < 1e-6, o
    assert res.info["solver"] == "good"


@pytest.mark.parametrize(("args", "says"), [
    (["--solver", "nope"], "invalid choice: 'nope'"),
    (["--solver", "fpk", "--paths", "64"], "--paths: does not apply"),
    (["--solver", "averaging", "--grid", "100"], "--grid"),
    (["--solver", "montecarlo", "--model", "exact"], "--model"),
])
def test_solver_options_that_do_not_apply_exit_2(no_computation, capsys, args, says):
    from vifpk.harness.cli.app import main

    try:
        code = main(["solve", "paper-base", *args])
    except SystemExit as exc:  # argparse's own refusal (an unknown choice)
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert says in err[-1], err


@pytest.mark.parametrize(("call", "says"), [
    (lambda v: v.run(42), "workflow 42"),
    (lambda v: v.run("nope", "paper-base"), "workflow 'nope'"),
    (lambda v: v.run("models"), "allowed: check, passage, solve"),
    (lambda v: v.run("figures"), "allowed: check, passage, solve"),
    (lambda v: v.run(["check"]), "workflow ['check']"),
    (lambda v: v.run("solve", "paper-base", "nope-solver"), "--solver 'nope-solver'"),
    (lambda v: v.run("solve", "paper-base", "fpk", paths=64), "paths"),
    (lambda v: v.run("check", "paper-base", models="exact"), "give a list of model names"),
    (lambda v: v.solve("paper-base", "montecarlo", model="exact"), "model"),
])
def test_the_registry_derived_api_refuses_in_one_line(no_computation, call, says):
    import vifpk
    from vifpk.core.result import BadInput

    with pytest.raises(BadInput) as err:
        call(vifpk)
    msg = str(err.value)
    assert "\n" not in msg and says in msg, msg


def test_the_api_names_what_it_does_not_have():
    import vifpk

    with pytest.raises(AttributeError, match="no attribute 'figures'"):
        vifpk.figures  # noqa: B018 - a workflow without a Python function
    with pytest.raises(AttributeError, match="no attribute '_private'"):
        vifpk._private  # noqa: B018
    with pytest.raises(registry.UnknownName, match="workflow with a tolerance test"):
        from vifpk.harness.testing import assertion

        assertion("solve")


@pytest.mark.parametrize("model", ["paper", "exact", "corrected"])
@pytest.mark.parametrize("bad", [-1.0, float("nan")])
def test_a_model_refuses_an_amplitude_that_is_not_one(base, model, bad):
    """Issue 28: `build_model(...).drift([0, -1, nan])` printed a numpy warning and returned a
    finite number at A = -1. A negative or NaN amplitude is now refused in one line; a
    positive one still gives the same number."""
    m = registry.build_model(base, model)
    want = m.drift(np.array([0.5]))
    for method in (m.drift, m.diffusion):
        with pytest.raises(ValueError, match=r"an amplitude must be >= 0, got (-1\.0|nan)"):
            method(np.array([0.5, bad]))
    assert np.array_equal(m.drift(np.array([0.5])), want)


# ------------------------------------------------ names that collide in the registries
def _hello(*a, **k):
    return "plugin"


SHADOW_SCENE = WorkflowSpec("scene", "a workflow named like vifpk.scene", api=_hello)
SHADOW_RUN = WorkflowSpec("run", "a workflow named like vifpk.run", api=_hello)
PARTIAL_ASSERTION = WorkflowSpec("partial", "an assertion without a name", api=_hello,
                                 assertion=functools.partial(_hello, 1))
FAKE_FPK = SolverSpec("fpk", "another distribution's fpk", stationary=_good)
FAKE_AVERAGING = SolverSpec("averaging", "a solver named like the closed form",
                            stationary=_good)


@pytest.mark.parametrize(("name", "attr"), [("scene", "SHADOW_SCENE"), ("run", "SHADOW_RUN")])
def test_a_workflow_named_like_an_api_function_does_not_replace_it(extra_entry, name, attr):
    import vifpk
    from vifpk import api

    vars(vifpk).pop(name, None)
    extra_entry(registry.WORKFLOW_GROUP, name, attr)
    assert getattr(vifpk, name) is getattr(api, name)


def test_an_assertion_without_a_name_is_not_exposed_and_breaks_nothing(extra_entry):
    import vifpk

    extra_entry(registry.WORKFLOW_GROUP, "partial", "PARTIAL_ASSERTION")
    assert vifpk.partial() == "plugin"  # its api is there
    assert "partial" in vifpk.__all__ and vifpk.check is not None


def test_a_solver_plugin_named_like_a_builtin_is_shadowed(monkeypatch):
    """A name keeps its first meaning (registry._group, read from installed metadata here):
    another distribution's `fpk` is not vifpk's (a conflict is recorded), and a plugin named
    `averaging` neither replaces the closed form nor appears twice."""
    from types import SimpleNamespace

    real = registry.metadata.entry_points
    dist = SimpleNamespace(metadata={"Name": "edge6"})
    fakes = [SimpleNamespace(name=n, value=f"{__name__}:{a}", dist=dist)
             for n, a in (("fpk", "FAKE_FPK"), ("averaging", "FAKE_AVERAGING"))]

    def entry_points(group=None, **kw):
        found = list(real(group=group, **kw))
        return found + fakes if group == registry.SOLVER_GROUP else found

    monkeypatch.setattr(registry.metadata, "entry_points", entry_points)
    registry.refresh()
    try:
        assert registry.solver_names() == ("averaging", "fpk", "montecarlo", "original-fpk")
        assert registry.solver("fpk")[1].builtin
        assert any("'fpk' from edge6" in c for c in registry._group(registry.SOLVER_GROUP)[1])
    finally:
        monkeypatch.undo()
        registry.refresh()


# ------------------------------------------------ the time-domain and sweep API, wrong types
def _sweep_file(tmp_path):
    from tests.conftest import ROOT

    return ROOT / "tests" / "data" / "sweep-averaging.toml"


API_CASES = [
    ("passage-threshold-text", lambda v, t: v.passage("paper-base", threshold="high"),
     "threshold"),
    ("passage-threshold-negative", lambda v, t: v.passage("paper-base", threshold=-1.0),
     "threshold"),
    ("passage-threshold-below-start", lambda v, t: v.passage("paper-base", threshold=0.3,
                                                             start=0.5), "start"),
    ("passage-models-string", lambda v, t: v.passage("paper-base", threshold=0.8,
                                                      models="exact"), "exact"),
    ("passage-paths-text", lambda v, t: v.passage("paper-base", threshold=0.8,
                                                   paths="many"), "paths"),
    ("passage-unknown-option", lambda v, t: v.passage("paper-base", threshold=0.8, floor=0.01),
     "floor: not an option of passage"),
    ("transient-times-text", lambda v, t: v.transient("paper-base", start=1.0,
                                                       times="10,20"), "times"),
    ("transient-times-empty", lambda v, t: v.transient("paper-base", start=1.0, times=[]),
     "times"),
    ("transient-start-negative", lambda v, t: v.transient("paper-base", start=-1.0,
                                                           times=[10]), "start"),
    ("sweep-not-a-path", lambda v, t: v.sweep(42, t / "o"), "42"),
    ("sweep-missing-file", lambda v, t: v.sweep(t / "nope.toml", t / "o"), "nope.toml"),
    ("sweep-executor", lambda v, t: v.sweep(_sweep_file(t), t / "o", executor="threads:2"),
     "threads:2"),
    ("check-tolerance-negative", lambda v, t: v.check("paper-base", tolerance=-0.1),
     "tolerance"),
    ("check-tolerance-metric", lambda v, t: v.check("paper-base", tolerance_metric="L7"),
     "L7"),
    ("check-confidence", lambda v, t: v.check("paper-base", confidence=1.5), "confidence"),
    ("solve-grid-fraction", lambda v, t: v.solve("paper-base", "fpk", grid=4.5), "grid"),
    ("scene-unknown-field", lambda v, t: v.scene("paper-base", **{"system.nope": 1}), "nope"),
    ("scene-noise-kind", lambda v, t: v.scene("paper-base", **{"noise.kind": "pink"}),
     "pink"),
]


def _existing(t):
    (t / "taken.txt").write_text("keep me")
    return t / "taken.txt"


API_CASES += [
    ("run-solve-unknown-model", lambda v, t: v.run("solve", "paper-base", "fpk", model="nope"),
     "'nope'"),
    ("run-check-unknown-model", lambda v, t: v.run("check", "paper-base", models=("nope",)),
     "'nope'"),
    ("check-out-is-a-file", lambda v, t: v.check("paper-base", out=_existing(t)), "taken.txt"),
    ("solve-grid-bool", lambda v, t: v.solve("paper-base", "fpk", grid=True), "grid"),
    ("passage-horizon-text", lambda v, t: v.passage("paper-base", threshold=0.8,
                                                     horizon="long"), "horizon"),
    ("passage-threshold-nan", lambda v, t: v.passage("paper-base", threshold=float("nan")),
     "threshold"),
    ("passage-threshold-bool", lambda v, t: v.passage("paper-base", threshold=True),
     "threshold"),
    ("transient-times-inf", lambda v, t: v.transient("paper-base", start=1.0,
                                                      times=[10, float("inf")]), "times"),
    ("transient-start-text", lambda v, t: v.transient("paper-base", start="1.0", times=[10]),
     "start"),
    ("transient-times-decreasing", lambda v, t: v.transient("paper-base", start=1.0,
                                                             times=[20, 10]), "increasing"),
    ("check-tolerance-nan", lambda v, t: v.check("paper-base", tolerance=float("nan")),
     "tolerance"),
    ("solve-paths-fraction", lambda v, t: v.solve("paper-base", "montecarlo", paths=64.5),
     "paths"),
    ("solve-seed-negative", lambda v, t: v.solve("paper-base", "montecarlo", seed=-1), "seed"),
    ("solve-dt-zero", lambda v, t: v.solve("paper-base", "montecarlo", dt=0), "dt"),
]


@pytest.mark.parametrize(("case", "call", "says"), API_CASES, ids=[c[0] for c in API_CASES])
def test_the_api_refuses_wrong_values_before_any_work(no_computation, tmp_path, case, call,
                                                      says):
    import vifpk
    from vifpk.core.result import BadInput

    with pytest.raises(BadInput) as err:
        call(vifpk, tmp_path)
    msg = str(err.value)
    assert "\n" not in msg and says in msg, msg
    assert not (tmp_path / "o").exists()


# ------------------------------------------------ the measured-rate stop, at its edges
@pytest.mark.parametrize(("elapsed", "computed", "remaining", "workers", "limit", "stops"), [
    (100.0, 2, 1000, 1, 10.0, False),  # fewer than 3 points: a rate says little yet
    (100.0, 3, 1000, 4, 10.0, False),  # a pool of 4: wait for 4 points
    (100.0, 4, 1000, 4, 10.0, True),
    (100.0, 3, 0, 1, 10.0, False),     # nothing left
    (30.0, 3, 7, 1, 100.0, False),     # projected 100 = the limit: not over it
    (30.0, 3, 8, 1, 100.0, True),      # projected 110
    (1e6, 3, 1000, 1, None, False),    # --yes (or the API): no limit
])
def test_check_rate_stops_exactly_when_the_projection_is_over(tmp_path, elapsed, computed,
                                                              remaining, workers, limit,
                                                              stops):
    from vifpk.harness.sweeps.errors import OverTime
    from vifpk.harness.sweeps.runs import check_rate

    if stops:
        with pytest.raises(OverTime, match="--yes"):
            check_rate(elapsed, computed, remaining, workers=workers, limit=limit, out=tmp_path)
    else:
        check_rate(elapsed, computed, remaining, workers=workers, limit=limit, out=tmp_path)
