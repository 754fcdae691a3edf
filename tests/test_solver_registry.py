"""The solver registry (issue 27): an FPK solver registered in the ``vifpk.solvers``
entry-point group is offered by ``vifpk solve --solver`` and measured by ``vifpk check``
against every model's closed form, beside vifpk's own ``fpk``, with no edit to vifpk.

The solver registered here is independent of vifpk's FPK: the zero-flux stationary density of
a 1-D diffusion in closed form, p(A) = exp(int_0^A 2 m / sigma^2 da) / sigma^2(A) / Z (Risken,
The Fokker-Planck Equation, eq. 5.4 with zero flux), by the trapezoid rule on its own grid and
normalised in log space.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.conftest import TINY, TINY_CHECK_SET
from vifpk.core import registry
from vifpk.core.protocols import Solver, SolverSpec

#: the quadrature plugin's grid: 4000 points on (0, 6]: the trapezoid rule's error is
#: O(h^2 max|d^2 log p / dA^2|) ~ (1.5e-3)^2 x 1e2 ~ 2e-4 in log p at most, so the L1 distance to
#: the closed form stays below 1e-3 (the bound the tests assert)
GRID = np.linspace(1e-6, 6.0, 4000)


def _quadrature(drift, diffusion, *, cells):
    A = GRID
    m, s2 = np.asarray(drift(A), float), np.asarray(diffusion(A), float)
    f = 2 * m / s2
    log_q = np.concatenate(([0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(A)))) - np.log(s2)
    log_q -= log_q.max()
    p = np.exp(log_q)
    return A, p / np.trapezoid(p, A)


def _negative(drift, diffusion, *, cells):
    A = np.linspace(0.01, 3, 50)
    return A, -np.ones_like(A)


QUADRATURE = SolverSpec("quadrature", "the zero-flux density by the trapezoid rule",
                        stationary=_quadrature)
NEGATIVE = SolverSpec("negative", "a broken solver", stationary=_negative)
NOT_A_SOLVER = object()


@pytest.fixture
def with_solver(monkeypatch):
    """Register ``tests.test_solver_registry:<attr>`` as the solver ``name`` (as another
    distribution's entry point would be)."""

    def install(attr: str, name: str):
        real = registry._group

        def group(g):
            entries, conflicts = real(g)
            if g == registry.SOLVER_GROUP:
                entries = (*entries, registry.ModelEntry(name, f"tests.test_solver_registry:"
                                                         f"{attr}", "tests"))
            return entries, conflicts

        monkeypatch.setattr(registry, "_group", group)
        registry.refresh()

    yield install
    registry.refresh()


def test_the_builtin_fpk_is_a_registered_solver():
    spec, entry = registry.solver("fpk")
    assert isinstance(spec, Solver) and entry.builtin
    assert registry.solver_names() == ("averaging", "fpk", "montecarlo", "original-fpk")


def test_a_registered_solver_is_offered_by_solve_and_agrees_with_the_closed_form(
        with_solver, tmp_path, capsys):
    from vifpk.harness.cli.app import main

    with_solver("QUADRATURE", "quadrature")
    assert registry.solver_names() == ("averaging", "fpk", "quadrature", "montecarlo",
                                      "original-fpk")
    out = {}
    for solver in ("averaging", "quadrature"):
        path = tmp_path / f"{solver}.json"
        assert main(["solve", "paper-base", "--solver", solver, "--model", "exact",
                     "--json", str(path)]) == 0
        out[solver] = json.loads(path.read_text())["pdf"]["A"]
    a, q = out["averaging"], out["quadrature"]
    p_q = np.interp(a["x"], q["x"], q["p"], left=0.0, right=0.0)
    l1 = float(np.trapezoid(np.abs(p_q - np.asarray(a["p"])), a["x"]))
    assert l1 < 1e-3, l1  # the quadrature's error bound (GRID)


def test_a_registered_solver_takes_part_in_check(with_solver):
    """Plumbing on the tiny scene (one model, no averaged-SDE run): the plugin's p(A) is
    measured against the closed form beside vifpk's FPK, and reported."""
    from vifpk.harness.cli.options import concrete_scene
    from vifpk.harness.outputs.report import _tables
    from vifpk.harness.workflows.check import cross_check

    with_solver("QUADRATURE", "quadrature")
    res = cross_check(concrete_scene(str(TINY), TINY_CHECK_SET), quiet=True, sde=False,
                      tail_mass=False, models=("exact",))
    entry = res.metrics["models"]["exact"]
    assert set(entry["solver_errors"]) == {"quadrature"}
    assert entry["solver_errors"]["quadrature"]["A"]["L1"] < 1e-3  # GRID's bound
    assert "discretisation_error" in entry  # vifpk's fpk, under the key it declares
    rows = [r[0] for r in _tables(res)[0][2]]
    assert "numerics of quadrature" in rows


@pytest.mark.parametrize(("attr", "name", "says"), [
    ("NEGATIVE", "negative", "not finite and non-negative"),
    ("NOT_A_SOLVER", "broken", "is not a vifpk.core.protocols.Solver"),
])
def test_a_broken_solver_plugin_is_one_line_naming_it(with_solver, capsys, attr, name, says):
    from vifpk.harness.cli.app import main

    with_solver(attr, name)
    assert main(["solve", "paper-base", "--solver", name, "--model", "exact"]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"'{name}'" in err and says in err, err
