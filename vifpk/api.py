"""The public Python API's functions (docs/api.md); ``import vifpk`` exposes them lazily.

Each takes a scene as a :class:`~vifpk.core.scene.Scene`, a path to a scene file or the name of
a shipped scene, and does what the command of the same name does, without the command line:
no cost guard, no output unless asked.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from vifpk.core.scene import Scene, load_scene


def run(workflow: str, /, *args: Any, **kwargs: Any) -> Any:
    """The registered workflow ``workflow``'s Python function (its ``api``,
    vifpk.core.protocols.Workflow) called with the arguments: ``vifpk.run("check", scene,
    models=("exact",))`` is ``vifpk.check(scene, models=("exact",))``, and a plugin's workflow
    is run the same way. An unknown name, or a workflow without a Python function, is refused
    in one line (BadInput) naming those that have one."""
    from vifpk.core.registry import workflows
    from vifpk.harness.request.errors import InputError

    have = {w.name: w.api for w in workflows() if getattr(w, "api", None) is not None}
    if not isinstance(workflow, str) or workflow not in have:
        raise InputError(f"workflow {workflow!r}: no such workflow with a Python function; "
                         f"allowed: {', '.join(have)}")
    return have[workflow](*args, **kwargs)


def scene(source: Scene | str | Path, **values: Any) -> Scene:
    """A scene from a Scene, a file or a shipped scene's name, with ``values`` set by their
    dotted names (``scene("paper-base", **{"noise.D": 0.02})``); validated like a file."""
    if not isinstance(source, Scene | str | Path):
        from vifpk.harness.request.validate import InputError

        raise InputError(f"scene {source!r}: not a scene; give a Scene, a scene file's path or "
                         "the name of a shipped scene")
    sc = source if isinstance(source, Scene) else load_scene(source)
    return sc.with_values(values) if values else sc


def solve(source: Scene | str | Path, solver: str = "averaging", *, model: str | None = None,
          grid: int | None = None, joint: bool = False, progress: bool = False,
          **options: Any) -> Any:
    """One solver on one scene (``vifpk solve``): ``Result(data, info)``.

    ``solver``: "averaging" (the model's closed form, or the FPK direct solve of a model with
    none), "fpk" (``grid`` cells), "montecarlo" (the original system; ``model`` and
    ``grid`` do not apply) or "original-fpk" (the original system's own FPK in (x, v), white
    noise; ``grid``: cells per axis, default from the accuracy; docs/fpk2d.md). ``model``: a
    registered name (:func:`model_names`; default: the first of the check models that
    applies, ``paper`` in the paper's family, else ``exact``).
    ``options``: the Monte Carlo options by the names of the command's flags (``paths``,
    ``dt``, ``time``, ``seed``, ``floor``, ``budget``; montecarlo only) and ``set``, a list of
    ``"section.key=value"`` overrides. Input is checked as the command line checks it, with
    the same one-line messages (:class:`~vifpk.core.result.BadInput`), before any work; no
    cost guard."""
    from vifpk.harness.door.solvers import run_solver
    from vifpk.harness.request.prepare import prepare_solve

    overrides = _overrides(options)
    req = prepare_solve(source, solver=solver, model=model, grid=grid, joint=joint,
                        overrides=overrides, **options)
    if solver == "montecarlo":
        from vifpk.harness.request import cost

        cost.refuse_oversized(req.scene)  # memory is a hard limit; time is the caller's
        return run_solver(req.scene, "montecarlo", progress=progress)
    return run_solver(req.scene, solver, model=req.model, grid=req.grid)


def check(source: Scene | str | Path, *, models: tuple[str, ...] | None = None,
          out: str | Path | None = None, quiet: bool = True, tolerance: float | None = None,
          tolerance_metric: str = "L1", tolerance_observable: str = "A",
          confidence: float | None = None, **options: Any) -> Any:
    """The cross-check (``vifpk check``): a ``CheckResult`` with ``metrics``, ``verdicts``,
    ``warnings``; with ``out``, the report folder is written there as well (checked before
    any work, as ``--out`` is). ``models``: registered names (default: the check models that
    apply to the scene; a named model that does not apply is refused). ``tolerance`` (default
    0.02), ``tolerance_metric``, ``tolerance_observable``, ``confidence``: the tolerance verdict
    and the recommendation that follows it (``vifpk check --tolerance``). ``options``: the
    Monte Carlo options by flag name and ``set``, as for :func:`solve`."""
    from vifpk.harness.request import cost, validate
    from vifpk.harness.request.prepare import prepare_check
    from vifpk.harness.workflows.check import cross_check

    if out is not None:
        if not isinstance(out, str | Path):
            raise validate.InputError(f"out {out!r}: not a folder path")
        validate.output_folder(str(out), "out", replaced=True)
    req = prepare_check(source, models=models, overrides=_overrides(options),
                        tolerance=tolerance, tolerance_metric=tolerance_metric,
                        tolerance_observable=tolerance_observable, confidence=confidence,
                        **options)
    cost.refuse_oversized(req.scene)  # memory is a hard limit; time is the caller's
    res = cross_check(req.scene, quiet=quiet, models=req.models, tolerance=req.tolerance)
    if out is not None:
        from vifpk.harness.outputs.report import write_report

        write_report(res, out)
    return res


def _overrides(options: dict[str, Any]) -> tuple[str, ...]:
    """``set=[...]`` taken out of ``options``: "section.key=value" texts, as ``--set``."""
    from vifpk.harness.request import validate

    given = options.pop("set", ())
    if isinstance(given, str) or not all(isinstance(o, str) for o in given):
        raise validate.InputError(f"set {given!r}: give a list of 'section.key=value' texts")
    return tuple(given)


def sweep(path: str | Path, out: str | Path, *, executor: str = "serial",
          quiet: bool = True) -> Any:
    """A sweep file run into the folder ``out`` (``vifpk sweep``): a ``SweepRun`` naming the
    points computed, skipped and failed and the files written (sweep.nc, maps)."""
    from vifpk.harness.request.errors import InputError
    from vifpk.harness.sweeps.executors import parse_executor, require_output_libraries
    from vifpk.harness.sweeps.runs import run_sweep
    from vifpk.harness.sweeps.spec import load_sweep

    for name, value in (("path", path), ("out", out)):
        if not isinstance(value, str | Path):
            raise InputError(f"{name} {value!r}: not a path; give a sweep file's path (or a "
                             "shipped sweep's name) and an output folder")
    sw = load_sweep(path)
    require_output_libraries()
    return run_sweep(sw, out, executor=parse_executor(executor), quiet=quiet)



TIME_OPTIONS = ("paths", "dt", "seed")  # the Monte Carlo options of passage and transient


def _time_scene(source: Any, options: dict[str, Any], what: str) -> Any:
    """The concrete scene: ``set`` overrides and the Monte Carlo options by flag name applied
    and checked as the command checks them."""
    from vifpk.harness.request import validate
    from vifpk.harness.request.prepare import concrete, with_mc_options

    overrides = _overrides(options)
    unknown = sorted(set(options) - set(TIME_OPTIONS))
    if unknown:
        raise validate.InputError(f"{unknown[0]}: not an option of {what}; allowed: "
                                  f"{', '.join(TIME_OPTIONS)}, set")
    if options.get("dt") == "auto":
        raise validate.InputError(f"dt 'auto': does not apply to {what}; give a number")
    return with_mc_options(concrete(source, overrides), options, mc=True)


def passage(source: Scene | str | Path, *, threshold: float, start: float | str = "stationary",
            models: Any = None, horizon: float | None = None, sde: bool = True,
            at: Any = None, method: str = "direct", particles: int | None = None,
            groups: int | None = None, rel_se: float | None = None,
            max_paths: int | None = None, out: str | Path | None = None, quiet: bool = True,
            yes: bool = False, **options: Any) -> Any:
    """First passage out of A < ``threshold`` (``vifpk passage``): a ``PassageResult`` with
    ``metrics`` (metrics.json's: ``mfpt``, ``models``, ``R``, ``plan``, ``at``, ...),
    ``verdicts``, ``recommendation``, ``warnings``; with ``out``, the report folder is written
    there (checked before any work, as ``--out`` is). ``models``: registered names or objects
    with the averaged-model protocol (default: the check models that apply). ``at``: a
    mission time T or a list of them (``--at``). ``method``: "direct" (default) or
    "splitting" (the MFPT only, at thresholds direct simulation cannot reach: a
    ``SplittingResult`` with ``metrics``, ``verdicts``, ``recommendation``; ``particles`` and
    ``groups`` its settings; ``horizon``, ``paths`` and ``at`` do not apply). ``options``:
    ``paths``, ``dt``, ``seed`` and ``set``, as the command's flags. ``rel_se``, ``max_paths``:
    the target relative standard error of the original system's MFPT and the paths cap
    (``--rel-se``, ``--max-paths``; not with ``paths``). The inputs are checked as
    the command checks them, by the same request (harness/request/timedomain.py: BadInput,
    one line). A direct run is priced as the command prices it, from the models' MFPTs
    before any R(t) stepping or Monte Carlo: one estimated above an hour is BadInput naming
    method="splitting" unless ``yes=True`` (issue 39, X12: threshold 2.0 ran silently for
    minutes). ``method="auto"`` chooses as ``vifpk passage`` does by default: direct where
    that price is within the hour (or ``yes=True``), else splitting, the reason said in the
    result's ``reason``."""
    from vifpk.harness.request.timedomain import output, passage_request, with_quadratures

    out = output(out)
    req = passage_request(_time_scene(source, options, "passage"), threshold=threshold,
                          start=start, models=models, horizon=horizon,
                          paths=options.get("paths"), sde=sde, method=method, at=at,
                          particles=particles, groups=groups, rel_se=rel_se,
                          max_paths=max_paths)
    req = with_quadratures(req)
    reason = "asked for: method='splitting'"
    if req.method == "auto" and not yes:  # the command's default choice (cli/timedomain.py)
        from vifpk.harness.request.errors import InputError
        from vifpk.harness.workflows.pricing import refuse_costly_direct

        try:
            refuse_costly_direct(req, override="method='splitting'")
        except InputError as exc:
            reason = f"chosen automatically: {exc}"
            req = replace(req, method="splitting")
    if req.method == "splitting":
        from vifpk.harness.workflows import rarepassage

        res = rarepassage.run(req, reason=reason, quiet=quiet)
        if out is not None:
            from vifpk.harness.outputs.splitreport import write_splitting_report

            write_splitting_report(res, out)
        return res
    from vifpk.harness.workflows.passage import run

    if not yes:
        from vifpk.harness.workflows.pricing import refuse_costly_direct

        refuse_costly_direct(req, override="or yes=True to run it anyway")
    res = run(req, quiet=quiet)
    if out is not None:
        from vifpk.harness.outputs.timereport import write_time_report

        write_time_report(res, out)
    return res


def transient(source: Scene | str | Path, *, start: float, times: Any, models: Any = None,
              sde: bool = True, rel_se: float | None = None, max_paths: int | None = None,
              out: str | Path | None = None, quiet: bool = True, **options: Any) -> Any:
    """The law of the amplitude at ``times`` from a start at amplitude ``start`` (``vifpk
    transient``): a ``TransientResult`` with ``metrics`` (per-snapshot L1 and KS with error
    bars and floors, ``relaxation``), ``verdicts``, ``warnings``; with ``out``, the report.
    ``models`` and ``options`` as for :func:`passage`; at least three ``times``; ``rel_se``,
    ``max_paths``: the relaxation time's target and the paths cap (``--rel-se``)."""
    from vifpk.harness.request.timedomain import output, transient_request
    from vifpk.harness.workflows.transient import run

    out = output(out)
    req = transient_request(_time_scene(source, options, "transient"), start=start,
                            times=times, models=models, paths=options.get("paths"), sde=sde,
                            rel_se=rel_se, max_paths=max_paths)
    res = run(req, quiet=quiet)
    if out is not None:
        from vifpk.harness.outputs.timereport import write_time_report

        write_time_report(res, out)
    return res
