"""Command line of the time-domain workflows (registered by harness/cli/options.py):

    vifpk passage SCENE --threshold Ac [--start A0 | --start stationary] [--model M ...]
                  [--horizon T] [--out DIR] [--json] [--paths N] [--dt H] [--seed S] [--yes]
    vifpk transient SCENE --start A0 --times t1,t2,... [--model M ...] [--out DIR] [--json]
                  [--paths N] [--dt H] [--seed S] [--yes]

Every input is checked before any computation (one line, exit 2: :func:`check_passage`,
:func:`check_transient`); the passage plan is priced by the cost guard once the averaged
models have given their MFPT (seconds), before any Monte Carlo.
"""

from __future__ import annotations

import argparse
import json
import math
import numbers
import os
from pathlib import Path
from typing import Any

from vifpk.harness.request import cost, validate

from vifpk.core import registry
from vifpk.core.defaults import CHECK_MODELS
from vifpk.core.scene import no_noise


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


def _amplitude_ok(scene: Any, option: str, value: float) -> None:
    """A finite amplitude > 0 inside the oscillation domain: the restoring force g(A) > 0 on
    (0, A] (a softening spring's potential well ends where g turns back)."""
    import numpy as np
    from vifpk.harness.door.solvers import restoring_force

    if not (math.isfinite(value) and value > 0):
        raise validate.InputError(f"{option} {value:g}: out of range; allowed: a finite "
                                  "amplitude > 0")
    grid = np.linspace(value / 1000.0, value, 1000)
    with np.errstate(all="ignore"):
        g = np.asarray(restoring_force(grid, tuple(scene.system.restoring_law)), float)
    from vifpk.harness.door.solvers import potential_energy

    with np.errstate(all="ignore"):
        u = float(potential_energy(scene, value))
    if not math.isfinite(u):
        raise validate.InputError(f"{option} {value:g}: beyond the domain: its energy U(A) "
                                  "overflows a double; allowed: an amplitude whose energy is "
                                  "finite")
    if not np.all(np.isfinite(g) & (g > 0)):
        edge = float(grid[np.argmax(~(np.isfinite(g) & (g > 0)))])
        raise validate.InputError(f"{option} {value:g}: beyond the domain of oscillation "
                                  f"(the restoring force vanishes near A = {edge:.4g}); "
                                  f"allowed: 0 < A < {edge:.4g}")


def _refuse_common(args: argparse.Namespace, command: str) -> None:
    if args.dt == "auto":
        raise validate.InputError(f"--dt auto: does not apply to {command} (auto picks the "
                                  "step from a target floor of the stationary p(A)); give a "
                                  "number")
    validate.output_folder(args.out, "--out", replaced=True)


def _scene(args: argparse.Namespace) -> Any:
    from vifpk.harness.cli.options import _checked_scene
    from vifpk.harness.door.solvers import SolverFailure
    from vifpk.harness.door.timedomain import time_step

    scene = _checked_scene(args, mc=True)
    if scene.montecarlo.dt == "auto":  # the time domain's one step rule (timedomain.time_step)
        scene = scene.with_values({"montecarlo.dt": time_step(scene)})
    if no_noise(scene.system):
        raise SolverFailure(f"{no_noise(scene.system)}; nothing passes or relaxes "
                            "stochastically, nothing to check")
    return scene


def _models(args: argparse.Namespace, scene: Any) -> tuple[str, ...]:
    """The models named (each must apply: one line otherwise), else the check models that
    apply to the scene (request.applicable_models, as check does): every route below, the
    auto pricing and splitting included, runs only models that apply."""
    from vifpk.harness.request.prepare import applicable_models

    names = tuple(dict.fromkeys(args.model)) if args.model else CHECK_MODELS
    applicable_models(scene, names, chosen=bool(args.model))
    return names  # the workflows report why a default model does not apply


def check_passage(args: argparse.Namespace) -> Any:
    """Every passage input, before any computation: the scene, the options, the folder."""
    _refuse_common(args, "passage")
    scene = _scene(args)
    passage_values(scene, threshold=args.threshold, start=args.start, horizon=args.horizon)
    cost.refuse_oversized(scene)
    return scene


def _real(option: str, value: Any, allowed: str) -> float:
    """``value`` as a float, or InputError naming the option (the Python API passes values as
    they come: a text or a list where a number belongs is refused, not a TypeError)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise validate.InputError(f"{option} {value!r}: not a number; allowed: {allowed}")
    return float(value)


def passage_values(scene: Any, *, threshold: float, start: float | str,
                   horizon: float | None = None) -> None:
    """The threshold, start and horizon of a passage run (InputError, one line)."""
    ac = _real("--threshold", threshold, "a finite amplitude > 0")
    if start != "stationary" and not isinstance(start, str):
        _real("--start", start, "an amplitude or 'stationary'")
    if horizon is not None:
        horizon = _real("--horizon", horizon, "a finite time > 0")
    if not math.isfinite(ac) or ac <= 0:
        raise validate.InputError(f"--threshold {ac:g}: out of range; allowed: a finite "
                                  "amplitude > 0")
    _amplitude_ok(scene, "--threshold", ac)
    if start != "stationary":
        if isinstance(start, str):
            raise validate.InputError(f"--start {start!r}: allowed: an amplitude or "
                                      "'stationary'")
        a0 = float(start)
        if not math.isfinite(a0) or a0 < 0:
            raise validate.InputError(f"--start {a0:g}: out of range; allowed: an amplitude "
                                      f"0 <= A0 < Ac = {ac:g}, or 'stationary'")
        if a0 >= ac:
            raise validate.InputError(f"--start {a0:g}: at or above the threshold Ac = {ac:g}; "
                                      "the path has already passed; allowed: 0 <= A0 < Ac, "
                                      "or 'stationary'")
    if horizon is not None and not (math.isfinite(horizon) and horizon > 0):
        raise validate.InputError(f"--horizon {horizon:g}: out of range; allowed: a "
                                  "finite time > 0")
    if horizon is not None and scene.montecarlo.dt != "auto":
        validate.at_least("--horizon", horizon / float(scene.montecarlo.dt), 1.0)


def check_transient(args: argparse.Namespace) -> Any:
    _refuse_common(args, "transient")
    scene = _scene(args)
    transient_values(scene, start=args.start, times=args.times)
    cost.refuse_oversized(scene)
    return scene


def transient_values(scene: Any, *, start: float, times: Any) -> None:
    """The start and the snapshot times of a transient run (InputError, one line)."""
    start = _real("--start", start, "an amplitude >= 0")
    _amplitude_ok(scene, "--start", start)
    if isinstance(times, str | bytes) or not hasattr(times, "__iter__"):
        raise validate.InputError(f"--times {times!r}: not a list of times; allowed: times > 0 "
                                  "in increasing order, e.g. [10, 20, 40]")
    allowed = "times > 0 in increasing order"
    t = tuple(_real("--times", x, allowed) for x in times)
    if not t:
        raise validate.InputError("--times: empty; allowed: times > 0 in increasing order")
    if not all(math.isfinite(x) for x in t):
        raise validate.InputError(f"--times {','.join(f'{x:g}' for x in t)}: not finite; "
                                  "allowed: finite times > 0 in increasing order")
    if min(t) <= 0:
        raise validate.InputError(f"--times: {min(t):g} is not > 0; allowed: times > 0 in "
                                  "increasing order (t = 0 is the start itself)")
    if any(b <= a for a, b in zip(t, t[1:], strict=False)):
        raise validate.InputError(f"--times {','.join(f'{x:g}' for x in t)}: not increasing; "
                                  "allowed: times > 0 in strictly increasing order")
    dt = scene.montecarlo.dt
    if isinstance(dt, int | float):  # the simulation snapshots at whole steps: say so, no move
        for x in t:
            k = round(x / dt)
            if k < 1 or abs(k * dt - x) > 1e-9 * x:
                near = ", ".join(f"{v:g}" for v in sorted({max(k, 1) * dt, (max(k, 1) + 1) * dt}))
                raise validate.InputError(
                    f"--times: {x:g} is not a whole number of steps of dt = {dt:g} (the "
                    f"simulation takes its snapshots at whole steps); nearest valid: {near}")


def _cores(scene: Any) -> int:
    return scene.montecarlo.threads or min(validate.numba_threads_available(),
                                           os.cpu_count() or 1)


def _out(args: argparse.Namespace, scene: Any, suffix: str) -> str:
    from vifpk.core.provenance import folder_name

    out = args.out or f"out/{folder_name(scene.name)}-{suffix}"
    if args.out is None:
        validate.output_folder(out, "--out (default)", replaced=True)
    return out


def _print(res: Any, files: dict[str, Any], as_json: bool) -> None:
    if as_json:
        from vifpk.core.io import jsonable

        doc = {k: v for k, v in res.metrics.items() if k not in ("R",)}
        print(json.dumps(jsonable(doc), indent=1, allow_nan=False))
        return
    for v in res.verdicts:
        print(v)
    if getattr(res, "recommendation", ""):
        print(res.recommendation)
    for w in res.warnings:
        print(f"warning: {w}")
    print(f"report: {files['report.html']}")


def cmd_passage(args: argparse.Namespace) -> int:
    from vifpk.harness.cli.options import _provenance
    from vifpk.harness.outputs import outdir
    from vifpk.harness.outputs.timereport import PASSAGE_FILES, write_time_report
    from vifpk.harness.workflows.passage import passage, run_seconds

    scene = check_passage(args)
    models = _models(args, scene)
    out = _out(args, scene, f"passage-{args.threshold:g}")
    prov = _provenance(args)

    def price(p: dict[str, Any]) -> None:
        what = (f"--threshold {args.threshold:g}: the averaged models put the MFPT at up to "
                f"{p['largest_model_mfpt']:.3g} time units, so the first-passage Monte Carlo "
                f"({p['paths']} paths to a horizon of {p['horizon']:.3g}, dt "
                f"{p['dt']:g}) is out of reach as a direct simulation (rare events need "
                "another method: --method splitting)")
        runs = 1 + len(models)
        try:
            cost.refuse_costly(lambda sp: run_seconds(
                p, runs, sp or cost.MC_STEPS_PER_CORE, _cores(scene)), what, args.yes)
        except validate.InputError as exc:
            if args.method != "auto":
                raise
            raise _Splitting(f"chosen automatically: {exc}") from None

    if args.method == "splitting":
        return _splitting(args, scene, models, out, prov, "asked for (--method splitting)")
    if args.method == "auto" and not args.yes:  # priced up front by the quadrature alone,
        from vifpk.harness.door import (
            solvers,
            timedomain,  # before any R(t) stepping (slow, and fragile, at high thresholds)
        )
        from vifpk.harness.workflows.passage import plan

        try:
            mf = {m: float(timedomain.mfpt_averaged(scene, m, threshold=args.threshold,
                                             start=args.start)["value"])
                  for m in registry.applicable(scene, models)[0]}
            price(plan(scene, mf, paths=args.paths, horizon=args.horizon))
        except solvers.SolverFailure:
            pass  # the workflow below meets it again and says so
        except _Splitting as why:
            return _splitting(args, scene, models, out, prov, str(why))

    try:
        with outdir.hold(out, run_id=prov["run_id"], allowed=PASSAGE_FILES,
                         kind="passage report"):
            with cost.guarded_run(scene, args.yes):
                res = passage(scene, threshold=args.threshold, start=args.start,
                              models=models, horizon=args.horizon, paths=args.paths,
                              quiet=args.quiet, price=price)
            _finite(res.metrics)
            files = write_time_report(res, out, prov=prov)
    except _Splitting as why:  # raised by the guard before any Monte Carlo or file
        return _splitting(args, scene, models, out, prov, str(why))
    _print(res, files, args.json)
    return 0


class _Splitting(Exception):
    """Direct simulation is priced beyond the guard: --method auto turns to splitting."""


def _splitting(args: argparse.Namespace, scene: Any, models: tuple[str, ...], out: str,
               prov: dict[str, Any], reason: str) -> int:
    """vifpk passage --method splitting (harness/workflows/rarepassage.py): the MFPT only."""
    from vifpk.harness.outputs import outdir
    from vifpk.harness.outputs.timereport import PASSAGE_FILES
    from vifpk.harness.workflows.rarepassage import passage_splitting_report

    print(f"method: splitting ({reason})")
    with outdir.hold(out, run_id=prov["run_id"], allowed=PASSAGE_FILES, kind="passage report"):
        met = passage_splitting_report(scene, threshold=args.threshold, start=args.start,
                                       models=models, out=out, prov=prov, reason=reason)
        _finite(met)
    o = met["mfpt"]["original_system"]
    if args.json:
        print(json.dumps({"mfpt": met["mfpt"], "method": "splitting"}))
    else:
        print(f"original system: MFPT {o['value']:.4g} +- {o['stderr']:.2g} "
              f"(95%: {o['ci'][0]:.4g} to {o['ci'][1]:.4g}; {met['splitting']['target']})")
        for m, e in met["models"].items():
            print(f"{m} model: MFPT {e['mfpt']:.4g}, relative error "
                  f"{e['mfpt_error']['value']:+.3f} +- {e['mfpt_error']['err']:.3f}")
    print(f"report: {Path(out) / 'report.md'}")
    return 0


def cmd_transient(args: argparse.Namespace) -> int:
    from vifpk.harness.cli.options import _provenance
    from vifpk.harness.outputs import outdir
    from vifpk.harness.outputs.timereport import TRANSIENT_FILES, write_time_report
    from vifpk.harness.workflows.transient import transient

    scene = check_transient(args)
    models = _models(args, scene)
    runs = 1 + len(models)
    dt = float(scene.montecarlo.dt)
    steps = (args.paths or scene.montecarlo.paths) * max(args.times) / dt
    cost.refuse_costly(lambda sp: runs * steps / ((sp or cost.MC_STEPS_PER_CORE)
                                                      * _cores(scene)),
                           f"this transient ({runs} Monte Carlo runs to t = {max(args.times):g})",
                           args.yes)
    out = _out(args, scene, f"transient-{args.start:g}")
    prov = _provenance(args)
    with outdir.hold(out, run_id=prov["run_id"], allowed=TRANSIENT_FILES,
                     kind="transient report"):
        with cost.guarded_run(scene, args.yes):
            res = transient(scene, start=args.start, times=args.times, models=models,
                            paths=args.paths, quiet=args.quiet)
        _finite(res.metrics)
        files = write_time_report(res, out, prov=prov)
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


def _common(p: argparse.ArgumentParser) -> None:
    """The options passage and transient share."""
    from vifpk.harness.cli.options import (
        _dt_value,
        _model_name,
        _whole_number,
        add_quiet,
        add_scene,
        add_set,
    )

    add_scene(p)
    p.add_argument("--model", action="append", type=_model_name, metavar="NAME",
                   help="an averaged model, any registered one (repeat for several; "
                        f"default: {', '.join(CHECK_MODELS)}, without paper outside its "
                        "family)")
    p.add_argument("--out", metavar="DIR",
                   help="report directory (default: out/<scene>-<command>-<value>)")
    p.add_argument("--json", action="store_true",
                   help="print metrics.json's results on stdout instead of the verdicts "
                        "(default: off; the report is written either way)")
    add_set(p)
    add_quiet(p)
    p.add_argument("--paths", type=_whole_number, metavar="N",
                   help="Monte Carlo: paths of each run, a whole multiple of "
                        "montecarlo.blocks (default: the scene's montecarlo.paths)")
    p.add_argument("--dt", type=_dt_value, metavar="H",
                   help="Monte Carlo: time step (default: the scene's montecarlo.dt)")
    p.add_argument("--seed", type=_whole_number, metavar="S",
                   help="Monte Carlo: root seed; each model's averaged SDE gets a seed "
                        "of S and the model's name alone, as in check (default: the "
                        "scene's montecarlo.seed)")
    p.add_argument("--yes", action="store_true",
                   help="run even when the estimated cost exceeds an hour (default: off)")


def passage_arguments(p: argparse.ArgumentParser) -> None:
    """``vifpk passage``'s options."""
    _common(p)
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
    p.add_argument("--horizon", type=_number, metavar="T",
                   help="Monte Carlo censoring horizon (default: "
                        "8 x the largest averaged-model MFPT)")


def transient_arguments(t: argparse.ArgumentParser) -> None:
    """``vifpk transient``'s options."""
    _common(t)
    t.add_argument("--start", type=_number, required=True, metavar="A0",
                   help="start amplitude (energy U(A0), phase uniform in time along that "
                        "orbit, noise from its stationary law); required")
    t.add_argument("--times", type=_times, required=True, metavar="t1,t2,...",
                   help="snapshot times > 0, increasing; required")
