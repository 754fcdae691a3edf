"""One point of a sweep: its key, seed and fingerprint, its job, and the workflow run at it.
A point is a pure function of (scene, settings, seed): its Monte Carlo seed is

    seed_point = SeedSequence([seed_sweep, *words(sha256(params))]).generate_state(1, uint64) >> 2

(params: the point's varied values, by name, as exact hexadecimal floats): not its position in
the grid nor the executor. ``WORKFLOW_FUNCTIONS`` maps a workflow to its function at one point.
"""

from __future__ import annotations

import hashlib
import json
import math
import numbers
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from vifpk.harness.sweeps.errors import SweepError
from vifpk.harness.workflows.assumptions import ASSUMPTION_KINDS

from vifpk.core import registry
from vifpk.core.defaults import BIFURCATION_MODELS, CHECK_MODELS, TOLERANCE, TOLERANCE_CONFIDENCE
from vifpk.core.protocols import resolved
from vifpk.core.result import BadInput
from vifpk.core.scene import Scene, SceneError

#: warnings of the cross-check as flags: variable name -> the warning's kind (WarningRecord.kind)
WARNING_FLAGS = {f"warn_{kind}": kind for kind in ASSUMPTION_KINDS}


# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, kw_only=True)
class Point:
    """One point: its varied values (in the sweep file's order), seed, key and scene."""

    params: tuple[tuple[str, float], ...]
    seed: int
    key: str
    scene: Scene
    fingerprint: str
    sde: bool = False  # a check point that runs the averaged SDEs' Monte Carlo
    batch: int = 0  # adaptive sweeps: 0 for the initial lattice, then 1, 2, ...

    def label(self) -> str:
        return " ".join(f"{k}={v:g}" for k, v in self.params)


@dataclass(frozen=True, kw_only=True)
class Sweep:
    """A validated sweep file."""

    path: str
    text: str
    name: str
    workflow: str
    mode: str
    seed: int
    vary: tuple[tuple[str, tuple[float, ...]], ...]
    fixed: Mapping[str, Any]
    bifurcation: Mapping[str, Any]
    base: Scene
    points: tuple[Point, ...] = field(repr=False)
    #: mode "adaptive": points, model, batch, resolution ([adaptive]); vary then holds the
    #: ranges as (start, stop), and ``points`` the initial lattice (run_adaptive adds the rest)
    adaptive: Mapping[str, Any] = field(default_factory=dict)
    models: tuple[str, ...] | None = None  # None: the workflow's default models
    #: check: the tolerance verdict's value (harness/workflows/tolerance.py)
    tolerance: float = TOLERANCE
    #: check: the rest of the tolerance question (metric, observable, confidence)
    tolerance_question: tuple[str, str, float] = ("L1", "A", TOLERANCE_CONFIDENCE)
    #: check sweeps whose file gives a tolerance: fit the error surface (sweeps/surface.py)
    surface: bool = False
    #: the file the base scene was read from (None: not a file on disk)
    base_file: str | None = None

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(k for k, _ in self.vary)


def canonical(params: tuple[tuple[str, float], ...]) -> str:
    """The parameters as text, exactly: names sorted, values as hexadecimal floats."""
    return json.dumps(sorted((k, float(v).hex()) for k, v in params))


def point_key(params: tuple[tuple[str, float], ...]) -> str:
    """The record name of a point: 16 hex digits of sha256 of its canonical parameters."""
    return hashlib.sha256(canonical(params).encode()).hexdigest()[:16]


def point_seed(seed: int, params: tuple[tuple[str, float], ...]) -> int:
    """A point's Monte Carlo seed from the sweep's seed and the point's parameters (< 2^62)."""
    import numpy as np

    digest = hashlib.sha256(canonical(params).encode()).digest()
    words = [int.from_bytes(digest[i:i + 4], "little") for i in range(0, 32, 4)]
    state = np.random.SeedSequence([int(seed), *words]).generate_state(1, dtype=np.uint64)
    return int(state[0]) >> 2


def fingerprint(workflow: str, scene: Scene, bifurcation: Mapping[str, Any], *,
                sde: bool = False, models: tuple[str, ...] | None = None,
                tolerance: Any = None) -> str:
    """sha256 of everything a point's result depends on (the scene includes the seed; ``sde``:
    the point runs the averaged SDEs' Monte Carlo, SDE_CHECK_EVERY; the models only when the
    sweep names them, so a sweep without ``models`` keeps its records; the tolerance question
    only when it is not the default one, likewise: a changed tolerance recomputes the points'
    verdicts instead of keeping the old ones)."""
    d = scene.to_dict()
    d.pop("name", None)
    d.pop("description", None)
    what: dict[str, Any] = {"workflow": workflow, "scene": d, "bifurcation": dict(bifurcation)}
    if workflow == "check":
        what["sde_check"] = bool(sde)
    if models is not None:
        what["models"] = list(models)
    if tolerance is not None and workflow == "check":
        from vifpk.harness.request.tolerance import Tolerance

        if tolerance != Tolerance():
            what["tolerance"] = tolerance.record()
    blob = json.dumps(what, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


#: a check sweep runs the Monte Carlo of each averaged SDE against its closed form (a check of
#: the closed forms and the Monte Carlo machinery, not of the averaging error, which is what a
#: map shows) only at sampled points: the sweep's first point and every point whose key,
#: read as a number, is divisible by SDE_CHECK_EVERY (about 1 in 16, chosen by the point's
#: parameters alone, so the choice does not depend on the executor or the order of points)
SDE_CHECK_EVERY = 16


def sde_check_at(key: str, *, first: bool) -> bool:
    """Whether a check point runs the averaged SDEs' Monte Carlo (SDE_CHECK_EVERY)."""
    return first or int(key, 16) % SDE_CHECK_EVERY == 0


def make_point(base: Scene, fixed: Mapping[str, Any], *, seed: int, workflow: str,
               bifurcation: Mapping[str, Any], params: tuple[tuple[str, float], ...],
               first: bool = False, where: str = "sweep",
               models: tuple[str, ...] | None = None, tolerance: Any = None) -> Point:
    """The point of a sweep at ``params`` (varied values by name): its scene (the base scene
    with ``fixed`` and ``params`` set, no wall-clock budget, its own seed), key and
    fingerprint. SweepError (naming the point) when the scene is out of range there."""
    from vifpk.harness.sweeps.timesweep import TIME_PARAMS, point_options

    s = point_seed(seed, params)
    # a budget of 0 means no wall-clock limit (see RESERVED)
    values = {**fixed, "montecarlo.budget": 0.0,
              **{k: v for k, v in params if k not in TIME_PARAMS}, "montecarlo.seed": s}
    table = dict(bifurcation)  # the file's options, before the point's values join them
    def alone() -> str | None:  # the fault without the point's values (None: there is none)
        try:
            sc = base.with_values({**fixed, "montecarlo.budget": 0.0})
            _validate_point(sc, workflow, table, where, ())
        except Exception as exc:  # noqa: BLE001 - any fault of its own (a key missing too)
            return str(exc).split(": ", 1)[-1]
        return None

    try:
        scene = base.with_values(values)
    except SceneError as exc:
        msg = str(exc).split(": ", 1)[-1] if ": " in str(exc) else str(exc)
        raise SweepError(fault(where, msg, params, fixed, workflow, alone)) from None
    if scene.sweep is not None:
        raise SweepError(f"{where}: scene: {scene.sweep.path} varies in the base scene; set "
                         "it in [set] or vary it in [vary]")
    if workflow in ("passage", "transient"):  # the point's own threshold, start
        bifurcation = point_options(bifurcation, params)
    try:
        _validate_point(scene, workflow, bifurcation, where, params)
    except SweepError as exc:
        raise SweepError(fault(where, str(exc), params, fixed, workflow, alone)) from None
    scene = _named(scene, f"{base.name}[{', '.join(f'{k}={v:g}' for k, v in params)}]")
    key = point_key(params)
    sde = workflow == "check" and sde_check_at(key, first=first)
    return Point(params=params, seed=s, key=key, scene=scene, sde=sde,
                 fingerprint=fingerprint(workflow, scene, bifurcation, sde=sde, models=models,
                                         tolerance=tolerance))


def fault(where: str, msg: str, params: tuple[tuple[str, float], ...],
          fixed: Mapping[str, Any], workflow: str, alone: Callable[[], str | None]) -> str:
    """A point's fault named where it was written (issue 45): the time workflow's options by
    their file names ("[transient] start", not "--start"); "at the point ..." unless the scene
    with [set] alone (``alone``: its fault, or None) fails the same way -- then "[set]" when
    the line names a key set there (it read "at the point system.mu = 0"), else nothing."""
    import re

    from vifpk.harness.sweeps.timesweep import KEYS

    keys = KEYS.get(workflow, ())

    def named(text: str) -> str:
        return re.sub(r"--([a-z][a-z-]*)", lambda m: f"[{workflow}] {m.group(1)}"
                      if m.group(1).replace("-", "_") in keys else m.group(0), text)

    msg = named(msg.split(f"{where}: ", 1)[-1])
    if params and not msg.startswith("at the point"):
        same = alone()
        if same is None or named(same) != msg:
            at = ", ".join(f"{k} = {v:g}" for k, v in params)
            return f"{where}: at the point {at}: {msg}"
    if msg.startswith("at the point") or msg.startswith("["):
        return f"{where}: {msg}"
    return f"{where}: [set]: {msg}" if any(k in msg for k in fixed) else f"{where}: {msg}"


def _validate_point(scene: Scene, workflow: str, bifurcation: Mapping[str, Any], where: str,
                    params: tuple[tuple[str, float], ...]) -> None:
    """A point's scene checked as `vifpk check` / `solve` check theirs before any work
    (magnitudes, the law's reach; the Monte Carlo settings where the workflow simulates)."""
    from vifpk.harness.request import validate

    try:
        validate.scene_magnitudes(scene)
        validate.stationary_density(scene)
        if workflow in ("averaging", "check"):
            validate.law_in_reach(scene)
        if workflow in ("passage", "transient"):
            from vifpk.harness.sweeps import timesweep

            timesweep.check_point(workflow, bifurcation, scene)  # the request's checks
        if workflow == "bifurcation" and bifurcation.get("find"):
            from vifpk.harness.workflows.bifurcation import vary_problem

            why = vary_problem(scene, str(bifurcation["find"]))
            if why is not None:  # failed at every point at run time (round 7b, "not tried")
                raise BadInput(why.replace("--vary r", "[bifurcation] find = 'r'").replace(
                    "allowed here: --vary mu", "allowed here: find = 'mu'"))
        if workflow in ("check", "passage", "transient") or (workflow == "bifurcation"
                                                             and bifurcation.get("mc")):
            # with a fixed step the checks depend on [montecarlo] and omega0 only: once each
            mc = scene.montecarlo
            key = (mc, scene.system.restoring_law[0]) if mc.dt != "auto" else None  # k1
            if key is None or key not in _CHECKED:
                validate.montecarlo_settings(scene)
                if key is not None:
                    _CHECKED.add(key)
    except BadInput as exc:  # SceneError, validate.InputError: named by make_point
        raise SweepError(f"{where}: {exc}") from None


def _named(scene: Scene, name: str) -> Scene:
    from dataclasses import replace

    return replace(scene, name=name)


# --------------------------------------------------------------------------------------------
# the point function: runs anywhere (this process, a process pool, a dask worker)
@dataclass(frozen=True, kw_only=True)
class Job:
    """What a worker needs to compute one point (picklable)."""

    key: str
    fingerprint: str
    params: tuple[tuple[str, float], ...]
    seed: int
    workflow: str
    scene: Scene
    bifurcation: Mapping[str, Any]
    sde: bool = True  # check: run the averaged SDEs' Monte Carlo (Point.sde)
    models: tuple[str, ...] | None = None  # None: the workflow's default models
    tolerance: float = TOLERANCE  # check: the tolerance verdict's value
    tolerance_question: tuple[str, str, float] = ("L1", "A", TOLERANCE_CONFIDENCE)
    #: check: keep where the Monte Carlo stopped (the record's "state", checkpoint bytes) and,
    #: with ``state``, continue that run toward the scene's floor (band sweeps, bandrun.py)
    keep_state: bool = False
    state: bytes | None = field(default=None, repr=False)
    stage: int = 0  # band sweeps: 0 for a new point, k for its k-th extension


def run_point(job: Job) -> dict[str, Any]:
    """Compute one point; a failure is returned as a record with status "failed"."""
    t0 = time.perf_counter()
    rec: dict[str, Any] = {"key": job.key, "params": dict(job.params), "seed": job.seed,
                           "fingerprint": job.fingerprint, "workflow": job.workflow}
    if job.keep_state:
        rec["stage"] = job.stage
    try:
        result = sweep_functions()[job.workflow](job)
    except Exception as exc:  # noqa: BLE001 - recorded with its message; the sweep goes on
        from vifpk.harness.door.solvers import SolverFailure

        from vifpk.core.guard import PluginError

        kind = ("numerical" if isinstance(exc, SolverFailure | ArithmeticError | PluginError)
                else "error")
        text = str(exc).splitlines()[0] if str(exc) else ""
        rec.update(status="failed", failure=kind,
                   message=f"{type(exc).__name__}: {text}" if kind == "error" else text)
    else:
        rec.update(status="ok", message="", result=result)
    rec["seconds"] = time.perf_counter() - t0
    return rec


def _models(job: Job, default: tuple[str, ...]) -> tuple[str, ...]:
    return job.models if job.models is not None else default


def _flags(warnings: list[Any]) -> dict[str, bool]:
    kinds = {w.kind for w in warnings}
    return {k: v in kinds for k, v in WARNING_FLAGS.items()}


def check_point(job: Job) -> dict[str, Any]:
    """The cross-check without the FPK: the averaging error of p(A) of each model."""
    import numpy as np
    from vifpk.harness.door.solvers import MonteCarloRun
    from vifpk.harness.request.tolerance import Tolerance
    from vifpk.harness.workflows.check import cross_check

    from vifpk.core.guard import PluginError

    names, failed = list(_models(job, CHECK_MODELS)), {}
    run = MonteCarloRun(keep_state=job.keep_state, resume=job.state if job.keep_state else None)
    while True:  # a plugin that fails is dropped, named, and the check run without it
        try:
            res = cross_check(job.scene, quiet=True, fpk=False, sde=job.sde, tail_mass=False,
                              models=tuple(names),
                              tolerance=Tolerance(value=job.tolerance,
                                                  metric=job.tolerance_question[0],
                                                  observable=job.tolerance_question[1],
                                                  confidence=job.tolerance_question[2]),
                              run=run)
            break
        except PluginError as exc:
            if exc.model not in names or len(names) == 1:
                raise
            failed[exc.model] = str(exc)
            names.remove(exc.model)
    mc = res.solutions["mc:original"]
    conv = res.metrics["monte_carlo"]["convergence"]
    models = {}
    for m in res.metrics["models"]:
        e = res.metrics["models"][m]["averaging_error"]["A"]
        models[m] = {"averaging_error_A": e["L1"], "averaging_error_A_err": e["L1_err"],
                     "L1_floor_A": e["L1_floor"],
                     "mean_A": res.solutions[f"closed:{m}"].info["summary"]["mean"],
                     "verdict_class": str(res.metrics["models"][m].get("verdict_class", ""))}
        tv = res.metrics["models"][m].get("tolerance")
        if tv is not None:  # the tolerance verdict (issue 29): the error, noise removed
            models[m].update(error_estimate=tv["error_estimate"],
                             error_estimate_err=tv["error_estimate_err"],
                             p_within_tolerance=tv["p_within_tolerance"],
                             tolerance_class=tv["class"])
        if job.sde:  # only where the averaged SDE ran (SDE_CHECK_EVERY); -1 elsewhere
            models[m]["sampling_ok"] = bool(res.metrics["models"][m]["sampling_ok"])
    # the simulation's mean amplitude from its histogram of A with an exactly rounded sum, its
    # batch error from the moments (accumulated per path and summed in path order: the same
    # bits for any thread count and executor, tests/test_sweep.py)
    d = mc.data["A"]
    mean = {"value": math.fsum((d["x"] * d["p"] * np.diff(d["edges"])).tolist()),
            "err": float(mc.info["moments"]["A"]["mean"]["err"])}
    converged = conv.get("equilibrated") is not False and all(
        v.get("sampling_ok", True) for v in models.values())
    models.update({m: {"failure": t} for m, t in failed.items()})
    return {"models": models, "mean_A_simulation": mean["value"],
            "mean_A_simulation_err": mean["err"], "converged": converged,
            "extensions": conv.get("extensions", 0),
            "flags": {**_flags(res.warnings), "warn_not_converged": not converged},
            "recommended_model": res.metrics["recommended_model"],
            "warnings": [w.text for w in res.warnings], "verdicts": res.verdicts,
            **_mc_cost(mc.info), **({"state": run.state} if run.keep_state else {})}


def _mc_cost(info: Mapping[str, Any]) -> dict[str, float]:
    """The Monte Carlo's path-steps: all of its run so far (burn-in and sampled windows, pilots
    not counted), those of this call (less than all for a continued run), and the sampled
    windows' (what doubling the sample would cost)."""
    st = info["settings"]
    return {"mc_path_steps": float(info["steps"]),
            "mc_path_steps_run": float(info.get("steps_this_run", info["steps"])),
            "mc_sampled_steps": float(round(st["time"] / st["dt"]) * st["paths"])}


def averaging_point(job: Job) -> dict[str, Any]:
    """Closed forms of each model (computed once), the L1 between them, the assumption
    warnings that need no simulation (strong damping, narrow band, strong noise)."""
    from vifpk.harness.door.solvers import run_solver
    from vifpk.harness.request.validate import finite_result
    from vifpk.harness.workflows.assumptions import assumption_warnings
    from vifpk.harness.workflows.check import models_of
    from vifpk.harness.workflows.compare import compare

    from vifpk.core.guard import PluginError

    closed, failed = {}, {}
    for m in models_of(job.scene, _models(job, CHECK_MODELS))[0]:
        try:
            closed[m] = run_solver(job.scene, "averaging", model=m)
        except PluginError as exc:  # the plugin's failure; the other models' numbers stay
            failed[m] = str(exc)
    if not closed and failed:
        raise PluginError(next(iter(failed.values())))
    for r in closed.values():  # a point is "ok" only with finite numbers, as `solve` exits 3
        finite_result(r, job.scene)
    warnings = assumption_warnings(job.scene, closed, {})
    flags = _flags(warnings)
    flags.pop("warn_sticking")  # needs the simulation
    out: dict[str, Any] = {"models": {**{m: {"mean_A": r.info["summary"]["mean"]}
                                         for m, r in closed.items()},
                                      **{m: {"failure": t} for m, t in failed.items()}},
                           "flags": flags, "warnings": [w.text for w in warnings]}
    if "paper" in closed and "exact" in closed:
        out["L1_paper_exact_A"] = compare(closed["paper"].data["A"],
                                          closed["exact"].data["A"])["L1"]
    return out


def bifurcation_point(job: Job) -> dict[str, Any]:
    """Critical mu or r of each model at this point, with the Monte Carlo checks."""
    from vifpk.harness.workflows.bifurcation import bifurcation

    b = job.bifurcation
    lo, hi = b["range"] if b.get("range") else (None, None)
    res = bifurcation(job.scene, b["find"], lo=lo, hi=hi, mc=b["mc"],
                      models=_models(job, BIFURCATION_MODELS))
    checks = [{"value": c["value"], "crater": c["monte_carlo"]["shape"] == "crater",
               "agrees": c["agrees"]} for c in res.get("mc_check", [])]
    return {"models": {m: {"critical": c} for m, c in res["critical"].items()},
            "range": res["range"], "mc_check": checks}


def passage_point(job: Job) -> dict[str, Any]:
    from vifpk.harness.sweeps import timesweep

    return timesweep.passage_point(job)


def transient_point(job: Job) -> dict[str, Any]:
    from vifpk.harness.sweeps import timesweep

    return timesweep.transient_point(job)


_CHECKED: set[Any] = set()  # Monte Carlo settings already validated in this process


#: workflow name -> the function run at one point: every registered workflow with a
#: ``sweep_point`` (vifpk.core.registry.workflows), filled on first use by sweep_functions()
WORKFLOW_FUNCTIONS: dict[str, Callable[[Job], dict[str, Any]]] = {}


def sweep_functions() -> dict[str, Callable[[Job], dict[str, Any]]]:
    """The sweepable workflows (module comment above), in registration order."""
    if not WORKFLOW_FUNCTIONS:
        for w in registry.workflows():
            if w.sweep_point is None:
                continue
            entry = registry.workflow_entry(w.name)
            fn = resolved(w.sweep_point)
            WORKFLOW_FUNCTIONS[w.name] = (fn if entry is None or entry.builtin else
                                          _checked_point(fn, entry))
    return WORKFLOW_FUNCTIONS


def _checked_point(fn: Callable[[Job], Any], entry: Any) -> Callable[[Job], dict[str, Any]]:
    """Another distribution's ``sweep_point``, its record checked (issue 39, W13/W14): a dict
    of text keys whose values are text, booleans, None, finite numbers, or lists and dicts of
    them; anything else (a list, a NaN) is a PluginError naming the plugin, so the point is
    recorded failed and the sweep exits 3. What it raises is named the same way."""
    from vifpk.core.guard import PluginError, describe, source_of

    label = f"workflow {entry.name!r} ({entry.value}, from {entry.distribution})"
    source = source_of(entry.value.partition(":")[0])

    def bad(value: Any) -> bool:
        if isinstance(value, dict):
            return any(not isinstance(k, str) or bad(v) for k, v in value.items())
        if isinstance(value, list | tuple):
            return any(bad(v) for v in value)
        if value is None or isinstance(value, str | bool):
            return False
        return not (isinstance(value, numbers.Real) and math.isfinite(value))

    def run(job: Job) -> dict[str, Any]:
        try:
            out = fn(job)
        except (KeyboardInterrupt, GeneratorExit, BadInput, PluginError):
            raise
        except BaseException as exc:  # noqa: BLE001 - the plugin's, named as such
            raise PluginError(f"{label}: its sweep_point {describe(exc, source)}") from exc
        if not isinstance(out, dict):
            raise PluginError(f"{label}: its sweep_point returned {type(out).__name__}; it "
                              "must return a dict (the point's record)")
        for k, v in out.items():
            if not isinstance(k, str) or bad(v):
                raise PluginError(f"{label}: its sweep_point returned {k!s} = {v!r}; a "
                                  "record holds text keys and text, booleans or finite "
                                  "numbers (or lists and dicts of them)")
        return out

    return run
