"""Stage 4 of a stationary run (simulate.py): the sampled time, window by window. Without a
target floor exactly the planned windows; with one, the planned first stage, then more windows
toward the floor (the 1/sqrt(time) law, at most doubling at a time) until it is reached or the
budget, checked between windows, runs out. Within an extension the floor is read after every
window and the run stops at the first window that meets it (the extension's length is an
estimate from a noisy floor: issue 44, paper-base ran 8000 time units where 7560 met 0.005)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from vifpk.montecarlo.burnin import Started
from vifpk.montecarlo.failures import BudgetExhausted
from vifpk.montecarlo.runplan import Clock, RunPlan
from vifpk.montecarlo.stepper import Stepper
from vifpk.montecarlo.summary import floor_A


@dataclass(frozen=True, kw_only=True)
class Sampled:
    """Stage 4's result: the certificate's window means (trimmed to the windows run), the
    windows run, why the run stopped ("fixed time", "floor reached" or "budget"), the last
    L1 floor of p(A) (nan without "A") and the seconds from the burn-in's start."""

    windows: np.ndarray | None
    run_to: int
    stopped: str
    floor: float
    run_s: float


def sample(plan: RunPlan, clock: Clock, run: Started, step: Stepper, bar: Any) -> Sampled:
    """Run the windows (module docstring). Raises BudgetExhausted when the budget ends before
    the first window."""
    st, target, deadline = plan.settings, plan.target, clock.deadline
    blocks, per_block = plan.blocks, plan.per_block
    arr, windows, n_burn, stride, spw = run.arr, run.windows, run.n_burn, run.stride, run.spw
    win_steps = run.win_steps
    run_to, n_win = run.run_to, run.n_win
    stopped = "fixed time"
    floor = math.nan
    first_stage = n_win  # the planned first stage runs whole; extensions stop when met
    while True:
        while run_to < n_win:  # window by window: the budget is checked between windows
            if target > 0 and time.perf_counter() >= deadline:
                stopped = "budget"
                break
            step.run(arr, win_steps, n_burn + run_to * win_steps, n_burn, stride, spw,
                     windows)
            run_to += 1
            if target > 0 and run_to > first_stage and "A" in plan.obs and run_to < n_win:
                # an extension stops at the first window whose floor meets the target (its
                # length is the 1/sqrt(time) law's estimate from a noisy floor)
                floor = floor_A(arr)
                if floor <= target:
                    break
        if run_to == 0:  # only a target floor's budget stops a run before its first window
            raise BudgetExhausted(
                f"the budget of {st.budget:g} s ran out before the first sampling window "
                f"(the pilots and the burn-in took {time.perf_counter() - clock.t_run:.3g} s): "
                "no sample was taken; give a larger budget, or 0 for no limit")
        if "A" in plan.obs:
            floor = floor_A(arr)
        if target <= 0:
            break
        if floor <= target:
            stopped = "floor reached"
            break
        if stopped == "budget" or time.perf_counter() >= deadline:
            stopped = "budget"
            break
        # the 1/sqrt(time) law, but at most doubling: early floors fall faster than the
        # law (the start of the sampled time is correlated with the burn-in's end), so a
        # long leap from a short run overshoots
        grow = min(max(math.ceil(run_to * ((floor / target) ** 2 * 1.02 - 1)), 1), run_to)
        n_win = run_to + grow
        if windows is not None:
            windows = np.concatenate([windows, np.zeros((blocks, per_block, grow))], axis=2)
        if bar is not None:
            bar.total += blocks * per_block * grow * win_steps
            bar.set_postfix_str(f"L1 floor {floor:.4f} -> {target:g}", refresh=False)
    run_s = time.perf_counter() - run.t_burn
    if windows is not None and run_to < windows.shape[2]:
        windows = windows[:, :, :run_to]
    return Sampled(windows=windows, run_to=run_to, stopped=stopped, floor=floor, run_s=run_s)
