"""The check's runs (harness/workflows/check.py): the models' closed forms and FPKs, the
original system's Monte Carlo with its extensions, and the averaged SDEs' Monte Carlo, each a
function of the scene (and its model) alone, whatever runs beside it (issue 44, the main job:
the check runs them in threads, harness/workflows/stages.py).
"""

from __future__ import annotations

import math
import threading
import time
import zlib
from dataclasses import replace
from typing import Any

import numpy as np
from vifpk.harness.door.coefficients import carried
from vifpk.harness.door.solvers import (
    MonteCarloRun,
    averaged_sde_solution,
    closed_form,
    model_solution,
    montecarlo_solution,
)
from vifpk.harness.workflows.compare import compare
from vifpk.harness.workflows.stages import Beside, Stages
from vifpk.harness.workflows.verdict import _evidence, sampling_failures

from vifpk.core.defaults import DENSITY_OBSERVABLES, FPK_CELLS
from vifpk.core.result import Resolved

OBSERVABLES = DENSITY_OBSERVABLES


def mc_edges_of(mc: Any) -> dict[str, np.ndarray]:
    """The histogram edges of a Monte Carlo run of the original system (its own, from its
    scale pilot: they depend on the scene, the step and the seed, never on a model), for the
    averaged SDEs' runs that are compared with it bin by bin."""
    return {"edges_A": np.asarray(mc.data["A"]["edges"]),
            "edges_x": np.asarray(mc.data["x1"]["edges"]),
            "edges_v": np.asarray(mc.data["x2"]["edges"])}


def sde_seed(root: int, model: str) -> int:
    """The root seed of the Monte Carlo of ``model``'s averaged SDE: the first word of
    numpy.random.SeedSequence([root, crc32(name)]), so a function of the scene's seed and the
    model's name alone, never of its place in the list of models checked."""
    ss = np.random.SeedSequence([int(root), zlib.crc32(model.encode())])
    return int(ss.generate_state(1, dtype=np.uint32)[0])


def model_solves(scene: Any, models: tuple[str, ...], solvers: tuple[str, ...],
                  tail_mass: bool, stages: Stages) -> tuple[dict[str, Any], dict[str, Any]]:
    """Each model's closed form, then every registered FPK solver (vifpk's fpk, plugins') on
    each model that has one, to be measured against it (none: nothing to measure against).
    Returns (closed forms by model, FPK solutions by "solver:model")."""
    t = time.perf_counter()
    closed = {m: closed_form(scene, model=m, tail_mass=tail_mass) for m in models}
    stages.beside("averaged models (closed forms)", time.perf_counter() - t)
    with_fpk = [m for m in models if closed[m].info.get("closed_form", True)]
    stages.total -= (len(models) - len(with_fpk)) * len(solvers)
    out = {}
    for name in solvers:
        for m in with_fpk:
            t = time.perf_counter()
            out[f"{name}:{m}"] = model_solution(scene, model=m, solver=name, cells=FPK_CELLS)
            stages.beside(f"{name.upper()} of the {m} model", time.perf_counter() - t)
    return closed, out


def original_mc(scene: Any, run: MonteCarloRun | None, quiet: bool, stages: Stages
                 ) -> tuple[Any, int, list[str], Any]:
    """The original system's simulation: its ranges, burn-in and extensions are its own.
    Extended (twice the burn-in and the sampled time) while the certificate says the run is
    too short and the budget allows another run of twice the cost, at most 3 times. Returns
    (result, extensions, the certificate's evidence against it, the scene of the last run)."""
    t_mc = time.perf_counter()
    budget = scene.montecarlo.budget or math.inf
    extensions = 0
    run_scene = scene
    while True:
        stages("Monte Carlo of the original system" + (f" (extended x{2 ** extensions})"
                                                       if extensions else ""))
        mc = montecarlo_solution(replace(run_scene, observables=replace(
            run_scene.observables, A=True, x1=True, x2=True, events=True, moments=True)),
            progress=not quiet, run=run)
        st = mc.resolved
        bad = _evidence(mc.info.get("convergence", {}), {})
        spent = time.perf_counter() - t_mc
        if not bad or extensions >= 3 or spent * 3 > budget - spent:
            return mc, extensions, bad, run_scene
        extensions += 1
        stages.total += 1
        mcs = run_scene.montecarlo
        run_scene = replace(run_scene, montecarlo=replace(
            mcs, time=2 * st.time, burn_in=2 * st.burn_in, dt=st.dt, floor=0.0))


#: the averaged SDEs run this many at a time, each taking the next model in order when it
#: ends: one's Python (its relaxation time, its coefficient tables: 0.7 s for the exact model
#: on paper-base) beside another's kernels, which release the GIL
SDE_LANES = 2


def sde_runs(scene: Any, models: tuple[str, ...], closed: dict[str, Any],
              edges: dict[str, np.ndarray], st: Resolved, burn_in: Any, budget: float,
              stages: Stages) -> dict[str, tuple[Any, int]]:
    """:func:`sde_run` of each model, SDE_LANES at a time in model order. Each run is a
    function of the scene and its model alone (its seed, its own extensions), so the overlap
    changes no number, unless a finite ``budget`` is set: whether a run is extended then
    depends on the wall time it took, which the parts beside it change. A failure is raised as
    in a run one after another: the first model's in order that failed (no model is started
    after one failed)."""
    todo, lock = list(models), threading.Lock()
    done: dict[str, tuple[str, Any]] = {}

    def lane() -> None:
        while True:
            with lock:
                if not todo:
                    return
                m = todo.pop(0)
            try:
                done[m] = ("ok", sde_run(scene, m, closed[m], edges, st, burn_in, budget,
                                          stages))
            except BaseException as exc:  # noqa: BLE001 - raised below, in model order
                done[m] = ("failed", exc)
                with lock:
                    todo.clear()
                return

    lanes = [Beside(carried(lane), name=f"vifpk-sde-{i}")
             for i in range(min(SDE_LANES, len(models)))]
    try:
        for one in lanes:
            one.result()
            stages.flush()
    except BaseException:
        with lock:  # Ctrl-C: no further model (a running one goes on to its end, a daemon)
            todo.clear()
        raise
    for m in models:
        if m in done and done[m][0] == "failed":
            raise done[m][1]
    return {m: done[m][1] for m in models}


def sde_run(scene: Any, model: str, closed: Any, edges: dict[str, np.ndarray],
             st: Resolved, burn_in: Any, budget: float, stages: Stages
             ) -> tuple[Any, int]:
    """The Monte Carlo of ``model``'s averaged SDE on the original system's edges and sample
    plan (its own step, from its relaxation time: montecarlo.averaged_sde), seeded by
    :func:`sde_seed`; doubled (sampled time and burn-in) while it is off its closed form beyond
    SAMPLING_FACTOR x its floor on any observable, at most 3 times and while the budget allows
    a run of twice the cost. Returns (result, extensions): a function of the scene and this
    model alone."""
    t0 = time.perf_counter()
    ext, time_ = 0, st.time
    while True:
        t = time.perf_counter()
        res = averaged_sde_solution(
            scene, model, edges=edges, seed=sde_seed(scene.montecarlo.seed, model), phase=True,
            paths=st.paths, blocks=st.blocks, dt="auto", time=time_, burn_in=burn_in,
            sample_every=st.sample_every)
        stages.beside(f"Monte Carlo of the {model} averaged SDE"
                      + (f" (extended x{2 ** ext})" if ext else ""), time.perf_counter() - t)
        spent = time.perf_counter() - t0
        if (not sampling_failures({o: compare(closed.data[o], res.data[o])
                                   for o in OBSERVABLES}) or ext >= 3
                or spent * 3 > budget - spent):
            return res, ext
        ext += 1
        stages.total += 1
        time_ = 2 * res.resolved.time
        burn_in = 2 * res.resolved.burn_in
