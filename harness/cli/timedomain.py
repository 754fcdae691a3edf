"""Command line of the time-domain workflows (registered by harness/cli/options.py):

    vifpk passage SCENE --threshold Ac [--start A0 | --start stationary] [--model M ...]
                  [--method auto|direct|splitting] [--horizon T] [--at T ...]
                  [--particles N] [--groups G] [--out DIR] [--json] [--paths N | --rel-se R
                  [--max-paths N]] [--dt H] [--seed S] [--yes]
    vifpk transient SCENE --start A0 --times t1,t2,t3,... [--model M ...] [--out DIR] [--json]
                  [--paths N | --rel-se R [--max-paths N]] [--dt H] [--seed S] [--yes]

Every input is checked before any computation by the time domain's request
(harness/request/timedomain.py; one line, exit 2: :func:`check_passage`,
:func:`check_transient`); the passage plan is priced by the cost guard from the averaged
models' MFPTs (the quadrature, computed once and handed to the workflow), before any Monte
Carlo.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
from pathlib import Path
from typing import Any

from vifpk.harness.request import cost, validate
from vifpk.harness.request.timedomain import (
    MAX_PATHS_FACTOR,
    REL_SE_ALLOWED,
    REL_SE_MFPT,
    REL_SE_RELAXATION,
)

from vifpk.core.defaults import CHECK_MODELS


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None


def _start(text: str) -> float | str:
    if text == "stationary":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an amplitude or 'stationary'"
                                         ) from None


def _times(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(t) for t in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a comma-separated list of times, "
                                         "e.g. 5,10,20,40") from None


def _refuse_common(args: argparse.Namespace, command: str) -> None:
    if args.dt == "auto":
        raise validate.InputError(f"--dt auto: does not apply to {command} (auto picks the "
                                  "step from a target floor of the stationary p(A)); give a "
                                  "number")
    validate.output_folder(args.out, "--out", replaced=True)


def check_passage(args: argparse.Namespace) -> Any:
    """Every passage input, before any computation: the scene, the options, the folder; the
    one PassageRequest (harness/request/timedomain.py) every front end builds."""
    from vifpk.harness.cli.options import _checked_scene
    from vifpk.harness.request.timedomain import passage_request

    _refuse_common(args, "passage")
    req = passage_request(_checked_scene(args, mc=True), threshold=args.threshold,
                          start=args.start, models=args.model, horizon=args.horizon,
                          paths=args.paths, method=args.method, at=args.at,
                          particles=args.particles, groups=args.groups, rel_se=args.rel_se,
                          max_paths=args.max_paths)
    return req


def check_transient(args: argparse.Namespace) -> Any:
    """Every transient input, before any computation (the one TransientRequest)."""
    from vifpk.harness.cli.options import _checked_scene
    from vifpk.harness.request.timedomain import transient_request

    _refuse_common(args, "transient")
    req = transient_request(_checked_scene(args, mc=True), start=args.start, times=args.times,
                            models=args.model, paths=args.paths, rel_se=args.rel_se,
                            max_paths=args.max_paths)
    return req


def _cores(scene: Any) -> int:
    return scene.montecarlo.threads or min(validate.numba_threads_available(),
                                           os.cpu_count() or 1)


def default_folder(scene: Any, command: str, *parts: str, models: Any = None) -> str:
    """out/<scene>-<command>-<parts...>[-<models>]: the question in the name (threshold and
    start, or start and times; the models when chosen), so that a different question never
    replaces another's report (issue 39, X15)."""
    from vifpk.harness.door.solvers import model_label

    from vifpk.core.provenance import folder_name

    name = "-".join([folder_name(scene.name), command, *parts])
    if models:
        name += "-" + "+".join(model_label(m) for m in models)
    return f"out/{folder_name(name)}"


def _out(args: argparse.Namespace, default: str) -> str:
    if args.out is None:
        validate.output_folder(default, "--out (default)", replaced=True)
    return args.out or default


def _print(res: Any, files: dict[str, Any], as_json: bool) -> None:
    if as_json:
        from vifpk.core.io import jsonable

        doc = {k: v for k, v in res.metrics.items() if k not in ("R",)}
        print(json.dumps(jsonable(doc), indent=1, allow_nan=False))
        return
    for v in res.verdicts:
        print(v)
    if "precision" in res.metrics:
        from vifpk.harness.workflows.precision import line

        print(line(res.metrics["precision"]))
    if getattr(res, "recommendation", ""):
        print(res.recommendation)
    for line in mission_lines(res.metrics.get("at", ())):
        print(line)
    for w in res.warnings:
        print(f"warning: {w}")
    print(f"report: {files['report.html']}")


def mission_lines(rows: Any) -> list[str]:
    """One line per mission time (``--at``): R(T) of the original system with its 95%
    interval and band, then every model's R_M(T)."""
    out = []
    for row in rows:
        o = row["original_system"]
        if o["value"] is None:
            head = f"R({row['T']:g}): original system not observed ({o['why']})"
        else:
            head = (f"R({row['T']:g}): original system {o['value']:.4f} +/- {o['se']:.4f} "
                    f"(95%: {o['ci'][0]:.4f} to {o['ci'][1]:.4f}; simultaneous band "
                    f"{o['band'][0]:.4f} to {o['band'][1]:.4f})")
        models = [f"{m} {v:.4f}" for m, v in row.items() if m not in ("T", "original_system")]
        out.append(head + ("; " + ", ".join(models) if models else ""))
    return out


def cmd_passage(args: argparse.Namespace) -> int:
    from vifpk.harness.cli.options import _provenance
    from vifpk.harness.outputs import outdir
    from vifpk.harness.outputs.timereport import PASSAGE_FILES, write_time_report
    from vifpk.harness.request.timedomain import with_quadratures
    from vifpk.harness.workflows.passage import plan, run, run_seconds

    req = check_passage(args)
    scene = req.scene
    start = "stationary" if req.start == "stationary" else f"{req.start:g}"
    out = _out(args, default_folder(scene, "passage", f"{req.threshold:g}", f"from-{start}",
                                    models=args.model))
    prov = _provenance(args)
    # the averaged models' MFPTs by the quadrature, once: the price up front and the workflow
    req = with_quadratures(req)

    def price(p: dict[str, Any]) -> None:
        what = (f"--threshold {req.threshold:g}: the averaged models put the MFPT at up to "
                f"{p['largest_model_mfpt']:.3g} time units, so the first-passage Monte Carlo "
                f"({p['paths']} paths{_CAPPED if req.paths is None else ''} to a horizon of "
                f"{p['horizon']:.3g}, dt "
                f"{p['dt']:g}) is out of reach as a direct simulation (rare events need "
                "another method: --method splitting)")
        runs = 1 + len(req.models)
        try:
            cost.refuse_costly(lambda sp: run_seconds(
                p, runs, sp or cost.MC_STEPS_PER_CORE, _cores(scene)), what, args.yes)
        except validate.InputError as exc:
            if req.method != "auto":
                raise
            raise _Splitting(f"chosen automatically: {exc}") from None

    if req.method == "splitting":
        return _splitting(args, req, out, prov, "asked for: --method splitting")
    if not args.yes:  # priced up front by the quadrature alone (direct or auto), before
        try:  # any R(t) stepping (slow, and fragile, at high thresholds)
            price(plan(scene, {m: float(q["value"]) for m, q in req.quadratures.items()},
                       paths=req.paths or req.max_paths, horizon=req.horizon))
        except _Splitting as why:
            return _splitting(args, req, out, prov, str(why))

    try:
        with outdir.hold(out, run_id=prov["run_id"], allowed=PASSAGE_FILES,
                         kind="passage report"):
            with cost.guarded_run(scene, args.yes):
                res = run(req, quiet=args.quiet, price=price)
            _finite(res.metrics)
            files = write_time_report(res, out, prov=prov, runtime_warnings=_recorded(args))
    except _Splitting as why:  # raised by the guard before any Monte Carlo or file
        return _splitting(args, req, out, prov, str(why))
    _print(res, files, args.json)
    return 0


def _recorded(args: argparse.Namespace) -> list[dict[str, Any]] | None:
    """The run's RuntimeWarnings so far (cli/app.py counts them; None when the command was
    called without it, e.g. directly in a test): metrics.json's ``runtime_warnings``."""
    tally = getattr(args, "run_warnings", None)
    return tally.records() if tally is not None else None


_CAPPED = " at most (the --max-paths cap of the --rel-se growth, priced as the worst case)"


class _Splitting(Exception):
    """Direct simulation is priced beyond the guard: --method auto turns to splitting."""


def _splitting(args: argparse.Namespace, req: Any, out: str, prov: dict[str, Any],
               reason: str) -> int:
    """vifpk passage --method splitting (harness/workflows/rarepassage.py): the MFPT only."""
    from vifpk.harness.outputs import outdir
    from vifpk.harness.outputs.splitreport import passage_splitting_report
    from vifpk.harness.outputs.timereport import PASSAGE_FILES

    if getattr(args, "rel_se", None) is not None or getattr(args, "max_paths", None) is not None:
        reason += ("; --rel-se and --max-paths do not apply to splitting, which has its own "
                   "target interval")
    print(f"method: splitting ({reason})")
    with outdir.hold(out, run_id=prov["run_id"], allowed=PASSAGE_FILES, kind="passage report"):
        met = passage_splitting_report(req, out=out, prov=prov, reason=reason,
                                       quiet=args.quiet,
                                       run_warnings=getattr(args, "run_warnings", None))
        _finite(met)
    o = met["mfpt"]["original_system"]
    if args.json:
        print(json.dumps({"mfpt": met["mfpt"], "method": "splitting",
                          "recommended_model": met["recommended_model"]}))
    else:
        print(f"original system: MFPT {o['value']:.4g} +- {o['stderr']:.2g} "
              f"(95%: {o['ci'][0]:.4g} to {o['ci'][1]:.4g}; {met['splitting']['target']})")
        for line in met["verdicts"]:
            print(line)
        print(met["recommendation"])
        for w in met.get("warnings", []):
            print(f"warning: {w}")
    print(f"report: {Path(out) / 'report.html'}")
    return 0


def cmd_transient(args: argparse.Namespace) -> int:
    from vifpk.harness.cli.options import _provenance
    from vifpk.harness.outputs import outdir
    from vifpk.harness.outputs.timereport import TRANSIENT_FILES, write_time_report
    from vifpk.harness.workflows.transient import run

    req = check_transient(args)
    scene = req.scene
    runs = 1 + len(req.models)
    n = req.paths or req.max_paths or scene.montecarlo.paths  # the growth's worst case: its cap
    steps = n * max(req.times) / req.dt
    cost.refuse_costly(lambda sp: runs * steps / ((sp or cost.MC_STEPS_PER_CORE)
                                                  * _cores(scene)),
                       f"this transient ({runs} Monte Carlo runs to t = {max(req.times):g})",
                       args.yes)
    times = ",".join(f"{t:g}" for t in req.times)
    if len(times) > 60:
        times = f"{req.times[0]:g}..{req.times[-1]:g}x{len(req.times)}"
    out = _out(args, default_folder(scene, "transient", f"{req.start:g}", f"at-{times}",
                                    models=args.model))
    prov = _provenance(args)
    with outdir.hold(out, run_id=prov["run_id"], allowed=TRANSIENT_FILES,
                     kind="transient report"):
        with cost.guarded_run(scene, args.yes):
            res = run(req, quiet=args.quiet)
        _finite(res.metrics)
        files = write_time_report(res, out, prov=prov, runtime_warnings=_recorded(args))
    _print(res, files, args.json)
    return 0


def _finite(metrics: dict[str, Any]) -> None:
    """Never exit 0 with NaN: a non-finite MFPT or distance is a numerical failure (exit 3)."""
    from vifpk.harness.door.solvers import SolverFailure

    bad: list[str] = []

    def walk(v: Any, where: str) -> None:
        if isinstance(v, dict):
            for k, x in v.items():
                walk(x, f"{where}.{k}" if where else str(k))
        elif isinstance(v, float) and math.isnan(v) and not where.startswith(("timings",
                                                                              "monte_carlo")):
            bad.append(where)

    walk({k: metrics[k] for k in ("mfpt", "models", "relaxation") if k in metrics}, "")
    if bad:
        raise SolverFailure(f"not finite: {', '.join(bad[:3])}"
                            + (" ..." if len(bad) > 3 else "") + "; no report written")


def _common(p: argparse.ArgumentParser, quantity: str, default: float) -> None:
    """The options passage and transient share (``quantity``, ``default``: what --rel-se
    is on, and its default)."""
    from vifpk.harness.cli.options import (
        _model_name,
        add_mc_option,
        add_quiet,
        add_scene,
        add_set,
    )
    from vifpk.harness.cli.options import _whole_number as _number_whole

    # a value such as -5,10,20 or -1e3 is a value, not an option (issue 39, T01): argparse
    # takes only plain negative numbers as values by default; vifpk has no option -<digit>
    p._negative_number_matcher = re.compile(r"^-(\d|\.\d|inf|nan)", re.IGNORECASE)
    add_scene(p)
    p.add_argument("--model", action="append", type=_model_name, metavar="NAME",
                   help="an averaged model, any registered one (repeat for several; "
                        f"default: {', '.join(CHECK_MODELS)}, without paper outside its "
                        "family)")
    p.add_argument("--out", metavar="DIR",
                   help="report directory (default: out/<scene>-passage-<Ac>-from-<A0>, "
                        "out/<scene>-transient-<A0>-at-<times>, and -<models> when chosen)")
    p.add_argument("--json", action="store_true",
                   help="print metrics.json's results on stdout instead of the verdicts "
                        "(default: off; the report is written either way)")
    add_set(p)
    add_quiet(p)
    add_mc_option(p, "paths", help="Monte Carlo: exactly N paths in each run, a whole "
                  "multiple of montecarlo.blocks, no precision target (default: units of the "
                  "scene's montecarlo.paths until --rel-se is met)")
    p.add_argument("--rel-se", type=_number, metavar="R",
                   help=f"target relative standard error of the original system's {quantity}, "
                        f"{REL_SE_ALLOWED}: its paths grow in units of the scene's "
                        "montecarlo.paths until R, --max-paths or the scene's montecarlo.budget "
                        "(seconds, priced in path-steps) is reached; the report says which "
                        f"(default {default:g})")
    p.add_argument("--max-paths", type=_number_whole, metavar="N",
                   help="the paths cap of --rel-se, >= montecarlo.paths, in whole units of "
                        f"it (default {MAX_PATHS_FACTOR} x the scene's montecarlo.paths)")
    add_mc_option(p, "dt", metavar="H", help="Monte Carlo: time step (default: the scene's "
                  "montecarlo.dt)")
    add_mc_option(p, "seed", help="Monte Carlo: root seed; each model's averaged SDE gets a "
                  "seed of S and the model's name alone, as in check (default: the scene's "
                  "montecarlo.seed)")
    p.add_argument("--yes", action="store_true",
                   help="run even when the estimated cost exceeds an hour (default: off)")


def passage_arguments(p: argparse.ArgumentParser) -> None:
    """``vifpk passage``'s options."""
    from vifpk.harness.cli.options import _whole_number

    _common(p, "MFPT", REL_SE_MFPT)
    p.add_argument("--threshold", type=_number, required=True, metavar="Ac",
                   help="the amplitude threshold Ac (energy U(Ac)); required")
    p.add_argument("--start", type=_start, default="stationary", metavar="A0|stationary",
                   help="start amplitude A0 < Ac, or 'stationary': the stationary law "
                        "restricted to A < Ac (default: %(default)s)")
    p.add_argument("--method", choices=("auto", "direct", "splitting"), default="auto",
                   help="the original system's Monte Carlo: direct simulation, or splitting "
                        "(the MFPT only, at thresholds direct simulation cannot reach); auto: "
                        "direct unless the cost guard prices it out, then splitting, said so "
                        "(default: %(default)s)")
    p.add_argument("--particles", type=_whole_number, metavar="N",
                   help="splitting: replicas per AMS run, >= 2 (default 200; --method "
                        "splitting or auto)")
    p.add_argument("--groups", type=_whole_number, metavar="G",
                   help="splitting: independent repetitions per batch (the interval's "
                        "samples), 2 to 400 (default 20; --method splitting or auto)")
    p.add_argument("--at", type=_number, action="append", metavar="T",
                   help="a mission time: print R(T) of the original system (with its 95%% "
                        "interval and simultaneous band) and of every model, and write it "
                        "in metrics.json's \"at\" (repeat for several; default: none)")
    p.add_argument("--horizon", type=_number, metavar="T",
                   help="Monte Carlo censoring horizon (default: "
                        "8 x the largest averaged-model MFPT)")


def transient_arguments(t: argparse.ArgumentParser) -> None:
    """``vifpk transient``'s options."""
    _common(t, "relaxation time", REL_SE_RELAXATION)
    t.add_argument("--start", type=_number, required=True, metavar="A0",
                   help="start amplitude (energy U(A0), phase uniform in time along that "
                        "orbit, noise from its stationary law); required")
    t.add_argument("--times", type=_times, required=True, metavar="t1,t2,...",
                   help="snapshot times > 0, increasing; required")
