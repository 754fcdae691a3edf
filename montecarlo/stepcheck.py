"""The run-time check of dt = "auto": an independent run at CHECK_FACTOR x dt, then the bias of
p(A) at dt judged against the target floor (tuning.step_check holds the judgement; this module
runs the coarse run and words the verdict)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from statistics import NormalDist
from typing import Any

import numpy as np
from vifpk.montecarlo.failures import BudgetExhausted, SimulationDiverged
from vifpk.montecarlo.runplan import Settings
from vifpk.montecarlo.tuning import (
    BIAS_FRACTION,
    BIAS_P,
    CHECK_FACTOR,
    CHECK_FLOOR_RATIO,
    DEFAULT_FLOOR,
    _jackknife_l1,
    split_floor,
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


def held_out_bias(simulate: Callable[..., Result], system: Any, noise: Any, st: Settings, *,
                  sample_floor: float, fine: int = 4, confidence: float = 0.99,
                  parametric: Any = None) -> dict[str, Any]:
    """Does the step rule keep its promise on a scene? (the held-out check of issue 44:
    tests/test_dt_heldout.py, benchmarks/bench_dt_heldout.py). The rule's step dt for the
    target floor F = st.floor (a short run at dt "auto" settles it: its scale pilot's Omega),
    then two independent runs to the noise floor ``sample_floor``, one at dt and one at
    dt / ``fine`` on its edges; b(dt) is estimated from their L1 distance on p(A) with the
    pair's noise floor measured on the blocks (tuning.split_floor) removed in quadrature,
    divided by 1 - fine^-BIAS_P (the fine run's own bias at the model's order). "held" unless
    L1 > sqrt((1 - fine^-p)^2 a^2 + floor^2) + z sigma: the promise a = BIAS_FRACTION F
    exceeded beyond the noise at ``confidence``, one-sided (sigma: the delete-one-block
    jackknife of both runs, as in step_check)."""
    pilot = simulate(system, noise, replace(st, dt="auto", dt_check=False,
                                            time=16 * st.sample_every, certificate=False),
                     parametric=parametric)
    rule = pilot.info["dt_rule"]
    h = float(pilot.info["settings"]["dt"])
    run_st = replace(st, dt=h, dt_check=False, floor=sample_floor)
    run = simulate(system, noise, run_st, parametric=parametric)
    A = run.data["A"]
    edges = {"edges_A": A["edges"], "edges_x": run.data["x1"]["edges"],
             "edges_v": run.data["x2"]["edges"]}
    seed = int(np.random.SeedSequence(st.seed, spawn_key=(1 << 26,)).generate_state(1)[0])
    ref = simulate(system, noise, replace(run_st, dt=h / fine, seed=seed, edges=edges),
                   parametric=parametric).data["A"]
    w = np.diff(np.asarray(A["edges"], float))
    p, q = np.asarray(A["p"]), np.asarray(ref["p"])
    L1 = float(np.sum(np.abs(p - q) * w))
    floor = math.hypot(split_floor(np.asarray(A["p_blocks"]), w),
                       split_floor(np.asarray(ref["p_blocks"]), w))
    sigma = math.hypot(_jackknife_l1(np.asarray(A["p_blocks"]), q, w),
                       _jackknife_l1(np.asarray(ref["p_blocks"]), p, w))
    gain = 1.0 - fine ** -BIAS_P
    allowance = BIAS_FRACTION * st.floor
    limit = math.hypot(gain * allowance, floor) + NormalDist().inv_cdf(confidence) * sigma
    return {"dt": h, "omega": rule.get("omega"), "omega_dt": (rule.get("omega") or 0) * h,
            "fine_dt": h / fine, "floor_target": st.floor, "allowance": allowance,
            "L1": L1, "L1_floor": floor, "L1_err": sigma,
            "bias": math.sqrt(max(L1 * L1 - floor * floor, 0.0)) / gain,
            "limit_L1": limit, "held": bool(L1 <= limit)}
