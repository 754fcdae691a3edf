"""Driver of the Monte Carlo of the original system: seeding, batching, histograms, errors,
the burn-in, the equilibration certificate and the stop at a target noise floor.

Independent blocks of paths are the batches. Path p of block b has its own generator, seeded
from ``numpy.random.SeedSequence(seed, spawn_key=(b,))`` (the b-th child of
``SeedSequence(seed)``; its 4 x paths-per-block state words seed the block's paths), and its
own state (x, v, xi). The kernel advances all paths by a given number of steps, so a run may be
cut into any number of calls (short ones, so that Ctrl-C is seen within about a second, and
more of them when the run is extended toward a target floor) and still gives bit-identical
results for a seed, for any thread count. Densities are block means; the error bar of each bin
is the standard error of the block means (paths in different blocks are independent, samples
along one path are not). The L1 noise floor is the expected L1 of pure sampling noise,
sum_i sqrt(2/pi) se_i w_i (Gaussian bin errors).

The run: a short pilot sets the histogram ranges and the amplitude scale; with
``burn_in = "auto"`` a second pilot measures the relaxation time (tuning.py); the paths start
over-dispersed; after the burn-in the sampled time is 16 to 32 windows of whole samples
(sampling_plan; 8 windows of time / 16 when a target floor is set, then extended window by
window toward the floor, within the budget);
the certificate (certificate.py) reads the per-path window means.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from vifpk.montecarlo.assemble import assemble
from vifpk.montecarlo.burnin import begin, resume
from vifpk.montecarlo.failures import BudgetExhausted, SimulationDiverged, likely_cause
from vifpk.montecarlo.pilots import START_LOW
from vifpk.montecarlo.progress import PLAIN_PROGRESS_EVERY, progress_bar
from vifpk.montecarlo.rng import block_seeds
from vifpk.montecarlo.runplan import OBSERVABLES, Settings, compile_kernel, effects, resolve
from vifpk.montecarlo.sampling import sample
from vifpk.montecarlo.stepper import CHUNK_SECONDS, Stepper
from vifpk.montecarlo.timing import Laps

from vifpk.core.result import Result

#: the names this module has always offered (their homes are the stage modules)
__all__ = ["CHUNK_SECONDS", "OBSERVABLES", "PLAIN_PROGRESS_EVERY", "START_LOW",
           "BudgetExhausted", "Settings", "SimulationDiverged", "block_seeds", "effects",
           "simulate"]


def simulate(system: Any, noise: Any, settings: Settings, *, parametric: Any = None,
             **overrides: Any) -> Result:
    """Monte Carlo of the original system for (duck-typed) scene.system, scene.noise and
    scene.parametric (``parametric``: None, or its stiffness and damping intensities).

    Raises ValueError on settings it cannot use (a ``resume`` checkpoint of another run among
    them), SimulationDiverged when the run blows up and BudgetExhausted when a target floor's
    budget ends before the first sampling window.

    ``settings.resume``: continue a run from its checkpoint (checkpoint.py): its step, burn-in
    and histogram ranges are kept (``dt`` and ``edges`` are not read), and the result is that of
    the whole run so far. ``settings.keep_state``: info["checkpoint"] holds where it stopped.

    The stages, each in its module: the plan from the settings (runplan.resolve), the kernel
    compiled apart from the run (runplan.compile_kernel), the pilots and the burn-in or the
    checkpoint's paths (burnin.begin, burnin.resume), the sampled windows toward a target
    floor (sampling.sample), the result (assemble.assemble).
    """
    laps = Laps()  # info["timing"] (timing.py): each stage's wall and CPU seconds
    plan = resolve(system, noise, replace(settings, **overrides), parametric)
    laps.lap("plan")
    clock = compile_kernel(plan)
    laps.lap("kernel")
    bar = progress_bar(plan.settings.progress)
    step = Stepper(plan.phys, plan.h, plan.threads, bar, likely_cause(system, parametric, plan.h))
    step.laps = laps
    try:
        run = begin(plan, clock, step, bar) if plan.resume is None else resume(plan, clock, bar)
        laps.lap("burn_in")
        done = sample(plan, clock, run, step, bar)
        laps.lap("sampling")
    finally:
        if bar is not None:
            bar.close()
    return assemble(system, noise, plan, clock, run, done, step, simulate)
