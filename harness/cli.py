"""Command line: ``vifpk solve SCENE --solver averaging|fpk|montecarlo ...`` and
``vifpk check SCENE [--out DIR]`` (the cross-check and its error report).

Exit codes: 0 success; 2 bad input (one line naming the field, no traceback, no output
file); 3 the solver could not produce a result (one line saying why); 130 interrupted.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from typing import Any

from vifpk.core import registry
from vifpk.core.defaults import BIFURCATION_MODELS, BURN_FACTOR, CHECK_MODELS, FPK_CELLS
from vifpk.core.guard import PluginError
from vifpk.core.registry import SOLVERS
from vifpk.core.result import BadInput
from vifpk.core.scene import Scene, load_scene, no_noise

from . import request, validate
from .run import SolverFailure, run_solver, solution_record

EXIT_BAD_INPUT = 2
EXIT_SOLVER = 3


SET_HELP = ("override a scene value, e.g. noise.D=0.02 (repeatable; default: none, the scene "
            "as written)")
QUIET_HELP = "no progress on the terminal (default: progress on stderr)"


class _Once(argparse._StoreAction):
    """A value option given twice is refused (the last would silently win), as ``--set``
    given twice for one key is."""

    def __call__(self, parser, namespace, values, option_string=None):  # type: ignore[override]
        seen = namespace.__dict__.setdefault("_given", {})
        if self.dest in seen:
            parser.error(f"{option_string} given twice ({seen[self.dest]} and {values}); give "
                         "it once")
        seen[self.dest] = values
        super().__call__(parser, namespace, values, option_string)


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.register("action", None, _Once)
        self.register("action", "store", _Once)

    def error(self, message: str) -> None:  # one line, exit 2
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


def concrete_scene(path: str, overrides: Sequence[str]) -> Scene:
    """Load a scene, apply ``--set`` overrides; a sweep must be pinned to one value
    (request.concrete)."""
    return request.concrete(path, overrides)


def _mc_summary(info: dict[str, Any]) -> str:
    st = info["settings"]
    lines = [f"montecarlo: {info['status']['message']} ({st['paths']} paths, dt {st['dt']:g}, "
             f"time {st['time']:g} after burn-in {st['burn_in']:g}; effects {info['effects']})"]
    if "moments" in info:
        a = info["moments"]["A"]["mean"]
        lines.append(f"  amplitude A: mean {a['value']:.5g} +/- {a['err']:.2g} (batch error)")
    if info.get("L1_floor"):
        floors = ", ".join(f"{k} {v:.2g}" for k, v in info["L1_floor"].items())
        lines.append(f"  L1 noise floor: {floors}")
    if "events" in info:
        ev = info["events"]
        lines.append(
            f"  impacts per unit time {ev['impacts_per_time']['value']:.4g} +/- "
            f"{ev['impacts_per_time']['err']:.2g}; stuck fraction "
            f"{ev['stuck_fraction']['value']:.3g} +/- {ev['stuck_fraction']['err']:.2g}; "
            f"chatter-guard entries {ev['chatter_entries']}")
    conv = info.get("convergence", {})
    if conv.get("equilibrated") is not None:
        burn = f"burn-in {conv['burn_in']:g}"
        if "relaxation_time" in conv:
            burn += (f" = {BURN_FACTOR:g} x measured relaxation time "
                     f"{conv['relaxation_time']:.3g}")
        if conv["equilibrated"]:
            lines.append(f"  equilibrated: yes (R-hat {conv['rhat']:.4f} <= "
                         f"{conv['rhat_limit']:.4f}, drift {conv['drift_z']:+.1f} s.e., ESS "
                         f"{conv['ess']:.0f}; {burn})")
        else:
            lines.append(f"  NOT equilibrated: {conv['reason']} ({burn})")
    if conv.get("target_floor"):
        lines.append(f"  target floor {conv['target_floor']:g}: "
                     + ("reached" if conv["reached"] else "NOT reached")
                     + f" (floor {conv['floor']:.4g}; stopped: {conv['stopped']})")
    atom = info.get("atoms", {}).get("x2")
    if atom and atom["weight"] > 0:
        lines.append(f"  atom of p(x2) at v = 0 (mass at rest): weight {atom['weight']:.4g} "
                     f"+/- {atom['err']:.2g}, kept out of the x2 bins")
    sec = info["seconds"]
    lines.append(f"  time: compile {sec['compile']:.2f} s, run {sec['run']:.2f} s "
                 f"({info['steps_per_second'] / 1e6:.0f} M steps/s on {info['threads']} threads)")
    return "\n".join(lines)


def _summary(result: Any) -> str:
    info = result.info
    if info["solver"] == "montecarlo":
        return _mc_summary(info)
    s, d = info["summary"], info["diagnostics"]
    lines = [
        f"{info['solver']} ({info.get('model', '-')}): {info['status']['message']}",
        *([f"  method: {info['method']}"] if info.get("closed_form") is False else []),
        *([f"  period T(A): {info['period']}"] if str(info.get("period", "model")) != "model"
          else []),
        f"  amplitude A: mean {s['mean']:.6g}, mode {s['mode']:.6g}, std {s['std']:.6g}",
        f"  grid: {info['grid'].get('points', info['grid'].get('cells'))} points on "
        f"[{info['grid']['A_min']:.4g}, {info['grid']['A_max']:.4g}]",
        f"  mass check: {d['mass']:.12f} (mass outside grid {d['tail_mass']:.1e}), "
        f"min p = {d['min']:.3g}",
        f"  time: {info['seconds']['total'] * 1e3:.1f} ms",
    ]
    return "\n".join(lines)


def _provenance(args: argparse.Namespace) -> dict[str, Any]:
    """The provenance block of this run (harness/provenance.py)."""
    from . import provenance

    scene = getattr(args, "scene", None)
    return provenance.collect(argv=getattr(args, "argv", None),
                              scene_path=provenance.scene_file(scene) if scene else None,
                              overrides=getattr(args, "set", []))


def _mc_given(args: argparse.Namespace) -> list[str]:
    """The Monte Carlo options given on the command line (names without dashes)."""
    return [k for k in validate.MC_OPTIONS if getattr(args, k, None) is not None]


def _mc_options(args: argparse.Namespace) -> dict[str, Any]:
    """The Monte Carlo options on the command line, by flag name (None: not given)."""
    return {k: getattr(args, k, None) for k in validate.MC_OPTIONS}


def _checked_scene(args: argparse.Namespace, *, mc: bool) -> Scene:
    """The concrete scene with the options applied, every check done (request.py)."""
    return request.with_mc_options(concrete_scene(args.scene, args.set), _mc_options(args),
                                   mc=mc)


def cmd_solve(args: argparse.Namespace) -> int:
    from .io import write_json

    if args.joint and not args.json:
        validate.refuse_options(["joint"], "without --json (the summary has no joint density)")
    validate.output_file(args.json, "--json")
    validate.outputs_apart_from_inputs(args, replaced=False)
    req = request.prepare_solve(args.scene, solver=args.solver, model=args.model,
                                grid=args.grid, joint=args.joint, overrides=args.set,
                                allow_unequilibrated=args.allow_unequilibrated,
                                **_mc_options(args))
    scene, model = req.scene, req.model
    validate.refuse_costly(lambda sp: validate.solve_seconds(scene, args.solver, model,
                                                             args.grid, speed=sp),
                           "this solve", args.yes)
    if args.solver == "montecarlo":
        validate.refuse_oversized(scene)
    if args.solver == "montecarlo":
        # priced again once the relaxation pilot has measured an automatic burn-in
        with validate.guarded_run(scene, args.yes):
            result = run_solver(scene, "montecarlo")
    else:
        result = run_solver(scene, args.solver, model=model, grid=args.grid)
    _finite_or_fail(result, scene)
    conv = result.info.get("convergence", {}) if args.solver == "montecarlo" else {}
    stuck = _not_equilibrated(conv) if not args.allow_unequilibrated else ""
    if args.json:
        model = None if args.solver == "montecarlo" else model
        write_json(args.json, solution_record(scene, args.solver, model, result,
                                              joint=args.joint, provenance=_provenance(args)))
        if not stuck:
            print(f"wrote {args.json}", file=sys.stderr)
    else:
        print(_summary(result))
    if stuck:  # one line, exit 3; the output is written, its certificate inside
        kept = f"{args.json} was written" if args.json else "the summary above was printed"
        print(f"vifpk: the simulation is NOT equilibrated: {stuck}; {kept} with its "
              "certificate; --allow-unequilibrated accepts it (exit 0)", file=sys.stderr)
        return EXIT_SOLVER
    if conv.get("equilibrated") is False:  # said on the terminal, not only inside the JSON
        print(f"vifpk: warning: the simulation is NOT equilibrated ({conv.get('reason', '')}); "
              "its densities are not yet the stationary ones: raise --time or --paths, or give "
              "--floor", file=sys.stderr)
    return 0 if result.info["status"]["ok"] else EXIT_SOLVER


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


def _add_tolerance_options(p: argparse.ArgumentParser) -> None:
    """The tolerance verdict's question (harness/tolerance.py; checked in cmd_check)."""
    from vifpk.core.defaults import TOLERANCE, TOLERANCE_CONFIDENCE

    from .tolerance import METRICS, OBSERVABLES

    p.add_argument("--tolerance", type=float, default=TOLERANCE, metavar="T",
                   help="the largest averaging error accepted; each model is called inside / "
                        "outside / undecided and the recommendation follows it (default "
                        f"{TOLERANCE:g})")
    p.add_argument("--tolerance-metric", default="L1", metavar="METRIC",
                   help=f"the distance the tolerance is on, one of {', '.join(METRICS)} "
                        "(default L1)")
    p.add_argument("--tolerance-observable", default="A", metavar="OBS",
                   help=f"the density it is on, one of {', '.join(OBSERVABLES)} (default A)")
    p.add_argument("--confidence", type=float, default=TOLERANCE_CONFIDENCE, metavar="C",
                   help="the confidence of the inside/outside classes, in (0.5, 1) "
                        f"(default {TOLERANCE_CONFIDENCE:g})")


def cmd_check(args: argparse.Namespace) -> int:
    from . import outdir
    from .check import cross_check
    from .provenance import folder_name
    from .report import REPORT_FILES, write_report

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
    validate.refuse_costly(lambda sp: validate.check_seconds(scene, models, speed=sp),
                           "this check", args.yes)
    validate.refuse_oversized(scene)
    prov = _provenance(args)
    # hold the folder from the start: a second run into it is refused before any work
    with outdir.hold(out, run_id=prov["run_id"], allowed=REPORT_FILES, kind="check report"):
        with validate.guarded_run(scene, args.yes):
            result = cross_check(scene, quiet=args.quiet, models=models, tolerance=tol)
        files = write_report(result, out, prov=prov)
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
    from .bifurcation import VARIABLES, bifurcation
    from .io import write_json

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
        validate.refuse_oversized(scene)
        validate.refuse_costly(lambda sp: points * validate.montecarlo_seconds(scene, speed=sp),
                               "this bifurcation "
                               f"search (Monte Carlo at up to {points} points)", args.yes)
    if not args.quiet:
        print(f"searching the critical {args.vary} (shape criterion on each averaged model)"
              + ("; then Monte Carlo on both sides" if not args.no_mc else "") + " ...",
              file=sys.stderr, flush=True)
    chosen = {"models": tuple(dict.fromkeys(args.model or default_models))}
    res = bifurcation(scene, args.vary, lo=lo, hi=hi, mc=not args.no_mc, **chosen)
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
        write_json(args.json, dict(res, provenance=_provenance(args)))
    return 0


def cmd_figures(args: argparse.Namespace) -> int:
    from . import outdir
    from .figures import FIGURES, draw_figures, render_table

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
            validate.refuse_oversized(scene)
        validate.refuse_costly(lambda sp: sum(validate.montecarlo_seconds(sc, speed=sp)
                                              for sc in scenes), "these figures", args.yes)

    if args.scene is not None:  # your own scene: its PDFs and joint density, any system
        from .figures import as_sweep, draw_scene_figures

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

    from . import outdir
    from .io import dumps
    from .provenance import folder_name
    from .workprecision import log_stderr, plot, run_workprecision, table_markdown

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
        raise validate.InputError("montecarlo.dt = 'auto': workprecision times a ladder of "
                                  "fixed steps; give a number with --dt")
    out = Path(args.out or f"out/{folder_name(scene.name)}-workprecision")
    if args.out is None:
        validate.output_folder(str(out), "--out (default)")
    validate.refuse_costly(lambda sp: validate.workprecision_seconds(scene, args.quick, speed=sp),
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
    from . import sweep as sw
    from .provenance import folder_name

    validate.output_folder(args.out, "--out")
    validate.outputs_apart_from_inputs(args, replaced=False, names=sw.SWEEP_FILES)
    sweep = sw.load_sweep(args.sweep)
    spec = sw.parse_executor(args.executor)
    sw.require_output_libraries()
    # the default folder is out/<the sweep's name made one safe folder name>: never outside out/
    out = args.out or f"out/{folder_name(sweep.name)}"
    if args.out is None:
        validate.output_folder(out, "--out (default)")
    sw.check_sweep_folder(out)
    validate.refuse_costly(lambda sp: sw.sweep_seconds(sweep, speed=sp),
                           f"this sweep ({len(sweep.points)} points)", args.yes)
    try:
        res = sw.run_sweep(sweep, out, executor=spec, quiet=args.quiet)
    except sw.WorkerLost as exc:
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


def _add_mc_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--paths", type=_whole_number, metavar="N",
                   help="Monte Carlo: number of paths, a whole multiple of montecarlo.blocks "
                        "(default: the scene's montecarlo.paths)")
    p.add_argument("--dt", type=_dt_value, metavar="H|auto",
                   help='Monte Carlo: time step, or "auto" (the largest with bias below half '
                        "the target floor) (default: the scene's montecarlo.dt)")
    p.add_argument("--time", type=float, metavar="T",
                   help="Monte Carlo: simulated time sampled per path after the burn-in "
                        "(default: the scene's montecarlo.time)")
    p.add_argument("--seed", type=_whole_number, metavar="S",
                   help="Monte Carlo: root seed (default: the scene's montecarlo.seed)")
    p.add_argument("--floor", type=float, metavar="F",
                   help="Monte Carlo: simulate until the L1 noise floor of p(A) is at most F "
                        "(default: the scene's montecarlo.floor; 0: sample exactly --time)")
    p.add_argument("--budget", type=float, metavar="SECONDS",
                   help="Monte Carlo: wall seconds allowed to reach the floor, 0: no limit "
                        "(default: the scene's montecarlo.budget, 600 unless set)")
    p.add_argument("--yes", action="store_true",
                   help="run even when the estimated cost exceeds an hour (default: off)")


def _whole_number(text: str) -> int:
    """An option's whole number; "1e6" is accepted when it is whole (ranges: validate.py)."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and v == int(v)):
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number")
    return int(v)


def _dt_value(text: str) -> float | str:
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number or 'auto'") from None


def _model_name(text: str) -> str:
    """A registered averaged model (vifpk.core.registry); else one line listing them."""
    names = registry.model_names()
    if text not in names:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a registered model; registered: {', '.join(names)} "
            "(vifpk models lists them; docs/plugins.md adds one)")
    return text


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


def build_parser() -> argparse.ArgumentParser:
    from .bifurcation import VARIABLES
    from .figures import FIGURES
    from .provenance import vifpk_version

    p = _Parser(prog="vifpk", description="How wrong is a stochastic-averaging approximation?")
    p.add_argument("--version", action="version", version=f"vifpk {vifpk_version()}",
                   help="print the version and exit")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    s = sub.add_parser("solve", help="solve one scene with one solver")
    s.add_argument("scene", help="scene TOML file (or the name of a shipped scene)")
    s.add_argument("--solver", choices=SOLVERS, default="averaging",
                   help="averaging: closed form of an averaged model; fpk: its Fokker-Planck "
                        "equation; montecarlo: the original system (default: %(default)s)")
    s.add_argument("--model", type=_model_name, metavar="NAME",
                   help="averaged model for --solver averaging|fpk: any registered one, "
                        "built-in or a plugin's (`vifpk models` lists them, docs/plugins.md; "
                        "default: paper)")
    s.add_argument("--json", metavar="OUT",
                   help="write the solution record to OUT (default: print a summary)")
    s.add_argument("--grid", type=_whole_number, metavar="N",
                   help=f"FPK: number of cells, >= 4 (default: {FPK_CELLS})")
    _add_mc_options(s)
    s.add_argument("--joint", action="store_true",
                   help="include the joint PDF in the JSON (default: off)")
    s.add_argument("--allow-unequilibrated", action="store_true",
                   help="Monte Carlo: exit 0 with a warning when the equilibration "
                        "certificate's R-hat or drift fails (default: exit 3, the output "
                        "still written)")
    s.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help=SET_HELP)
    s.set_defaults(func=cmd_solve)
    c = sub.add_parser("check", help="cross-check the averaged models (default: "
                                     f"{', '.join(CHECK_MODELS)}; outside the paper's family "
                                     "without paper) against the Monte Carlo of the original "
                                     "system and write an error report")
    c.add_argument("scene", help="scene TOML file (or the name of a shipped scene)")
    c.add_argument("--out", metavar="DIR", help="report directory (default: out/<scene name>)")
    c.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help=SET_HELP)
    c.add_argument("--model", action="append", type=_model_name, metavar="NAME",
                   help="an averaged model to check, any registered one (repeat for several; "
                        f"default: {', '.join(CHECK_MODELS)})")
    c.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    _add_tolerance_options(c)
    _add_mc_options(c)
    c.set_defaults(func=cmd_check)
    b = sub.add_parser("bifurcation", help="find the critical mu or r of the P-bifurcation of "
                                           "each averaged model and check it by Monte Carlo")
    b.add_argument("scene", help="scene TOML file (or the name of a shipped scene)")
    b.add_argument("--vary", choices=tuple(VARIABLES), required=True,
                   help="the parameter to vary (required; the other one stays at the scene's "
                        "value, and the output names it)")
    b.add_argument("--range", nargs=2, type=float, metavar=("LO", "HI"),
                   help="search interval (default: mu 0 0.05, r 0.9 1)")
    b.add_argument("--model", action="append", type=_model_name, metavar="NAME",
                   help="an averaged model whose critical value to find, any registered one "
                        f"(repeat for several; default: {', '.join(BIFURCATION_MODELS)})")
    b.add_argument("--json", metavar="OUT", help="write the result as JSON (default: none)")
    b.add_argument("--no-mc", action="store_true",
                   help="skip the Monte Carlo check (default: run it on both sides)")
    b.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help=SET_HELP)
    b.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    _add_mc_options(b)
    b.set_defaults(func=cmd_bifurcation)
    f = sub.add_parser("figures", help="redraw the paper's Figures 2-6: two averaged models "
                                       "(the paper's and the exact one) against the Monte "
                                       "Carlo of the original system")
    f.add_argument("--out", default="out/figures", metavar="DIR",
                   help="directory for paper-fig*.png and figures.json/.md "
                        "(default: %(default)s)")
    f.add_argument("--figure", type=int, action="append", choices=tuple(FIGURES),
                   help="only this figure (repeatable; default: all of 2-6)")
    f.add_argument("--scene", metavar="SCENE",
                   help="instead of the paper's figures, draw the PDFs and the joint density "
                        "of this scene (any system; a list-valued parameter gives a row per "
                        "value): SCENE-pdfs.png, SCENE-joint.png "
                        "(default: none, the paper's Figures 2-6)")
    f.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    _add_mc_options(f)
    f.set_defaults(func=cmd_figures)
    w = sub.add_parser("workprecision", help="what accuracy costs in time, for every solver")
    w.add_argument("scene", help="scene TOML file (or the name of a shipped scene)")
    w.add_argument("--out", metavar="DIR",
                   help="directory for workprecision.png/.md/.json "
                        "(default: out/<scene>-workprecision)")
    w.add_argument("--quick", action="store_true",
                   help="short ladders, a smoke test (default: the full ladders)")
    w.add_argument("--repeats", type=_whole_number, default=3,
                   help="timed repeats after the warm-up, 1-100 (default: %(default)s)")
    w.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help=SET_HELP)
    w.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    _add_mc_options(w)
    w.set_defaults(func=cmd_workprecision)
    sw = sub.add_parser("sweep", help="run a workflow over a parameter grid (serial, process "
                                      "pool or dask) and write sweep.nc and maps")
    sw.add_argument("sweep", help="sweep TOML file (or the name of a shipped sweep)")
    sw.add_argument("--executor", default="serial", metavar="E",
                    help="serial | processes:N | dask:N | tcp://HOST:PORT (default serial)")
    sw.add_argument("--out", metavar="DIR", help="output directory (default out/<sweep name>)")
    sw.add_argument("--quiet", action="store_true",
                    help="no progress lines on the terminal (default: one line a point)")
    sw.add_argument("--yes", action="store_true",
                    help="run even when the estimated cost exceeds an hour (default: off)")
    sw.set_defaults(func=cmd_sweep)
    from .timecli import add_commands

    add_commands(sub, _model_name, SET_HELP, QUIET_HELP)
    ms = sub.add_parser("models", help="list the registered averaged models (built-in and "
                                       "plugins, docs/plugins.md)")
    ms.set_defaults(func=cmd_models)
    return p


def _first_warning(caught: list[Any]) -> str:
    """' (numpy: overflow encountered in multiply, averaging/paper.py:165)' or ''."""
    if not caught:
        return ""
    w = caught[0]
    where = "/".join(str(w.filename).split("/")[-2:])
    return f" (numpy: {w.message}, {where}:{w.lineno})"


def main(argv: Sequence[str] | None = None) -> int:
    """The ``vifpk`` command. Exit codes: 0, 2 bad input, 3 numerical failure, 130 Ctrl-C.

    numpy RuntimeWarnings are caught (never printed): a run that then fails names the first
    one in its one-line message; a run whose results are finite drops them."""
    import warnings

    from . import signals

    parser = build_parser()
    from_command_line = argv is None  # the console script: Ctrl-C watchdog (not in-process)
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv:  # `vifpk` alone: the usage and the commands, exit 2
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    args = parser.parse_args(argv)
    args.argv = ["vifpk", *(sys.argv[1:] if argv is None else argv)]
    try:
        validate.environment()
    except BadInput as exc:
        print(f"vifpk: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    signals.reset()
    if from_command_line:
        signals.install()
    caught: list[Any] = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RuntimeWarning)
            code = int(args.func(args))
            sys.stdout.flush()  # a closed pipe shows here, not at exit
            return code
    except BadInput as exc:  # a scene field, an option, an output folder
        print(f"vifpk: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (SolverFailure, PluginError) as exc:  # PluginError: names the plugin and its file
        print(f"vifpk: {exc}{_first_warning(caught)}", file=sys.stderr)
        return EXIT_SOLVER
    except ArithmeticError as exc:  # overflow, 0 division, numpy errors, FPK coefficients
        print(f"vifpk: numerical failure: {exc}{_first_warning(caught)}; the scene's "
              "magnitudes or the step are most likely too extreme", file=sys.stderr)
        return EXIT_SOLVER
    except ValueError as exc:  # past validation: a run that could not go on, never a traceback
        print(f"vifpk: {exc}{_first_warning(caught)}", file=sys.stderr)
        return EXIT_SOLVER
    except MemoryError:
        print("vifpk: out of memory: a grid, histogram or sample size is too large for this "
              "machine; reduce it (e.g. averaging.phase_points, montecarlo.bins, --grid)",
              file=sys.stderr)
        return EXIT_SOLVER
    except KeyboardInterrupt:  # Ctrl-C, or SIGTERM (signals.Terminated)
        signals.announce()
        return signals.exit_code()
    except BrokenPipeError:  # e.g. `vifpk solve ... | head -2`: the reader left
        _silence_stdout()
        return 141
    except OSError as exc:  # a full disk, a read-only or vanished folder, `> /dev/full`
        _silence_stdout()
        where = f" {exc.filename}" if exc.filename else " the standard output"
        print(f"vifpk: cannot write{where} ({exc.strerror or exc}); the run's output is "
              "incomplete", file=sys.stderr)
        return EXIT_SOLVER
    except Exception as exc:  # noqa: BLE001 - never a traceback: one line, where it happened
        import os
        import traceback

        if os.environ.get("VIFPK_TRACEBACK") or not from_command_line:
            raise  # in-process callers (the Python API, tests) get the exception itself
        tb = traceback.extract_tb(exc.__traceback__)[-1]
        where = "/".join(tb.filename.split("/")[-2:])
        text = str(exc).splitlines()[0][:300] if str(exc) else ""
        print(f"vifpk: internal error: {type(exc).__name__}: {text} ({where}:{tb.lineno})"
              f"{_first_warning(caught)}; please report it (VIFPK_TRACEBACK=1 shows the "
              "traceback)", file=sys.stderr)
        return EXIT_SOLVER


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush stays quiet."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


if __name__ == "__main__":
    sys.exit(main())
