"""Issue 38 item 2: what a simulation resolved comes back typed (vifpk.core.result.Resolved),
and no workflow reads a setting out of an ``info`` dict to send it down again. Fast: the
session's tiny check (tests/conftest.py) and a scan of the workflows' source."""

from __future__ import annotations

import ast
from pathlib import Path

from vifpk.core.result import Resolved

ROOT = Path(__file__).resolve().parents[1]


def test_the_simulations_resolved_settings_are_typed(tiny_check):
    for key in ("mc:original", *(k for k in tiny_check.solutions if k.startswith("mc:"))):
        res = tiny_check.solutions[key]
        assert isinstance(res.resolved, Resolved), key
        st = res.info["settings"]  # the JSON record keeps them, the same numbers
        assert (res.resolved.dt, res.resolved.time, res.resolved.burn_in,
                res.resolved.paths) == (st["dt"], st["time"], st["burn_in"], st["paths"]), key
    closed = tiny_check.solutions.get("averaging:exact") or next(
        v for k, v in tiny_check.solutions.items() if not k.startswith("mc:"))
    assert closed.resolved is None  # a closed form resolves no simulation setting


def test_no_workflow_reads_settings_out_of_an_info_dict():
    """`info["settings"]` is the record written to JSON; a workflow that continues a run reads
    the typed `Result.resolved` (harness/workflows/check.py did, before issue 38)."""
    found = []
    for path in sorted((ROOT / "harness" / "workflows").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant)
                    and node.slice.value == "settings"):
                found.append(f"{path.name}:{node.lineno}")
    assert found == []


def test_the_plan_that_is_priced_is_the_run_that_is_made(tiny_check):
    """docs/architecture.md, "The Monte Carlo's plan is written once": the plan the request
    layer checks and prices (harness.door.solvers.montecarlo_plan, montecarlo/plan.py) gives
    the step and the sampled time the simulation then ran with (its Resolved), on the tiny
    check's own scene."""
    from vifpk.harness.door.solvers import montecarlo_plan

    assert tiny_check.scene.montecarlo.floor == 0.0  # no floor: exactly the plan's time
    plan = montecarlo_plan(tiny_check.scene)
    res = tiny_check.solutions["mc:original"].resolved
    assert (res.dt, res.time, res.burn_in) == (plan.dt, plan.sampled_time, plan.burn_in)
