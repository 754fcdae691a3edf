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
    CHECK_CONFIDENCE,
    CHECK_FACTOR,
    CHECK_LOOKS,
    CHECK_START_SHARE,
    DEFAULT_FLOOR,
    _jackknife_l1,
    split_floor,
    step_check,
)

from vifpk.core.result import Result


def run_step_check(simulate: Callable[..., Result], system: Any, noise: Any, st: Settings,
                   dens: dict[str, Any], edges: dict[str, np.ndarray], h: float,
                   burn_in: float, sampled: float, floor: float, target: float,
                   deadline: float, omega: float | None, *, reach: float = 0.0,
                   start: np.ndarray | None = None, tau: float | None = None
                   ) -> dict[str, Any]:
    """The run-time check of dt = "auto" (tuning.step_check): an independent run at
    CHECK_FACTOR x dt (its own seed, derived from the run's; the run's edges, burn-in and
    reach of its starts ``reach``, so no pilot measures anything again; the run's
    observables, so no kernel is compiled anew), then the bias of p(A) at dt judged against
    BIAS_FRACTION x the target floor. The verdict and a sentence (``message``); a failed
    check's sentence goes to the run's ``warnings``. ``simulate``: the stationary driver
    (simulate.simulate) that runs the coarse run.

    **Sequential** (tuning.CHECK_LOOKS): the coarse run goes to floors CHECK_LOOKS x the
    run's in turn, one set of paths continued from look to look (checkpoint.py: nothing is
    run twice; the last look is today's single run to CHECK_FLOOR_RATIO x the floor, window
    for window), and stops at the first look that decides: "failed" or "passed" (as in
    tuning.step_check), or a failure excluded, P(L <= (k^2 - 1) allowance) -- the verdict
    stays "undecided" then, as it would at the last look. Why it is worth looking early: with
    independent runs, "passed" is out of reach at any affordable cost where p(A) is narrow
    (the blocks' noise is then one mode, a shift of the whole law, so L1 of pure noise is
    half-normal, its standard deviation 0.76 of its mean: passing at L1 + z sigma <=
    hypot((k - 1) allowance, floor) needs a pair floor far below (k - 1) allowance = 1.5 x
    the target floor, a coarse run longer than the run itself); what the check can afford is
    to catch a failure, L > (k^2 - 1) allowance, and to exclude one, which at a bias well
    below that threshold it does at a larger floor than the last look's. Each early look
    decides at confidence 1 - (1 - CHECK_CONFIDENCE) / len(CHECK_LOOKS), the last at
    CHECK_CONFIDENCE: by the union bound the early stops add at most (looks - 1) / looks x
    (1 - CHECK_CONFIDENCE) to the check's error rate (less: the looks share their paths).
    ``info["dt_check"]["looks"]`` records each look.

    **Its start** (given the run's final paths ``start`` and its measured relaxation time
    ``tau``): the coarse run starts where the run ended, with streams of its own, so it
    starts at the law at dt, within L (the distance measured) of the law at k dt, not at the
    over-dispersed starts a run burns in for BURN_FACTOR x tau. What is left of the start
    after a burn-in B is L e^(-B / tau) e^(-t / tau); averaged over the first look's sampled
    time T_1 it is at most L e^(-B / tau) tau / T_1, so B = tau ln(tau / (CHECK_START_SHARE
    T_1)) (at least 0, at most the run's burn-in) leaves at most CHECK_START_SHARE of L in
    the first look and less in the later ones (it errs toward passing by that share, the
    measured L is (1 - share) L). The start shares the run's last states only: the run's
    histograms hold them in its last ~tau of sampled time out of its whole, so their
    errors stay independent to that fraction. Without them (a fixed burn-in: no tau), the
    coarse run starts over-dispersed and burns in as long as the run did."""
    allowance = BIAS_FRACTION * (target if target > 0 else DEFAULT_FLOOR)
    k = CHECK_FACTOR
    head = f"dt = {h:.4g} (auto)"
    # the splitting's linear stability limit is dt omega < 2 (docs/montecarlo.md); the check
    # stays at half of it for the fastest orbit the rule saw
    if omega is not None and k * h * omega >= 1.0:
        return {"verdict": "not run", "dt": h, "message": f"{head}: the step check was not "
                f"run: {k} x dt is too close to the stability limit dt Omega = 2"}
    if deadline - time.perf_counter() <= 0:
        return {"verdict": "not run", "dt": h, "message": f"{head}: the step check was not "
                "run: the budget was spent"}
    seed = int(np.random.SeedSequence(st.seed, spawn_key=(1 << 25,)).generate_state(1)[0])
    early = 1.0 - (1.0 - CHECK_CONFIDENCE) / len(CHECK_LOOKS)
    first = max(sampled / CHECK_LOOKS[0] ** 2, 8 * st.sample_every)  # the first look's time
    if start is not None and tau is not None and math.isfinite(tau) and tau > 0:
        burn_in = min(tau * max(math.log(tau / (CHECK_START_SHARE * first)), 0.0), burn_in)
    else:
        start = None
    out: dict[str, Any] | None = None
    state, timings, looks = None, [], []
    for i, ratio in enumerate(CHECK_LOOKS):
        last = i == len(CHECK_LOOKS) - 1
        left = deadline - time.perf_counter()
        if out is not None and left <= 0:
            break
        # a floor r x the run's takes 1 / r^2 of its sampled time: the floor mode starts
        # with half of ``time`` and extends from there (a continued look from where it was)
        time_c = max(2 * sampled / ratio**2, 16 * st.sample_every)
        chk_st = replace(st, dt=k * h, burn_in=burn_in, floor=ratio * floor, time=time_c,
                         seed=seed, edges=edges, dt_check=False, resume=state,
                         keep_state=not last, max_path_steps=math.inf, start_reach=reach,
                         start_state=start,
                         budget=left if math.isfinite(left) else 0.0)
        try:
            res = simulate(system, noise, chk_st)
        except (SimulationDiverged, BudgetExhausted) as exc:
            if out is not None:
                break
            return {"verdict": "not run", "dt": h, "message": f"{head}: the step check at "
                    f"{k} x dt could not run ({str(exc).split(':')[0]})"}
        state = res.info.pop("checkpoint", None)
        timings.append(res.info["timing"])
        out = step_check(dens, res.data["A"], dt=h, factor=k, allowance=allowance,
                         confidence=CHECK_CONFIDENCE if last else early)
        looks.append({"floor_ratio": ratio, "check_floor": res.info["L1_floor"]["A"],
                      "L1": out["L1"], "L1_floor": out["L1_floor"], "L1_err": out["L1_err"],
                      "verdict": out["verdict"],
                      "probability_beyond": out["probability_beyond"]})
        if last or out["verdict"] != "undecided" or out["probability_beyond"] <= 1 - early:
            break
    assert out is not None
    excluded = out["verdict"] == "undecided" and len(looks) < len(CHECK_LOOKS)
    out.update(looks=looks, burn_in=burn_in, start="where the run ended" if start is not None
               else "over-dispersed", stopped=("a failure excluded" if excluded else
                                     "decided" if out["verdict"] != "undecided" else
                                     "last look"))
    out["timing"] = _summed(timings)  # the coarse run's own stages (assemble moves it out)
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


def _summed(records: list[dict[str, Any]]) -> dict[str, Any]:
    """The looks' timing records (timing.py) added stage by stage."""
    stages: dict[str, dict[str, float]] = {}
    total = {"wall": 0.0, "cpu": 0.0}
    for rec in records:
        for name, t in rec["stages"].items():
            s = stages.setdefault(name, {"wall": 0.0, "cpu": 0.0})
            s["wall"] += t["wall"]
            s["cpu"] += t["cpu"]
        total["wall"] += rec["total"]["wall"]
        total["cpu"] += rec["total"]["cpu"]
    return {"stages": stages, "total": total}


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
