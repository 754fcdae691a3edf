"""The three-way cross-check of one scene: how wrong is each averaged model, and why.

For each averaged model M (``paper``, ``exact``, ``corrected``) on the observables A, x1, x2:

    discretisation_error  FPK(M) against the closed form of M         (numerics of the FPK)
    solver_errors[S]      a registered FPK solver S's p(M) against it  (a plugin's numerics)
    sampling_error        MC of M's averaged SDE against M's closed form (MC noise + bias)
    averaging_error       MC of the ORIGINAL system against M's closed form (the answer)

Every metric against an MC histogram carries its noise floor and error bar (compare.py).
**The simulation of the original system does not know which models are checked** (issue 29):
its histogram ranges come from its own scale pilot (montecarlo.simulate, the range every
``solve --solver montecarlo`` uses), its burn-in from its own relaxation pilot, its extensions
from its own equilibration certificate, so the same seed gives the same numbers for a model
whatever else is checked. The averaged SDEs' runs share its edges (bin by bin comparisons);
each is seeded from the root seed and the model's *name* (``checkruns.sde_seed``) and
extended on its own evidence only.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from vifpk.harness.door.boundary import one_blas_thread
from vifpk.harness.door.coefficients import carried, shared_coefficients
from vifpk.harness.door.original import original_fpk_problem, original_fpk_solution
from vifpk.harness.door.solvers import (
    MonteCarloRun,
    validity,
)
from vifpk.harness.request.tolerance import Tolerance
from vifpk.harness.workflows.assumptions import assumption_warnings
from vifpk.harness.workflows.checkruns import mc_edges_of, model_solves, original_mc, sde_runs
from vifpk.harness.workflows.compare import compare, paired
from vifpk.harness.workflows.stages import Beside, Stages
from vifpk.harness.workflows.tolerance import line as tolerance_line
from vifpk.harness.workflows.tolerance import model_verdicts
from vifpk.harness.workflows.truth import truth_metrics, truth_verdicts
from vifpk.harness.workflows.verdict import (
    assumptions_failing,
    observable_classes,
    recommend,
    sampling_failures,
    sampling_words,
    verdict,
    verdict_class,
)

from vifpk.core import registry
from vifpk.core.defaults import CHECK_MODELS, DENSITY_OBSERVABLES
from vifpk.core.protocols import Ref, WorkflowSpec
from vifpk.core.result import WarningRecord

OBSERVABLES = DENSITY_OBSERVABLES


def models_of(scene: Any, models: tuple[str, ...] = CHECK_MODELS
              ) -> tuple[tuple[str, ...], dict[str, str]]:
    """Of ``models`` (registered names; default CHECK_MODELS), the ones that apply to the
    scene's system, and why each other one does not (each model's own ``applies``:
    vifpk.core.registry.applicable)."""
    return registry.applicable(scene, tuple(models))


@dataclass(frozen=True)
class CheckResult:
    scene: Any
    solutions: dict[str, Any]  # name -> Result(data, info)
    metrics: dict[str, Any]
    warnings: list[WarningRecord]
    verdicts: list[str]
    #: vifpk.core.provenance.collect(); set by the writer
    provenance: dict[str, Any] | None = None
    recommendation: str = ""  # one line: the model to trust here and why (recommend())
    models: tuple[str, ...] = CHECK_MODELS  # the averaged models checked, in report order
    tolerance_lines: tuple[str, ...] = ()  # per model: the tolerance verdict (tolerance.line)


def cross_check(scene: Any, *, quiet: bool = False, fpk: bool = True, sde: bool = True,
                tail_mass: bool = True, models: tuple[str, ...] = CHECK_MODELS,
                tolerance: Tolerance | None = None,
                run: MonteCarloRun | None = None, truth: bool = True,
                warm: Callable[[], Any] | None = None) -> CheckResult:
    """Run every solver on a concrete scene and compute the error decomposition.

    ``run``: the cost limit and checkpoint of the original system's Monte Carlo
    (harness.door.solvers.MonteCarloRun, handed to every run of it here; None: neither).

    ``models``: registered averaged models (vifpk.core.registry), in report order (those that
    do not apply to the scene are named in ``models_absent``); the Monte Carlo of model i's
    averaged SDE is seeded with the scene's seed + 1 + i. A model with no closed form (a
    plugin giving only drift and diffusion) has the FPK direct solve as its reference
    density (harness.door.solvers.closed_form), so no FPK is measured against it (no
    ``discretisation_error``; its entry holds ``reference`` instead).

    ``fpk=False`` skips the FPK of each model (no ``discretisation_error``): a sweep point
    needs only the averaging error, and the FPK is the costliest part of a check.
    ``sde=False`` skips the Monte Carlo of each averaged SDE (no ``sampling_error``, and
    ``sampling_ok`` is None): it checks the closed forms and the Monte Carlo machinery against
    each other, not the averaging error, so a sweep makes it at a few sampled points only
    (harness/sweeps/spec.py); without it only the equilibration certificate can ask for an
    extension. ``tail_mass=False`` skips the closed forms' measurement of the mass beyond
    their grids (a diagnostic of the closed form, about half its cost). ``tolerance``: the
    question of the tolerance verdict (harness/workflows/tolerance.py; default Tolerance(): L1 of
    p(A)
    <= 0.02 at 95%): each model's entry gets ``tolerance`` (its estimate with the noise
    removed, interval, P(error <= tolerance), class), and the recommendation follows it.

    ``truth`` (default): where the original system's own FPK applies (white noise:
    harness/door/original.py), each model's error is also measured against it (no sampling
    noise; its discretisation error stated), the tolerance verdicts and the recommendation are
    decided on it, and the Monte Carlo is its independent cross-check: where the two disagree
    beyond the Monte Carlo's floor the run says so loudly and decides on the Monte Carlo
    (harness/workflows/truth.py). ``truth=False``: the Monte Carlo alone.

    The averaged models' coefficients are computed once per grid for the whole run and
    shared by the closed forms, the FPKs and the averaged SDEs (door.shared_coefficients).

    Concurrency (issue 44): the models' closed forms and FPKs are solved in a thread beside
    the original system's Monte Carlo, and the averaged SDEs run ``checkruns.SDE_LANES`` at a
    time; every part is a function of the scene (and its model) alone, so the numbers are
    those of the parts run one after another. ``warm``: the caller's own preparation (the
    command line imports the report's drawing), run in a thread while the SDEs' kernels run.
    """
    with shared_coefficients():
        return _cross_check(scene, quiet=quiet, fpk=fpk, sde=sde, tail_mass=tail_mass,
                            models=models, tolerance=tolerance, run=run, truth=truth,
                            warm=warm)


def _cross_check(scene: Any, *, quiet: bool, fpk: bool, sde: bool, tail_mass: bool,
                 models: tuple[str, ...], tolerance: Tolerance | None,
                 run: MonteCarloRun | None, truth: bool,
                 warm: Callable[[], Any] | None) -> CheckResult:
    tol = tolerance if tolerance is not None else Tolerance()
    models, absent = models_of(scene, models)
    solvers = registry.model_solver_names() if fpk else ()
    # closed forms, the original system's Monte Carlo and the metrics; FPK and SDE per model
    stages = Stages(3 + len(models) * (len(solvers) + int(sde)), quiet)
    # the models' closed forms and FPKs (numpy, Python) beside the original system's Monte
    # Carlo (numba, the GIL released), then the averaged SDEs two at a time: nothing flows
    # between them, so each gives the numbers it gives alone; BLAS is held on one thread
    # around them all (the door's limits nest: the outermost is undone last)
    with one_blas_thread():
        sol, closed, mc, extensions, bad, run_scene = _models_and_mc(
            scene, models, solvers, tail_mass, run, quiet, stages)
        st = mc.resolved  # typed: what the run resolved (step, burn-in, sampled time, ...)
        budget = scene.montecarlo.budget or math.inf
        why_no_truth = original_fpk_problem(scene) if truth else "not asked (truth=False)"
        if why_no_truth is None:
            stages.total += 1
            stages("FPK of the original system (the truth without sampling noise)")
            sol["fpk2d:original"] = original_fpk_solution(scene)
        # the caller's own preparation, while the SDEs' kernels run
        warming = Beside(warm, name="vifpk-warm") if warm is not None else None
        runs = sde_runs(scene, models if sde else (), closed, mc_edges_of(mc), st,
                        run_scene.montecarlo.burn_in, budget, stages)
        if warming is not None:  # ended inside the BLAS scope: the door's import watch is
            warming.result()  # taken off sys.meta_path when it ends, never mid-import
    sde_extensions = {}
    for m, (res, ext) in runs.items():
        sol[f"mc:{m}"], sde_extensions[m] = res, ext
    stages("metrics")
    metrics: dict[str, Any] = {"models": {}}
    if absent:
        metrics["models_absent"] = dict(absent)
    for m in models:
        cf = closed[m].data
        entry: dict[str, Any] = {}
        for name in solvers:  # the FPK solvers' numerics, under the key each declares
            if f"{name}:{m}" in sol:
                errors = {o: compare(cf[o], sol[f"{name}:{m}"].data[o]) for o in OBSERVABLES}
                key = getattr(registry.solver(name)[0], "metric", None)
                if key:
                    entry[key] = errors
                else:
                    entry.setdefault("solver_errors", {})[name] = errors
        for kind, key in (("sampling_error", f"mc:{m}"), ("averaging_error", "mc:original")):
            if key in sol:
                entry[kind] = {o: compare(cf[o], sol[key].data[o]) for o in OBSERVABLES}
        # the averaged SDE against its closed form on EVERY observable compared (issue 45)
        failed = sampling_failures(entry.get("sampling_error", {}))
        entry["sampling_ok"] = not failed if "sampling_error" in entry else None
        if failed:
            entry["sampling_failed"] = failed
            entry["sampling_reason"] = sampling_words(m, entry["sampling_error"])
        if m in sde_extensions:
            entry["sampling_extensions"] = sde_extensions[m]
        if not closed[m].info.get("closed_form", True):
            entry["reference"] = closed[m].info["method"]
        metrics["models"][m] = entry
    conv = dict(mc.info.get("convergence", {}))
    conv["extensions"] = extensions
    if bad:
        conv["equilibrated"] = False
        conv["reason"] = "; ".join(bad)
    val = validity(scene)
    warnings = assumption_warnings(scene, closed, mc.info, val)
    outside = mc.info.get("events", {}).get("outside_fraction", {})
    worst = max(outside.values(), default=0.0)
    if worst > 1e-3:
        warnings.append(WarningRecord(
            "outside_range",
            f"the simulation of the original system puts {100 * worst:.1f}% of its "
            "samples outside the range where the averaged models hold their mass "
            "(not converged, or a different state altogether); its densities there "
            "are not shown and count toward L1 as one cell beyond the range"))
    if mc.info.get("dt_check", {}).get("verdict") == "failed":
        warnings.append(WarningRecord("dt_bias", mc.info["dt_check"]["message"]))
    verdicts = [verdict(m, metrics["models"][m], warnings, convergence=conv) for m in models]
    verdicts += [f"{m} model: not checked, {why}" for m, why in absent.items()]
    for m in models:
        cls, cause = verdict_class(metrics["models"][m], warnings, convergence=conv)
        metrics["models"][m]["verdict_class"] = cls
        metrics["models"][m]["verdict_cause"] = cause
        metrics["models"][m]["verdict_by_observable"] = observable_classes(metrics["models"][m])
        # beside the class, never instead of it (issue 45): the assumptions that fail here
        metrics["models"][m]["verdict_assumptions"] = (
            [w.kind for w in assumptions_failing(warnings)] if cls != "not an estimate" else [])
    metrics["tolerance"] = tol.record()
    # the jackknife over the blocks has blocks - 1 degrees of freedom; a step bias the run's
    # check could not rule out is carried by the interval and the class (tolerance.py)
    tverdicts = model_verdicts(metrics, tol, dof=int(scene.montecarlo.blocks) - 1,
                               dt_check=mc.info.get("dt_check"))
    for m, v in tverdicts.items():
        metrics["models"][m]["tolerance"] = v
    metrics["paired"] = paired_table(closed, sol["mc:original"], models, tol)
    fp = sol.get("fpk2d:original")
    metrics["truth"] = truth_metrics(fp, mc, closed, models, why_no_truth)
    if fp is not None:
        for m in models:
            metrics["models"][m]["truth_error"] = metrics["truth"]["models"][m]
        if metrics["truth"]["agrees"]:  # decide on the truth; the MC's decision kept beside
            metrics["paired_mc"] = metrics["paired"]
            metrics["paired"] = paired_table(closed, fp, models, tol,
                                             diff_err=metrics["truth"]["error"])
            for m, v in truth_verdicts(metrics, tol).items():
                metrics["models"][m]["tolerance_mc"] = metrics["models"][m].get("tolerance")
                metrics["models"][m]["tolerance"] = v
                tverdicts[m] = v
        else:
            warnings.append(WarningRecord("truth_disagrees", metrics["truth"]["words"]))
        verdicts.append(metrics["truth"]["line"])
    stages.done()
    rec_model, rec_line = recommend(metrics, warnings, val, convergence=conv)
    if metrics["truth"].get("agrees"):
        rec_line += (f" -- decided against the original system's own FPK (no sampling noise; "
                     f"its discretisation error L1(A) ~{metrics['truth']['error']:.1g}, the "
                     "error bar of every difference above), with which the Monte Carlo agrees")
    metrics["recommended_model"] = rec_model
    metrics["recommendation"] = rec_line
    metrics["validity"] = val
    metrics["verdicts"] = verdicts
    metrics["warnings"] = [w.text for w in warnings]
    metrics["warning_kinds"] = [w.kind for w in warnings]
    metrics["monte_carlo"] = {k: mc.info[k] for k in ("settings", "effects", "events", "L1_floor",
                                                     "seed", "atoms", "relaxation", "dt_rule",
                                                     "dt_check")
                              if k in mc.info}
    metrics["monte_carlo"]["convergence"] = conv
    # everything that depends on the machine's speed lives under "timings" only, so that the
    # rest of metrics.json is a function of (scene, settings, seed) alone (issue 11.5)
    metrics["timings"] = {
        "wall_seconds": time.perf_counter() - stages.start,
        "stages": stages.seconds,
        "steps_per_second": {name: s.info["steps_per_second"] for name, s in sol.items()
                             if "steps_per_second" in s.info},
        "solutions": {name: s.info["seconds"] for name, s in sol.items()
                      if "seconds" in s.info},
        "threads": mc.info.get("threads"),
    }
    metrics["tolerance_verdicts"] = [tolerance_line(m, v) for m, v in tverdicts.items()]
    return CheckResult(scene=scene, solutions=sol, metrics=metrics, warnings=warnings,
                       verdicts=verdicts, recommendation=rec_line, models=models,
                       tolerance_lines=tuple(metrics["tolerance_verdicts"]))


def _models_and_mc(scene: Any, models: tuple[str, ...], solvers: tuple[str, ...],
                   tail_mass: bool, run: MonteCarloRun | None, quiet: bool, stages: Stages
                   ) -> tuple[dict[str, Any], dict[str, Any], Any, int, list[str], Any]:
    """The models' closed forms and FPKs (checkruns.model_solves) in a thread beside the
    original system's Monte Carlo (checkruns.original_mc) in this one. Returns (the solutions
    so far, in the check's order, the closed forms, the Monte Carlo's result, its
    extensions, the certificate's evidence against it, the scene of its last run)."""
    beside = Beside(carried(model_solves), scene, models, solvers, tail_mass, stages,
                    name="vifpk-models")
    try:
        mc, extensions, bad, run_scene = original_mc(scene, run, quiet, stages)
    except Exception:
        beside.wait()  # its failure came first in a check without the overlap
        if beside.failed() is not None:
            raise beside.failed() from None
        raise
    stages.done()  # the Monte Carlo's line; then the lines of what ran beside it
    closed, fpk_solutions = beside.result()
    stages.flush()
    sol: dict[str, Any] = {f"closed:{m}": closed[m] for m in models}
    sol.update(fpk_solutions)
    sol["mc:original"] = mc
    return sol, closed, mc, extensions, bad, run_scene


def paired_table(closed: dict[str, Any], truth: Any, models: tuple[str, ...],
                 tol: Tolerance, *, diff_err: float | None = None) -> dict[str, Any]:
    """Every pair of models compared on the SAME sample (compare.paired): the difference of
    their distances to the truth in the tolerance's metric and observable, with the error bar
    of the difference (the recommendation decides between models by it). ``truth``: a Result
    whose data holds the observable (a Monte Carlo histogram; a smooth, noise-free density
    gives error bars 0, or ``diff_err``: the original system's FPK's discretisation error,
    the most by which it can move a difference of two distances to it, triangle inequality)."""
    o, k = tol.observable, tol.metric
    ref = truth.data[o]
    pairs = []
    for i, a in enumerate(models):
        for b in models[i + 1:]:
            pr = paired(closed[a].data[o], closed[b].data[o], ref, metric=k)
            pairs.append({"a": a, "b": b, "diff": pr["diff"],
                          "diff_err": pr["diff_err"] if diff_err is None else diff_err,
                          "dof": pr["dof"]})
    out = {"observable": o, "metric": k, "pairs": pairs}
    if diff_err is not None:
        out["truth"] = "original-fpk"
    return out


def output_problems(result: CheckResult) -> list[str]:
    """What is wrong with a cross-check's output, in words (empty: nothing): a non-finite or
    negative density; a histogram whose mass (the atom of p(x2) at rest counted) is outside
    [0.99, 1] (its mass is 1 minus the samples outside its edges; the report warns from 0.1%
    outside, this bound is loose: its job is finite and normalised); a smooth density whose
    trapezoid mass is off 1 by more than 1e-9; a non-finite metric. Used by
    tests/test_hard_scenes.py and benchmarks/validate_hard_scenes.py."""
    out = []
    for name, sol in result.solutions.items():
        for obs in ("A", "x1", "x2"):
            d = sol.data[obs]
            p = np.asarray(d["p"])
            if not (np.all(np.isfinite(p)) and np.min(p) >= 0):
                out.append(f"{name} {obs}: density not finite or negative")
                continue
            if "edges" in d:
                mass = float(np.sum(p * np.diff(d["edges"]))) + float(d.get("atom_weight", 0))
                if not 0.99 <= mass <= 1.0 + 1e-9:
                    out.append(f"{name} {obs}: histogram mass {mass:.4f}")
            elif abs(np.trapezoid(p, d["x"]) - 1) > 1e-9:
                out.append(f"{name} {obs}: mass {np.trapezoid(p, d['x']):.12f}")
    for m, entry in result.metrics["models"].items():
        for kind in ("discretisation_error", "sampling_error", "averaging_error"):
            for o, e in entry.get(kind, {}).items():
                if not all(math.isfinite(v) for v in e.values()):
                    out.append(f"{m} {kind} {o}: not finite")
    return out


# ------------------------------------------------------------------ the workflow's record
#: ``vifpk check`` (vifpk.core.protocols.Workflow), registered in pyproject.toml's
#: ``vifpk.workflows``. Its command line (harness/cli), sweep point (harness/sweeps), Python
#: function (vifpk.api) and tolerance test (harness/testing.py) are named by Ref, imported
#: when used: the registry does not depend on the layers above this one.
SPEC = WorkflowSpec(
    "check", "cross-check the averaged models (default: "
    f"{', '.join(CHECK_MODELS)}; outside the paper's family "
    "without paper) against the Monte Carlo of the original "
    "system and write an error report",
    add_arguments=Ref("vifpk.harness.cli.arguments:check_arguments"),
    command=Ref("vifpk.harness.cli.commands:cmd_check"),
    sweep_point=Ref("vifpk.harness.sweeps.points:check_point"), api=Ref("vifpk.api:check"),
    assertion=Ref("vifpk.harness.testing:assert_averaging_error"))
