"""The run-time check of dt = "auto": an independent run at CHECK_FACTOR x dt, then the bias of
p(A) at dt judged against the target floor (tuning.step_check holds the judgement; this module
runs the coarse run and words the verdict)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from vifpk.montecarlo.failures import BudgetExhausted, SimulationDiverged
from vifpk.montecarlo.runplan import Settings
from vifpk.montecarlo.tuning import (
    BIAS_FRACTION,
    CHECK_FACTOR,
    CHECK_FLOOR_RATIO,
    DEFAULT_FLOOR,
    step_check,
)

from vifpk.core.result import Result


def run_step_check(simulate: Callable[..., Result], system: Any, noise: Any, st: Settings,
                   dens: dict[str, Any], edges: dict[str, np.ndarray], h: float,
                   burn_in: float, sampled: float, floor: float, target: float,
                   deadline: float, omega: float | None) -> dict[str, Any]:
    """The run-time check of dt = "auto" (tuning.step_check): an independent run at
    CHECK_FACTOR x dt (its own seed, derived from the run's; the run's edges and burn-in, so
    no pilot measures anything again; the run's observables, so no kernel is compiled anew)
    to a floor CHECK_FLOOR_RATIO x the run's, within what is left of the budget; then the
    bias of p(A) at dt is judged against BIAS_FRACTION x the target floor. The verdict and a
    sentence (``message``); a failed check's sentence goes to the run's ``warnings``.
    ``simulate``: the stationary driver (simulate.simulate) that runs the coarse run."""
    allowance = BIAS_FRACTION * (target if target > 0 else DEFAULT_FLOOR)
    k = CHECK_FACTOR
    head = f"dt = {h:.4g} (auto)"
    # the splitting's linear stability limit is dt omega < 2 (docs/montecarlo.md); the check
    # stays at half of it for the fastest orbit the rule saw
    if omega is not None and k * h * omega >= 1.0:
        return {"verdict": "not run", "dt": h, "message": f"{head}: the step check was not "
                f"run: {k} x dt is too close to the stability limit dt Omega = 2"}
    left = deadline - time.perf_counter()
    if left <= 0:
        return {"verdict": "not run", "dt": h, "message": f"{head}: the step check was not "
                "run: the budget was spent"}
    seed = int(np.random.SeedSequence(st.seed, spawn_key=(1 << 25,)).generate_state(1)[0])
    # a floor CHECK_FLOOR_RATIO x the run's takes 1 / CHECK_FLOOR_RATIO^2 of its sampled time:
    # the floor mode starts with half of ``time`` and extends from there
    time_c = max(2 * sampled / CHECK_FLOOR_RATIO**2, 16 * st.sample_every)
    chk_st = replace(st, dt=k * h, burn_in=burn_in, floor=CHECK_FLOOR_RATIO * floor,
                     time=time_c, seed=seed, edges=edges, dt_check=False, resume=None,
                     keep_state=False, max_path_steps=math.inf,
                     budget=left if math.isfinite(left) else 0.0)
    try:
        res = simulate(system, noise, chk_st)
        coarse, timing = res.data["A"], res.info["timing"]
    except (SimulationDiverged, BudgetExhausted) as exc:
        return {"verdict": "not run", "dt": h, "message": f"{head}: the step check at "
                f"{k} x dt could not run ({str(exc).split(':')[0]})"}
    out = step_check(dens, coarse, dt=h, factor=k, allowance=allowance)
    out["timing"] = timing  # the coarse run's own stages (timing.py; assemble moves it out)
    lo, hi = out["bias_range"]
    said = {"passed": "within", "failed": "ABOVE", "undecided": "not decided against"}
    out["message"] = (f"{head}: the step check ({k} x dt, an independent run) puts the bias of "
                      f"p(A) at {lo:.2g}-{hi:.2g} in L1 (as it grows like dt^2 or dt), "
                      f"{said[out['verdict']]} the allowance {allowance:.2g} (half the target "
                      "floor)")
    if out["verdict"] == "failed":
        out["message"] += (": the step rule does not hold here and p(A) carries a step bias; "
                           f"run again with --dt {h / 4:.3g} or smaller")
    return out
