"""A stationary run's settings and the first two stages of simulate.py: ``Settings`` (the
caller's plain numbers), ``resolve`` (stage 1: the step, the sampling windows, the blocks, the
physics, a checkpoint checked against them: a ``RunPlan``) and ``compile_kernel`` (stage 2:
the kernel compiled, or loaded from numba's cache, for the run's types apart from the run, and
the run's clock started)."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numba
import numpy as np
from vifpk.montecarlo.checkpoint import Checkpoint, run_key
from vifpk.montecarlo.plan import physics, sampling_plan, step_size
from vifpk.montecarlo.rng import block_seeds
from vifpk.montecarlo.stepper import arrays, kernel_call

from vifpk.core.sections import Observables

OBSERVABLES = ("A", "x1", "x2", "joint", "moments", "events", "energy")


@dataclass(frozen=True, kw_only=True)
class Settings:
    """Monte Carlo settings: plain numbers, no defaults (the scene's [montecarlo] section
    holds the one set of defaults, vifpk.core.scene.MonteCarloSettings).

    dt: a step, or "auto" (tuning.auto_dt for the target floor); burn_in: a time, or "auto"
    (BURN_FACTOR x the relaxation time measured by a pilot); floor: target L1 noise floor of
    p(A), 0 for none (then exactly ``time`` is sampled); budget: wall seconds for reaching the
    floor (0: no limit); max_path_steps: the path-steps the burn-in and the (first) sampled
    windows may take once an "auto" burn-in is measured (inf: no limit), else
    vifpk.core.result.CostRefused is raised before the burn-in starts (the caller's cost
    guard prices the run with the measured burn-in); dt_check: with dt "auto", check the
    step's bias at run time (stepcheck.step_check, tuning.step_check)."""

    paths: int
    dt: float | str
    time: float
    burn_in: float | str
    sample_every: float
    seed: int
    blocks: int
    bins: int
    threads: int
    floor: float
    budget: float
    observables: tuple[str, ...] = Observables().names()  # the scene's one default (issue 38)
    progress: bool = True
    certificate: bool = True
    dt_check: bool = True
    max_path_steps: float = math.inf
    edges: dict[str, Any] = field(default_factory=dict, compare=False)
    #: a checkpoint.Checkpoint (or its bytes) to continue from: the same paths, the next
    #: window on, toward this run's floor; no pilot, no burn-in (checkpoint.py)
    resume: Any = field(default=None, compare=False, repr=False)
    #: return where the run stopped as info["checkpoint"] (a checkpoint.Checkpoint)
    keep_state: bool = False
    #: the top of the over-dispersed starts (the scale pilot's reach, burnin.begin) from an
    #: earlier run of the same scene at a given step with its ``edges`` (the step check's
    #: coarse run, stepcheck.py): no scale pilot is run; 0: the scale pilot measures it
    start_reach: float = 0.0
    #: (x, v, xi) of every path, [blocks, paths per block, 3], to start from instead of the
    #: over-dispersed starts (the step check's coarse run starts where the run ended,
    #: stepcheck.py); None: the over-dispersed starts
    start_state: Any = field(default=None, compare=False, repr=False)


@dataclass(frozen=True, kw_only=True)
class RunPlan:
    """What the settings resolve to before any path runs (stage 1). ``h``, ``stride``,
    ``spw`` and ``n_win`` are provisional with dt "auto": the scale pilot settles them
    (burnin.begin)."""

    settings: Settings
    resume: Checkpoint | None
    obs: tuple[str, ...]  # the observables, "A" first when a target floor needs it
    target: float  # the target L1 floor of p(A), 0 for none
    phys: dict[str, Any]  # plan.physics
    h: float
    threads: int
    stride: int  # steps between samples
    spw: int  # samples per certificate window
    n_win: int  # windows to sample (the first stage's, with a target floor)
    blocks: int
    per_block: int
    t_start: float  # perf_counter at the start of the run, compile included


@dataclass(frozen=True, kw_only=True)
class Clock:
    """Stage 2's result: the histogram edges given (by the settings or the checkpoint; {}:
    the scale pilot sets them), the compile time, and the run's clock: the budget counts the
    run (pilots, burn-in, windows), not numba's one-off compile."""

    edges: dict[str, np.ndarray]
    compile_s: float
    t_run: float
    deadline: float


def resolve(system: Any, noise: Any, st: Settings, parametric: Any = None) -> RunPlan:
    """Stage 1: the run's plan from its settings (overrides applied). Raises ValueError on
    settings it cannot use, a ``resume`` checkpoint of another run among them."""
    ck = st.resume
    if isinstance(ck, bytes | bytearray):
        ck = Checkpoint.from_bytes(bytes(ck))
    obs = tuple(o for o in st.observables if o in OBSERVABLES)
    target = float(st.floor) if st.floor else 0.0
    if target > 0 and "A" not in obs:
        obs = ("A", *obs)
    phys = physics(system, noise, parametric)
    h = ck.h if ck is not None else step_size(st.dt, target, phys, st.sample_every)
    if not (math.isfinite(h) and h > 0 and st.paths >= st.blocks >= 2):
        raise ValueError("need dt > 0 and paths >= blocks >= 2")
    t_start = time.perf_counter()
    threads = st.threads or numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(threads)
    stride, spw, n_win = sampling_plan(st.time, st.sample_every, h, target)
    per_block = st.paths // st.blocks
    blocks = st.blocks
    run = run_key(phys, h, st.seed, blocks, per_block, obs, st.certificate)
    if ck is not None and (ck.key != run or (st.dt != "auto" and float(st.dt) != ck.h)):
        raise ValueError("resume: the checkpoint belongs to another run (its physics, dt, seed, "
                         "paths, blocks or observables differ from these settings)")
    return RunPlan(settings=st, resume=ck, obs=obs, target=target, phys=phys, h=h,
                   threads=threads, stride=stride, spw=spw, n_win=n_win, blocks=blocks,
                   per_block=per_block, t_start=t_start)


def compile_kernel(plan: RunPlan) -> Clock:
    """Stage 2: compile (or load from the cache) apart from the run: a one-step call of the
    same types (the run's observables, its certificate or none); then the run's clock."""
    st, ck = plan.settings, plan.resume
    t0 = time.perf_counter()
    edges = {k: np.asarray(v, dtype=float) for k, v in st.edges.items()}
    if ck is not None:
        edges = {k: np.asarray(ck.hist[k], dtype=float) for k in ("edges_A", "edges_x",
                                                                   "edges_v")}
    tiny = arrays(block_seeds(st.seed, 1, 1), np.full((1, 1, 3), 0.1),
                  edges or {"edges_A": np.linspace(0, 1, 3), "edges_x": np.linspace(0, 1, 3),
                            "edges_v": np.linspace(-1, 1, 3)}, plan.obs)
    kernel_call(tiny, plan.phys, plan.h, 2, 0, 1, 1, 1,
                np.zeros((1, 1, 1)) if st.certificate else None)
    compile_s = time.perf_counter() - t0
    # the budget counts the run (pilots, burn-in, windows), not numba's one-off compile: a cold
    # cache would otherwise eat a small budget before any physics ran
    t_run = time.perf_counter()
    deadline = t_run + st.budget if st.budget and st.budget > 0 else math.inf
    return Clock(edges=edges, compile_s=compile_s, t_run=t_run, deadline=deadline)


def effects(system: Any, noise: Any) -> dict[str, bool | str]:
    """The effects the scene switches on, as info["effects"] names them: friction, a wall
    (the lower one), the noise kind."""
    p = physics(system, noise)
    return {"friction": p["mu"] is not None, "barrier": p["lower"] is not None,
            "noise": p["noise"].kind}
