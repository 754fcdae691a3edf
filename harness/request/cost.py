"""What a run costs, before it runs: seconds and memory, and the refusals they lead to.

The Monte Carlo's time is path-steps / (steps per second per core x cores); the rate is
``MC_STEPS_PER_CORE`` (faster than every kernel measured, so an estimate is a lower bound)
unless the machine's own speed was calibrated (``machine_speed``, cached per machine). A run
estimated above ``HOUR`` needs ``--yes``; a run whose arrays would not fit in memory is refused
outright. Split from validate.py (issue 27); the constants' sources are beside them.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path

from vifpk.harness.door.solvers import MonteCarloRun
from vifpk.harness.request.errors import InputError

from vifpk.core import registry
from vifpk.core.defaults import CHECK_MODELS, FPK_CELLS
from vifpk.core.registry import CLOSED_FORM, ORIGINAL, ORIGINAL_FPK
from vifpk.core.scene import Scene

HOUR = 3600.0


def numba_threads_available() -> int:
    """The threads numba can use: NUMBA_NUM_THREADS if set, else the cores."""
    env = os.environ.get("NUMBA_NUM_THREADS", "").strip()
    return int(env) if env.isdigit() and int(env) >= 1 else (os.cpu_count() or 1)


# measured rates for the cost estimate (lower bounds of the wall time)
# (solve on the base scene, this machine, 2026-11-23: FPK 2.6 / 2.9 / 4.1 / 5.6 s at 400 / 800
# / 1600 / 3200 cells; closed forms at 3201 points: paper 0.11 s, exact 2.6 s with 64 nodes x 24
# harmonics); each rate below is faster than measured, so the estimate is a lower bound
MC_STEPS_PER_CORE = 150e6  # faster than every kernel measured: benchmarks/results/kernel_bound.json


#   (paper-base 68.7, no friction 106.7, smooth OU 123.6 M path-steps/s a core; 60e6 was below)
FPK_SECONDS_PER_CELL = 5e-4  # measured 1.7e-3 s per cell at 3200 cells
#: the original system's FPK (vifpk.fpk2d), CPU seconds per cell of its n x n grid: measured
#: 2.3e-5 at 320^2 and 2.9e-5 at 160^2 (2 cores, loaded); its LU grows faster than n^2, so a
#: lower bound
FPK2D_SECONDS_PER_CELL = 1e-5


AVG_SECONDS_PER_POINT = 1e-5  # paper model, measured 3.5e-5 s per point


AVG_SECONDS_PER_NODE = 2e-7  # exact model, per point x theta node x harmonic, measured 5.2e-7


# --------------------------------------------------------------------------------------------
# cost
def _montecarlo_parts(scene: Scene, speed: float | None) -> tuple[float, float, float]:
    """(seconds of the pilots and the burn-in, of the first sampled windows, of the sampling
    a target floor needs at least) at ``speed`` path-steps per second per core (default
    MC_STEPS_PER_CORE, faster than any machine measured) on every core the run uses, from the
    Monte Carlo's own plan (montecarlo.plan: burn-in "auto" at its minimum, the pilots' sizes);
    with a target floor the first windows are half of ``time``, else the sampled time."""
    from vifpk.harness.door.solvers import montecarlo_plan

    mc = scene.montecarlo
    plan = montecarlo_plan(scene)
    cores = mc.threads or min(numba_threads_available(), os.cpu_count() or 1)
    per_step = 1.0 / plan.dt / ((speed or MC_STEPS_PER_CORE) * cores)
    first = mc.time / 2 if mc.floor > 0 else plan.sampled_time
    needed = floor_time(scene) if mc.floor > 0 else 0.0
    return ((mc.paths * plan.burn_in + plan.pilot_path_time) * per_step,
            mc.paths * first * per_step, mc.paths * needed * per_step)


def _montecarlo_least_seconds(scene: Scene) -> float:
    """Lower bound of the least wall time a Monte Carlo run does (the pilots, the burn-in
    and the first sampled windows; see :func:`_montecarlo_parts`)."""
    fixed, first, _ = _montecarlo_parts(scene, None)
    return fixed + first


def montecarlo_seconds(scene: Scene, *, speed: float | None = None) -> float:
    """Lower bound of the wall time of one Monte Carlo run of the original system
    (:func:`_montecarlo_parts`): with a target floor, the sampling is the larger of the
    first windows and what the floor needs (:func:`floor_time`), cut at ``budget`` seconds
    when there is one (0: no limit)."""
    mc = scene.montecarlo
    fixed, first, needed = _montecarlo_parts(scene, speed)
    sampling = max(first, needed)
    if mc.floor > 0 and mc.budget > 0:
        sampling = min(sampling, mc.budget)
    return fixed + sampling


def floor_time(scene: Scene) -> float:
    """Lower bound of the sampled time per path that reaching the target floor F needs.

    N >= 2 / (pi F^2) independent samples: the floor of a histogram is sqrt(2/pi) sum se_i
    w_i >= sqrt(2 / (pi N)) (sum sqrt(q_i) >= 1 for bin masses q_i, se_i^2 = q_i / (N w_i^2)
    at best), and a path gives at most one independent sample a ``sample_every``."""
    mc = scene.montecarlo
    return 2.0 / (math.pi * mc.floor**2) * mc.sample_every / mc.paths


def memory_bytes(scene: Scene) -> float:
    """Lower bound of the memory one Monte Carlo run allocates: per path its state and random
    generator (~100 bytes) and the equilibration certificate's window sums (8 bytes a window:
    the plan's windows, or with a target floor as many windows of the plan's length as fit
    in ``montecarlo.time``, the most a floor run can grow to)."""
    from vifpk.harness.door.solvers import montecarlo_plan

    mc = scene.montecarlo
    plan = montecarlo_plan(scene)
    windows = float(plan.windows)
    if mc.floor:
        window_time = plan.samples_per_window * plan.sample_interval
        windows = max(windows, mc.time / max(window_time, 1e-300))
    return mc.paths * (100.0 + 8.0 * min(windows, 1e6))


def refuse_oversized(scene: Scene, option: str = "--paths") -> None:
    """A run that cannot fit in this machine's memory is refused even with --yes."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return
    need = memory_bytes(scene)
    if need > total:
        raise InputError(f"{option} {scene.montecarlo.paths}: the simulation needs at least "
                         f"{need / 2**30:.3g} GiB of memory; this machine has {total / 2**30:.3g}"
                         " GiB; allowed: fewer paths")


def refuse_costly(seconds: float | Callable[[float | None], float], what: str, yes: bool
                  ) -> None:
    """Refuse a run estimated above an hour, unless ``--yes``.

    ``seconds`` may be a function of the machine's speed (path-steps per second per core):
    the estimate at MC_STEPS_PER_CORE (faster than any machine) decides alone when it is
    already above the hour or far below it; in between, the speed measured on this machine
    (:func:`machine_speed`, a short calibration, cached) decides."""
    if yes:
        return
    if callable(seconds):
        fast = seconds(None)
        if HOUR / CALIBRATE_BELOW < fast <= HOUR:
            seconds = seconds(machine_speed())
        else:
            seconds = fast
    if seconds > HOUR:
        raise InputError(f"{what}: estimated at least {_duration(seconds)} of computation; "
                         "allowed without --yes: up to 1 hour (reduce the size, or add --yes)")


def run_cost_limit(scene: Scene, yes: bool) -> tuple[float, float] | None:
    """(seconds, path-steps per second) for harness.door.solvers.MonteCarloRun: the hour the guard
    allows without ``--yes`` at this machine's speed on the run's cores, the one refuse_costly
    applies up front. The speed is the cached calibration (or VIFPK_STEPS_PER_SECOND), never
    faster than MC_STEPS_PER_CORE; with none cached, MC_STEPS_PER_CORE (so that only a run
    certainly above the hour is stopped). None with ``--yes`` (no limit)."""
    if yes:
        return None
    mc = scene.montecarlo
    cores = mc.threads or min(numba_threads_available(), os.cpu_count() or 1)
    speed = min(cached_speed() or MC_STEPS_PER_CORE, MC_STEPS_PER_CORE)
    return HOUR, speed * cores


@contextmanager
def guarded_run(scene: Scene, yes: bool) -> Iterator[MonteCarloRun]:
    """Yields the MonteCarloRun to hand the workflow inside (its ``run`` argument): the run
    is priced again once its relaxation pilot has measured an automatic burn-in
    (run_cost_limit, the run's ``cost_limit``); a refusal then is worded here
    (priced_burn_in), where the rest of the guard's words are."""
    from vifpk.core.result import CostRefused

    limit = run_cost_limit(scene, yes)
    try:
        yield MonteCarloRun(cost_limit=limit)
    except CostRefused as exc:
        if limit is None:
            raise
        raise CostRefused(priced_burn_in(exc.numbers, *limit), **exc.numbers) from None


def priced_burn_in(numbers: Mapping[str, float], seconds: float, rate: float) -> str:
    """The one line of a run refused once its relaxation pilot has measured the burn-in
    (montecarlo's CostRefused numbers: relaxation_time, burn_in, path_steps)."""
    return (f"the relaxation pilot measured a relaxation time of "
            f"{numbers['relaxation_time']:.3g}, so the automatic burn-in is "
            f"{numbers['burn_in']:.3g} time units and the run {numbers['path_steps']:.3g} "
            f"path-steps: estimated at least {_duration(numbers['path_steps'] / rate)} at "
            f"{rate / 1e6:.3g} M path-steps/s; allowed without --yes: up to "
            f"{'1 hour' if seconds == HOUR else _duration(seconds)}; give --yes, a fixed "
            "burn-in (--set montecarlo.burn_in=T), or stronger noise (a larger noise.D or "
            "system.f: the paths mix faster)")


CALIBRATE_BELOW = 8.0  # an estimate at the fastest rate above HOUR / 8 is re-estimated with


def _cache_file() -> Path:
    from vifpk.core.defaults import cache_dir

    return cache_dir() / "speed.json"


def machine_speed() -> float:
    """Path-steps per second per core of the original system's simulation on this machine.

    ``VIFPK_STEPS_PER_SECOND`` overrides it; else the value cached in
    ``speed.json`` in vifpk.core.defaults.cache_dir() for this host and core count; else a
    short calibration (the base scene, 512 paths x 200 time units on one thread, ~1-5 s with
    the compile), which is cached with the load average it was taken under."""
    import socket

    known = cached_speed()
    if known is not None:
        return known
    key = {"host": socket.gethostname(), "cores": os.cpu_count()}
    path = _cache_file()
    speed = _calibrate()
    try:
        from vifpk.core.io import write_json

        write_json(path, {**key, "steps_per_second_per_core": speed,
                          "load_average": os.getloadavg()[0],
                          "how": "harness.request.cost._calibrate: paper-base, 512 paths, one "
                                 "thread, 200 time units at dt 0.01"})
    except OSError:
        pass  # an unwritable cache: measure again next time
    return speed


def cached_speed() -> float | None:
    """VIFPK_STEPS_PER_SECOND, else the speed cached for this host and core count (see
    :func:`machine_speed`), else None: nothing is measured here."""
    import json
    import socket

    env = os.environ.get("VIFPK_STEPS_PER_SECOND")
    if env:
        try:
            if float(env) > 0:
                return float(env)
        except ValueError:
            pass
        raise InputError(f"VIFPK_STEPS_PER_SECOND={env}: allowed: a number > 0")
    key = {"host": socket.gethostname(), "cores": os.cpu_count()}
    try:
        cached = json.loads(_cache_file().read_text(encoding="utf-8"))
        if {k: cached.get(k) for k in key} == key and cached["steps_per_second_per_core"] > 0:
            return float(cached["steps_per_second_per_core"])
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return None


def _calibrate() -> float:
    import sys

    from vifpk.harness.door.solvers import run_solver

    from vifpk.core.scene import load_scene

    print("vifpk: measuring this machine's simulation speed once (a few seconds; cached in "
          f"{_cache_file()})", file=sys.stderr, flush=True)
    scene = load_scene("paper-base").with_values({
        "montecarlo.paths": 512, "montecarlo.blocks": 32, "montecarlo.time": 200.0,
        "montecarlo.burn_in": 0.0, "montecarlo.dt": 0.01, "montecarlo.threads": 1,
        "montecarlo.floor": 0.0})
    info = run_solver(scene, "montecarlo", progress=False).info
    return float(info["steps_per_second"]) / max(int(info.get("threads", 1)), 1)


def _duration(s: float) -> str:
    if s < 2 * HOUR:
        return f"{s / 60:.0f} minutes"
    if s < 48 * HOUR:
        return f"{s / HOUR:.0f} hours"
    return f"{s / 86400:.3g} days"


def fpk_seconds(cells: int) -> float:
    """One FPK stationary solve priced as py-pde's stepping (``method="stepping"``), on which
    it was measured: FPK_SECONDS_PER_CELL x cells, times cells / 3200 above 3200 cells (the
    stable step shrinks with the cell: measured 1.4 s of CPU at 3200 cells and more than 56 s
    at 12800, load 11; it was priced linearly, so --grid 5e6 ran for minutes with no word).
    The check and ``solve --solver fpk`` now solve directly (fpk.stationary's default since
    issue 44, 100-400x cheaper at the default grid): for them this price is an upper estimate,
    not a lower bound, so the guard asks --yes early on huge grids rather than late."""
    return FPK_SECONDS_PER_CELL * cells * max(1.0, cells / 3200)


def averaging_seconds(scene: Scene, model: str) -> float:
    """Lower bound of one closed-form solve: AVG_SECONDS_PER_POINT per grid point (paper),
    AVG_SECONDS_PER_NODE per point x theta node x harmonic (exact and corrected: the orbit
    quadrature)."""
    av = scene.averaging
    if model != "paper":  # exact, corrected: orbit quadratures
        return AVG_SECONDS_PER_NODE * av.points * av.theta_nodes * av.harmonics
    return AVG_SECONDS_PER_POINT * av.points


def solve_seconds(scene: Scene, solver: str, model: str, grid: int | None, *,
                  speed: float | None = None) -> float:
    """Lower bound of ``vifpk solve``."""
    if solver == ORIGINAL:
        return montecarlo_seconds(scene, speed=speed)
    if solver == ORIGINAL_FPK:  # the grid asked and its half (the error estimate), or 128^2
        n = grid or 128
        return FPK2D_SECONDS_PER_CELL * 1.25 * n * n
    base = averaging_seconds(scene, model)
    # an FPK solver (vifpk's or a plugin's) priced as vifpk's on that grid
    return base + (fpk_seconds(grid or FPK_CELLS) if solver != CLOSED_FORM else 0.0)


def check_seconds(scene: Scene, models: tuple[str, ...] = CHECK_MODELS, *,
                  speed: float | None = None) -> float:
    """Lower bound of ``vifpk check``: the Monte Carlo of the original system, the closed
    forms and FPKs of the models that apply (the averaged SDEs are not counted): the
    models that do not apply to the scene are left out (they are not run there)."""
    models = registry.applicable(scene, models)[0]
    return (montecarlo_seconds(scene, speed=speed)
            + sum(averaging_seconds(scene, m) for m in models)
            + len(models) * fpk_seconds(FPK_CELLS))


def workprecision_seconds(scene: Scene, quick: bool, *, speed: float | None = None) -> float:
    """Lower bound of ``vifpk workprecision``: its Monte Carlo reference run (256 paths x 400
    time units with --quick, else 4096 x 4000, at dt / 2)."""
    from dataclasses import replace

    paths, time_ = (256, 400.0) if quick else (4096, 4000.0)
    mc = scene.montecarlo
    ref = replace(scene, montecarlo=replace(mc, paths=paths, time=time_, blocks=16,
                                            dt=float(mc.dt) / 2, floor=0.0))
    return montecarlo_seconds(ref, speed=speed)
