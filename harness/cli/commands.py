"""The stationary commands: ``solve``, ``check``, ``bifurcation``, ``figures``,
``workprecision``, ``sweep`` and ``models``. Each checks its input (request layer), prices the
run, runs it through the workflows and writes its outputs as units; exit codes are ``app``'s.
"""

from __future__ import annotations

import argparse
import builtins
import functools
import gc
import sys
from typing import Any

from vifpk.harness.cli.options import (
    EXIT_SOLVER,
    _checked_scene,
    _mc_given,
    _mc_options,
    _provenance,
    _summary,
)
from vifpk.harness.door.solvers import SolverFailure, run_solver, solution_record
from vifpk.harness.request import cost, validate
from vifpk.harness.request import prepare as request

from vifpk.core import registry
from vifpk.core.defaults import BIFURCATION_MODELS, CHECK_MODELS
from vifpk.core.scene import Scene, load_scene, no_noise


def cmd_solve(args: argparse.Namespace) -> int:
    from vifpk.core.provenance import process_clock

    startup = process_clock()  # the interpreter and the imports (the run's timing record)
    if args.joint and not args.json:
        validate.refuse_options(["joint"], "without --json (the summary has no joint density)")
    validate.output_file(args.json, "--json")
    validate.outputs_apart_from_inputs(args, replaced=False)
    req = request.prepare_solve(args.scene, solver=args.solver, model=args.model,
                                grid=args.grid, joint=args.joint, overrides=args.set,
                                allow_unequilibrated=args.allow_unequilibrated,
                                **_mc_options(args))
    scene, model = req.scene, req.model
    cost.refuse_costly(lambda sp: cost.solve_seconds(scene, args.solver, model,
                                                             args.grid, speed=sp),
                           "this solve", args.yes)
    if args.solver == "montecarlo":
        cost.refuse_oversized(scene)
    ready = process_clock()
    if args.solver == "montecarlo":
        # priced again once the relaxation pilot has measured an automatic burn-in
        with cost.guarded_run(scene, args.yes) as run:
            result = run_solver(scene, "montecarlo", run=run)
    else:
        result = run_solver(scene, args.solver, model=model, grid=args.grid)
    ran = process_clock()
    timing = result.info.setdefault("timing", {})
    run = timing.get("total", {"wall": 0.0, "cpu": 0.0})  # the solver's own stages' sum
    timing.update(  # this process's stages around the solver's (montecarlo/timing.py)
        startup=startup, request=_since(startup, ready),
        door={k: ran[k] - ready[k] - run[k] for k in ran})
    _finite_or_fail(result, scene)
    conv = result.info.get("convergence", {}) if args.solver == "montecarlo" else {}
    stuck = _not_equilibrated(conv) if not args.allow_unequilibrated else ""
    if args.json:
        model = None if args.solver in (registry.ORIGINAL, registry.ORIGINAL_FPK) else model
        record = solution_record(scene, args.solver, model, result, joint=args.joint,
                                 provenance=_provenance(args))
        done = process_clock()
        timing.update(record=_since(ran, done), process=done)  # the record shares ``timing``
        json_out(args.json, record)
        if not stuck and args.json != validate.STDOUT:
            print(f"wrote {args.json}", file=sys.stderr)
    else:
        print(_summary(result))
    if stuck:  # one line, exit 3; the output is written, its certificate inside
        kept = f"{args.json} was written" if args.json else "the summary above was printed"
        print(f"vifpk: the simulation is NOT equilibrated: {stuck}; {kept} with its "
              "certificate; --allow-unequilibrated accepts it (exit 0)", file=sys.stderr)
        return EXIT_SOLVER
    for warning in result.info.get("warnings", ()):  # e.g. a failed check of dt "auto"
        print(f"vifpk: warning: {warning}", file=sys.stderr)
    if conv.get("equilibrated") is False:  # said on the terminal, not only inside the JSON
        print(f"vifpk: warning: the simulation is NOT equilibrated ({conv.get('reason', '')}); "
              "its densities are not yet the stationary ones: raise --time or --paths, or give "
              "--floor", file=sys.stderr)
    return 0 if result.info["status"]["ok"] else EXIT_SOLVER


def _since(a: dict[str, float], b: dict[str, float]) -> dict[str, float]:
    """{"wall", "cpu"} seconds from process clock ``a`` to ``b`` (provenance.process_clock)."""
    return {k: b[k] - a[k] for k in a}


def _not_equilibrated(conv: dict[str, Any]) -> str:
    """'' unless the equilibration certificate's R-hat or drift failed (the densities still
    carry the start: montecarlo/certificate.py), else those diagnostics and the remedy in
    words. A too small effective sample size alone is not one: the error bars say it."""
    failed = conv.get("failed") or ()
    said = []
    if "rhat" in failed:
        said.append(f"R-hat across starting amplitudes {conv['rhat']:.3f} > "
                    f"{conv['rhat_limit']:.3f} (the paths still remember where they started)")
    if "drift" in failed:
        said.append(f"the mean amplitude drifts by {conv['drift_z']:+.1f} standard errors "
                    f"(limit {conv['drift_limit']:g}) over the sampled time")
    if not said:
        return ""
    return (" and ".join(said) + f" after a burn-in of {conv.get('burn_in', 0):g}: give a "
            "longer burn-in (--set montecarlo.burn_in=T, or auto: from the measured relaxation"
            " time) or a longer --time")


def _finite_or_fail(result: Any, scene: Scene) -> None:
    """Never exit 0 with NaN (validate.finite_result)."""
    validate.finite_result(result, scene)


def _mc_overrides(args: argparse.Namespace) -> dict[str, Any]:
    """{"montecarlo.<key>": value} for the --paths, --dt, --time, --seed, --floor, --budget
    given, each checked against its field's range (request.mc_values)."""
    return request.mc_values(_mc_options(args))


def cmd_check(args: argparse.Namespace) -> int:
    from vifpk.harness.outputs import outdir
    from vifpk.harness.outputs.report import REPORT_FILES, write_report
    from vifpk.harness.outputs.report_figures import prepare as prepare_figures
    from vifpk.harness.workflows.check import cross_check

    from vifpk.core.provenance import folder_name

    validate.output_folder(args.out, "--out", replaced=True)
    validate.outputs_apart_from_inputs(args, replaced=True)
    req = request.prepare_check(args.scene, models=args.model, overrides=args.set,
                                tolerance=args.tolerance,
                                tolerance_metric=args.tolerance_metric,
                                tolerance_observable=args.tolerance_observable,
                                confidence=args.confidence, **_mc_options(args))
    scene, models, tol = req.scene, req.models, req.tolerance
    out = args.out or f"out/{folder_name(scene.name)}"
    if args.out is None:
        validate.output_folder(out, "--out (default)", replaced=True)
    cost.refuse_costly(lambda sp: cost.check_seconds(scene, models, speed=sp),
                           "this check", args.yes)
    cost.refuse_oversized(scene)
    prov = _provenance(args)
    # what the imports made (numba's, numpy's, scipy's ~10^5 objects) is kept out of the
    # collector's full passes during the run (they are module state, never garbage): those
    # passes were ~0.3 s of a warm check of paper-base (gc.callbacks, issue 44)
    gc.freeze()
    # hold the folder from the start: a second run into it is refused before any work
    with outdir.hold(out, run_id=prov["run_id"], allowed=REPORT_FILES, kind="check report"):
        with cost.guarded_run(scene, args.yes) as run:
            result = cross_check(scene, quiet=args.quiet, models=models, tolerance=tol,
                                 run=run, warm=prepare_figures)
        gc.freeze()  # and what the run made and keeps (matplotlib's modules among them)
        files = write_report(result, out, prov=prov, runtime_warnings=_recorded(args))
    for v in result.verdicts:
        print(v)
    for v in result.tolerance_lines:
        print(v)
    print(result.recommendation)
    for w in result.warnings:
        print(f"warning: {w}")
    print(f"report: {files['report.html']}")
    return 0


def cmd_bifurcation(args: argparse.Namespace) -> int:
    from vifpk.harness.workflows.bifurcation import VARIABLES, bifurcation, vary_problem


    if args.no_mc:
        validate.refuse_options(_mc_given(args), "with --no-mc (no Monte Carlo is run)")
    validate.output_file(args.json, "--json")
    validate.outputs_apart_from_inputs(args, replaced=False)
    section, key, (d_lo, d_hi) = VARIABLES[args.vary]
    for text in args.set:
        if text.partition("=")[0].strip() == f"{section}.{key}":
            raise validate.InputError(f"--set {text}: {section}.{key} is the parameter "
                                      f"--vary {args.vary} searches; give its interval with "
                                      "--range LO HI instead")
    scene = _checked_scene(args, mc=not args.no_mc)
    if vary_problem(scene, args.vary) is not None:
        raise validate.InputError(vary_problem(scene, args.vary))
    if no_noise(scene.system):
        raise SolverFailure(f"{no_noise(scene.system)}, at any "
                            f"{args.vary}; nothing to search")
    lo, hi = args.range if args.range else (None, None)
    validate.search_range(args.vary, d_lo if lo is None else lo, d_hi if hi is None else hi,
                          validate.fields_of(section)[key])
    outside = scene.system.paper_family_problem()
    if outside is not None and "paper" in (args.model or ()):
        raise validate.InputError(f"--model paper: {outside}; allowed here: --model exact "
                                  "or --model corrected")
    default_models = (BIFURCATION_MODELS if outside is None
                      else tuple(m for m in BIFURCATION_MODELS if m != "paper"))
    if not args.no_mc:
        # two Monte Carlo checks around each model's critical value (check_points)
        points = 2 * len(set(args.model or default_models))
        cost.refuse_oversized(scene)
        cost.refuse_costly(lambda sp: points * cost.montecarlo_seconds(scene, speed=sp),
                               "this bifurcation "
                               f"search (Monte Carlo at up to {points} points)", args.yes)
    if not args.quiet:
        print(f"searching the critical {args.vary} (shape criterion on each averaged model)"
              + ("; then Monte Carlo on both sides" if not args.no_mc else "") + " ...",
              file=sys.stderr, flush=True)
    chosen = {"models": tuple(dict.fromkeys(args.model or default_models))}
    res = bifurcation(scene, args.vary, lo=lo, hi=hi, mc=not args.no_mc, **chosen)
    if args.json == validate.STDOUT:  # the standard output holds the JSON alone
        return _bifurcation_lines(args, res, file=sys.stderr)
    return _bifurcation_lines(args, res, file=sys.stdout)


def _bifurcation_lines(args: argparse.Namespace, res: dict[str, Any], *, file: Any) -> int:
    """The bifurcation's summary lines (to ``file``), then --json."""
    print = functools.partial(builtins.print, file=file)  # noqa: A001
    fixed = ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}"
                      for k, v in res["fixed"].items())
    print(f"varying {args.vary} with {fixed}")
    for m, c in res["critical"].items():
        lo_hi = res["range"]
        where = f"{c:.6g}" if c is not None else (
            f"none in {lo_hi[0]:g} to {lo_hi[1]:g}" if isinstance(lo_hi, list | tuple)
            and len(lo_hi) == 2 else f"none in {lo_hi}")
        print(f"{m} model: critical {args.vary} = {where}")
    for chk in res.get("mc_check", []):
        said = ", ".join(f"{k} a {v}" for k, v in chk["predicted"].items()) \
            if isinstance(chk["predicted"], dict) else str(chk["predicted"])
        print(f"  {args.vary} = {chk['value']:.5g}: models predict {said}; "
              f"original system (MC): {chk['monte_carlo']['shape']} "
              f"(largest rise of log p(y, y') {chk['monte_carlo']['max_rise_in_se']:.1f} s.e.)"
              f" -- {chk['words']}")
    if res.get("mc_disagreement"):
        print(f"FLAG: {res['mc_disagreement']}")
    if res.get("paper_claim"):  # None outside the paper's system
        print(f"paper claims: {res['paper_claim']}")
    if res.get("paper_claim_note") and res.get("paper_claim"):
        print(f"  NOTE: {res['paper_claim_note']}")
    if args.json:
        json_out(args.json, dict(res, provenance=_provenance(args)))
    return 0


def json_out(path: str, obj: Any) -> None:
    """--json OUT: the file written as a unit, or with "-" the standard output (issue 45: it
    wrote a file named "-"); the summary lines then go to the standard error."""
    from vifpk.core.io import dumps, write_json

    if path == validate.STDOUT:
        sys.stdout.write(dumps(obj))
        sys.stdout.flush()
    else:
        write_json(path, obj)


def cmd_figures(args: argparse.Namespace) -> int:
    from vifpk.harness.outputs import outdir
    from vifpk.harness.workflows.figures import FIGURES, draw_figures, render_table

    validate.output_folder(args.out, "--out")
    overrides = _mc_overrides(args)
    options = {k: f"--{k}" for k in _mc_given(args)}

    def checked(*sweeps: Any) -> None:
        """Every scene the figures will simulate (``--set`` applied), checked and priced
        before any work."""
        scenes = [scene for sweep in sweeps
                  for scene in (sweep.with_values(overrides) if overrides else sweep).variants()]
        for scene in scenes:
            validate.scene_magnitudes(scene)
            validate.stationary_density(scene)
            validate.montecarlo_settings(scene, options)
            cost.refuse_oversized(scene)
        cost.refuse_costly(lambda sp: sum(cost.montecarlo_seconds(sc, speed=sp)
                                              for sc in scenes), "these figures", args.yes)

    if args.scene is not None:  # your own scene: its PDFs and joint density, any system
        from vifpk.harness.workflows.figures import as_sweep, draw_scene_figures

        if args.figure:
            validate.refuse_options(["figure"], "with --scene (the paper's figures are "
                                    "drawn from their own scenes)")
        base = load_scene(args.scene)
        checked(as_sweep(base))
        own = base.with_values(overrides) if overrides else base
        prov = _provenance(args)
        with outdir.hold(args.out, run_id=prov["run_id"]):
            table = draw_scene_figures(args.out, own, quiet=args.quiet, prov=prov)
        print(render_table(table), end="")
        print(f"figures: {args.out}/{own.name}-joint.png, {args.out}/{own.name}-pdfs.png")
        return 0
    checked(*(load_scene(FIGURES[no])  # shipped scenes, as draw_figures loads them
              for no in args.figure or tuple(FIGURES)))
    prov = _provenance(args)
    # figures are replaced one by one (--figure redraws some of them), each atomically; the
    # lock keeps two runs from interleaving in one folder
    with outdir.hold(args.out, run_id=prov["run_id"]):
        table = draw_figures(args.out, numbers=tuple(args.figure or FIGURES),
                             overrides=overrides, quiet=args.quiet, prov=prov)
    print(render_table(table), end="")
    print(f"figures: {args.out}/paper-fig*.png")
    return 0


def cmd_workprecision(args: argparse.Namespace) -> int:
    from pathlib import Path

    from vifpk.harness.outputs import outdir
    from vifpk.harness.workflows.workprecision import (
        log_stderr,
        plot,
        run_workprecision,
        table_markdown,
    )

    from vifpk.core.io import dumps
    from vifpk.core.provenance import folder_name

    validate.refuse_options([k for k in ("paths", "time", "floor", "budget")
                             if getattr(args, k) is not None],
                            "to workprecision (its ladders set the paths and the time)")
    if args.dt == "auto":
        raise validate.InputError("--dt auto: does not apply to workprecision (it times a "
                                  "ladder of fixed steps); give a number")
    # each repeat times every run of the ladder again: 100 is past any useful minimum of times
    validate.at_least("--repeats", args.repeats, 1, 100)
    validate.output_folder(args.out, "--out", replaced=True)
    validate.outputs_apart_from_inputs(args, replaced=True)
    scene = _checked_scene(args, mc=True)
    outside = scene.system.paper_family_problem()
    if outside is not None:  # its ladders time the paper model's closed form and FPK
        raise validate.InputError(f"{args.scene}: workprecision times the paper model's "
                                  f"solvers, which do not apply here: {outside}")
    if scene.montecarlo.dt == "auto":
        if "montecarlo.dt" in scene.given:
            raise validate.InputError("montecarlo.dt = 'auto': workprecision times a ladder "
                                      "of fixed steps; give a number with --dt")
        from dataclasses import replace

        from vifpk.core.sections import FIXED_DT

        # the scene gave no step: the fixed one (a ladder around a step tuned to a floor would
        # time a different ladder on every scene)
        scene = replace(scene.with_values({"montecarlo.dt": FIXED_DT}), given=scene.given)
    out = Path(args.out or f"out/{folder_name(scene.name)}-workprecision")
    if args.out is None:
        validate.output_folder(str(out), "--out (default)")
    cost.refuse_costly(lambda sp: cost.workprecision_seconds(scene, args.quick, speed=sp),
                           "this work-precision run", args.yes)
    prov = _provenance(args)
    files = ("workprecision.png", "workprecision.md", "workprecision.json")
    # the folder is held from the start and written as a unit, like a check report
    with outdir.hold(out, run_id=prov["run_id"], allowed=files, kind="work-precision run"):
        data = run_workprecision(scene, quick=args.quick, repeats=args.repeats,
                                 log=None if args.quiet else log_stderr)
        table = table_markdown(data)

        def fill(tmp: Path) -> None:
            plot(data, tmp / "workprecision.png")
            (tmp / "workprecision.md").write_text(table, encoding="utf-8")
            (tmp / "workprecision.json").write_text(dumps(dict(data, provenance=prov)),
                                                    encoding="utf-8")

        outdir.write_folder(out, fill, run_id=prov["run_id"], allowed=files)
    print(table, end="")
    print(f"diagram: {out / 'workprecision.png'}")
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    from vifpk.harness.sweeps import errors, executors, runs, store
    from vifpk.harness.sweeps import spec as sweeps_spec

    from vifpk.core.provenance import folder_name

    validate.output_folder(args.out, "--out")
    sweep = sweeps_spec.load_sweep(args.sweep)
    validate.outputs_apart_from_inputs(args, replaced=False, names=store.SWEEP_FILES,
                                       extra=sweeps_spec.inputs(sweep))
    spec = executors.parse_executor(args.executor)
    executors.require_output_libraries(
        surface=bool(sweep.adaptive and sweep.adaptive.get("method") == "band"))
    # the default folder is out/<the sweep's name made one safe folder name>: never outside out/
    out = args.out or f"out/{folder_name(sweep.name)}"
    if args.out is None:
        validate.output_folder(out, "--out (default)")
    store.check_sweep_folder(out)
    cost.refuse_costly(lambda sp: store.sweep_seconds(sweep, speed=sp),
                           f"this sweep ({store.sweep_size(sweep)})", args.yes)
    try:
        # the estimate is a lower bound: the run checks it against its measured rate
        res = runs.run_sweep(sweep, out, executor=spec, quiet=args.quiet,
                             time_limit=None if args.yes else cost.HOUR)
    except errors.WorkerLost as exc:
        print(f"vifpk: {exc}; the finished points are kept in {out}/points: run the same "
              "command again to compute the rest", file=sys.stderr)
        return EXIT_SOLVER
    print(f"{res.total} points: {len(res.computed)} computed, {res.skipped} done before, "
          f"{len(res.failed)} failed; " + ", ".join(str(f) for f in res.files.values()))
    if res.failed:
        print(f"vifpk: {len(res.failed)} of {res.total} points failed; their messages are in "
              "sweep.nc (variables failed, message)", file=sys.stderr)
        return EXIT_SOLVER
    return 0


def cmd_models(args: argparse.Namespace) -> int:
    """List the registered averaged models: name, who registered it, its entry point."""
    from vifpk.core.guard import source_of

    entries = registry.models()
    width = max(len(e.name) for e in entries)
    for e in entries:
        missing = not e.builtin and source_of(e.value.partition(":")[0].strip()) is None
        tags = [t for t, on in (("check default", e.name in CHECK_MODELS),
                                ("built-in", e.builtin),
                                ("CANNOT BE LOADED: module not installed", missing)) if on]
        print(f"{e.name:<{width}}  {e.value}  ({e.distribution}"
              + (f"; {', '.join(tags)}" if tags else "") + ")")
    for c in registry.model_conflicts():
        print(f"warning: model registered twice: {c}", file=sys.stderr)
    for e in entries:  # found without importing it (a listing runs no plugin code)
        module = e.value.partition(":")[0].strip()
        if not e.builtin and source_of(module) is None:
            print(f"warning: model {e.name!r} (from {e.distribution}) cannot be loaded: its "
                  f"module {module!r} is not installed", file=sys.stderr)
    return 0


def _recorded(args: argparse.Namespace) -> list[dict[str, Any]] | None:
    """The run's RuntimeWarnings so far (cli/app.py records them; None when the command was
    called without it, e.g. directly in a test)."""
    tally = getattr(args, "run_warnings", None)
    return tally.records() if tally is not None else None
