"""Stage 3 of a stationary run (simulate.py): from the plan to paths that are burnt in and
ready to sample. A new run runs the scale pilot (the histogram ranges; with dt "auto" the
step, from the orbits the pilot's paths reach), measures the relaxation time with an "auto"
burn-in (the relaxation pilot), refuses a run over its path-step limit, starts the paths
over-dispersed on the orbits up to the pilot's reach and burns them in. A run continued from a
checkpoint takes its paths, its plan and its arrays instead (no pilot, no burn-in)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from vifpk.montecarlo.failures import SimulationDiverged, diverged
from vifpk.montecarlo.pilots import START_LOW, pilot_scale, potential, relaxation, starts
from vifpk.montecarlo.plan import MIN_AUTO_BURN_IN, bounds, sampling_plan, step_size
from vifpk.montecarlo.progress import label
from vifpk.montecarlo.rng import block_seeds
from vifpk.montecarlo.runplan import Clock, RunPlan
from vifpk.montecarlo.stepper import Arrays, Stepper, arrays
from vifpk.montecarlo.tuning import (
    BIAS_FRACTION,
    BURN_SHARE,
    CHECK_FACTOR,
    OMEGA_REF,
    scene_omega,
)

from vifpk.core.defaults import BURN_FACTOR
from vifpk.core.result import CostRefused


@dataclass(frozen=True, kw_only=True)
class Started:
    """Paths ready to sample (stage 3's result): the step and sampling plan as settled (dt
    "auto": after the scale pilot), the histogram edges, the arrays (updated in place by the
    windows), the certificate's window means, the windows already sampled (``run_to``), the
    burn-in in steps, and what the pilots measured."""

    h: float
    stride: int
    spw: int
    n_win: int
    edges: dict[str, np.ndarray]
    arr: Arrays
    windows: np.ndarray | None
    run_to: int
    n_burn: int
    relax: dict[str, Any] | None
    dt_rule: dict[str, Any] | None
    pilot_s: float
    t_burn: float  # perf_counter when the burn-in (or the continuation) began
    reach: float = 0.0  # the top of the over-dispersed starts (0: a continued run's)
    coarse: dict[str, Any] | None = None  # the burn-in's part at a coarser step (or None)

    @property
    def win_steps(self) -> int:
        """Steps per certificate window."""
        return self.spw * self.stride


def begin(plan: RunPlan, clock: Clock, step: Stepper, bar: Any) -> Started:
    """A new run: pilots, starts, burn-in (module docstring). ``step.h`` follows dt "auto"."""
    st, phys, target = plan.settings, plan.phys, plan.target
    h, stride, spw, n_win = plan.h, plan.stride, plan.spw, plan.n_win
    blocks, per_block = plan.blocks, plan.per_block
    edges = clock.edges
    dt_rule = None
    t1 = time.perf_counter()
    a_hint = float(edges["edges_A"][-1]) if "edges_A" in edges else 1.0
    path_max: list[float] = []
    if st.start_reach > 0 and st.dt != "auto" and edges:  # measured by an earlier run
        a_hi = float(st.start_reach)
    else:
        a_hi = pilot_scale(phys, h, st.seed, step, a_hint, path_max)
        step.laps.lap("scale_pilot")
    if st.dt == "auto":  # the step from the orbits the pilot's paths reach (auto_dt)
        a_typ = float(np.median(path_max)) if np.isfinite(path_max).all() else math.nan
        h_pilot, h = h, step_size(st.dt, target, phys, st.sample_every, a_typ)
        step.h = h
        stride, spw, n_win = sampling_plan(st.time, st.sample_every, h, target)
        dt_rule = {"pilot_dt": h_pilot, "amplitude": a_typ, "omega_ref": OMEGA_REF,
                   "omega": scene_omega(phys, a_typ) if a_typ > 0 else None,
                   "rule": "dt = dt_ref(F) OMEGA_REF / Omega, Omega the fastest free "
                           "orbit on amplitudes up to the median of the scale pilot's "
                           "path maxima (montecarlo/tuning.py)"}
    if not edges:
        edges = _edges(a_hi, phys, st.bins, h, step.cause)
    relax, burn_in = _burn_in(plan, step, bar, a_hi, h)
    pilot_s = time.perf_counter() - t1
    if relax is not None:
        step.laps.lap("relaxation_pilot")

    need = float(blocks * per_block) * (burn_in / h + n_win * spw * stride)
    if st.burn_in == "auto" and need > st.max_path_steps:
        raise CostRefused(
            f"the relaxation pilot measured a relaxation time of {relax['tau']:.3g}, so "
            f"the burn-in is {burn_in:.3g} and the run {need:.3g} path-steps, more "
            f"than the {st.max_path_steps:.3g} allowed",
            relaxation_time=float(relax["tau"]), burn_in=float(burn_in),
            path_steps=need, limit=float(st.max_path_steps))
    if not burn_in / h < 2.0**53:  # beyond any run (and numba's integers)
        raise SimulationDiverged(
            "the relaxation pilot measured a relaxation time of "
            f"{burn_in / BURN_FACTOR:.3g} (burn-in {burn_in:.3g} = {burn_in / h:.3g} "
            f"steps of dt = {h:g}): the paths "
            "barely forget their start (most likely the noise is too weak to mix them: "
            "check noise.D and f); give montecarlo.burn_in explicitly to run anyway")
    coarse = _coarse_burn_in(plan, relax, burn_in, h, n_win * spw * stride * h,
                             (dt_rule or {}).get("omega"))
    n_coarse = int(round(burn_in / (CHECK_FACTOR * h))) if coarse is not None else 0
    if coarse is not None:
        burn_in = coarse["fine"]
    n_burn = int(round(burn_in / h))
    win_steps = spw * stride
    gen = np.random.default_rng(np.random.SeedSequence(st.seed, spawn_key=(1 << 24,)))
    frac = START_LOW + (1 - START_LOW) * (np.arange(per_block) + 0.5) / per_block
    amps = np.broadcast_to(a_hi * frac, (blocks, per_block)).copy()
    if st.start_state is None:
        state0 = starts(amps, phys, gen)
    else:  # where an earlier run of the scene ended (the step check's coarse run)
        state0 = np.array(st.start_state, dtype=float)
        if state0.shape != (blocks, per_block, 3):
            raise ValueError(f"start_state has shape {state0.shape}; the run's paths need "
                             f"{(blocks, per_block, 3)}")
    arr = arrays(block_seeds(st.seed, blocks, per_block), state0, edges, plan.obs)
    windows = np.zeros((blocks, per_block, n_win)) if st.certificate else None

    t2 = time.perf_counter()
    if bar is not None:
        bar.reset(total=blocks * per_block * (n_burn + n_win * win_steps))
        label(bar, "monte carlo")
    if n_coarse:  # the start forgotten at CHECK_FACTOR x dt, then the coarse law at dt
        step.h = CHECK_FACTOR * h
        step.run(arr, n_coarse, 0, n_coarse, stride)
        step.h = h
    step.run(arr, n_burn, 0, n_burn, stride)
    return Started(h=h, stride=stride, spw=spw, n_win=n_win, edges=edges, arr=arr,
                   windows=windows, run_to=0, n_burn=n_burn, relax=relax, dt_rule=dt_rule,
                   pilot_s=pilot_s, t_burn=t2, reach=a_hi, coarse=coarse)


def _edges(a_hi: float, phys: dict[str, Any], bins: int, h: float, cause: str
           ) -> dict[str, np.ndarray]:
    """The histogram ranges from the scale pilot's reach ``a_hi``: A on [0, a_hi], x1 on the
    walls' span within it, x2 up to the speed of the orbit of amplitude a_hi."""
    try:
        vmax = math.sqrt(2 * potential(a_hi, phys))
    except OverflowError:
        vmax = math.inf
    if not math.isfinite(vmax):
        raise diverged(h, f"the pilot reached amplitude {a_hi:.3g}, whose energy "
                       "overflows double precision", cause)
    return {"edges_A": np.linspace(0.0, a_hi, bins + 1),
            # x1 lives on [a, b] (the walls), within the pilot's reach
            "edges_x": np.linspace(max(-a_hi, bounds(phys)[0]),
                                   min(a_hi, bounds(phys)[1]), bins + 1),
            "edges_v": np.linspace(-vmax, vmax, bins + 1)}


def _burn_in(plan: RunPlan, step: Stepper, bar: Any, a_hi: float, h: float
             ) -> tuple[dict[str, Any] | None, float]:
    """(the relaxation pilot's fit or None, the burn-in time): the settings' time, or with
    "auto" max(BURN_FACTOR tau, MIN_AUTO_BURN_IN), tau the relaxation pilot's."""
    st = plan.settings
    if st.burn_in != "auto":
        return None, float(st.burn_in)
    label(bar, "monte carlo: relaxation pilot")
    relax = relaxation(plan.phys, h, st.seed, step, a_hi, st.sample_every)
    return relax, max(BURN_FACTOR * relax["tau"], MIN_AUTO_BURN_IN)


def _coarse_burn_in(plan: RunPlan, relax: dict[str, Any] | None, burn_in: float, h: float,
                    first: float, omega: float | None) -> dict[str, Any] | None:
    """The burn-in in two parts, where that is cheaper and the run's step check will judge
    the step (dt and burn-in "auto", a target floor F, the check on): the whole burn-in
    (BURN_FACTOR tau) at k dt, k = CHECK_FACTOR, forgets the over-dispersed start as before,
    but toward the law at k dt, for 1 / k of the cost; then at dt, the time
    tau ln(D tau / (BURN_SHARE F T_1)), at most the whole burn-in, forgets the law at k dt.

    Why that long: D bounds the L1 distance between the laws at k dt and dt, the distance the
    step check measures; D = (k^2 - 1) BIAS_FRACTION F, the distance beyond which the check
    fails (and the run says so: tuning.step_check), so a run whose check does not fail has
    started within D. What is left of it after a time B at dt is at most D e^(-B / tau)
    e^(-t / tau) (tau the relaxation pilot's, the slowest relaxation it saw); averaged over
    the sampled time T >= T_1 (the first stage's: the run samples at least that) it is at
    most D e^(-B / tau) tau / T_1, which B makes BURN_SHARE F. Paper-base at F = 0.005: D =
    0.0375, tau ~ 89, T_1 = 1000: 1.9 tau at dt after 6 tau at 4 dt, 3.4 tau of the cost
    of dt instead of 6. The equilibration certificate still checks the result (R-hat across
    the starts, drift). None where it does not apply or would cost more than the burn-in at
    dt, or where k dt would not be stable (Omega k dt >= 1, as for the check)."""
    st, target = plan.settings, plan.target
    if not (st.dt == "auto" and st.dt_check and relax is not None and target > 0
            and st.start_state is None and omega is not None
            and CHECK_FACTOR * h * omega < 1.0):
        return None
    tau = float(relax["tau"])
    far = min(2.0, (CHECK_FACTOR**2 - 1) * BIAS_FRACTION * target)
    fine = min(tau * max(math.log(far * tau / (BURN_SHARE * target * first)), 0.0), burn_in)
    if burn_in / CHECK_FACTOR + fine >= burn_in:
        return None
    return {"dt": CHECK_FACTOR * h, "time": burn_in, "fine": fine, "distance": far,
            "share": BURN_SHARE, "first_stage": first}


def resume(plan: RunPlan, clock: Clock, bar: Any) -> Started:
    """A run continued from its checkpoint: its plan, its paths, the next window on."""
    ck = plan.resume
    h = plan.h
    n_burn, stride, spw = ck.n_burn, ck.stride, ck.spw
    arr = Arrays(rng=ck.arrays["rng"].copy(), state=ck.arrays["state"].copy(),
                 hist={**clock.edges, **{k: None if ck.hist[k] is None else
                                         ck.hist[k].copy() for k in ("A", "x", "v", "joint")}},
                 moments=_copy(ck.arrays["moments"]), events=ck.arrays["events"].copy(),
                 stuck=ck.arrays["stuck"].copy(), energy=_copy(ck.arrays["energy"]))
    t2 = time.perf_counter()
    if bar is not None:
        bar.reset(total=1)
        label(bar, "monte carlo: extending")
    return Started(h=h, stride=stride, spw=spw, n_win=ck.run_to, edges=clock.edges, arr=arr,
                   windows=_copy(ck.windows), run_to=ck.run_to, n_burn=n_burn, relax=ck.relax,
                   dt_rule=None, pilot_s=0.0, t_burn=t2,
                   coarse=ck.notes.get("burn_in_coarse"))


def _copy(a: np.ndarray | None) -> np.ndarray | None:
    return None if a is None else a.copy()
