"""Running a sweep: every point of a grid (``run_sweep``), or an adaptive design refined in
batches where the models' verdict changes (``run_adaptive``; geometry in ``adaptive``), then
sweep.nc, the maps and the report (``dataset``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from vifpk.harness.sweeps.dataset import write_results
from vifpk.harness.sweeps.errors import OverTime, _duration, check_rate  # noqa: F401
from vifpk.harness.sweeps.executors import (
    ExecutorSpec,
    Runner,
    parse_executor,
    require_output_libraries,
)
from vifpk.harness.sweeps.points import Point, Sweep
from vifpk.harness.sweeps.store import (
    SWEEP_FILES,
    SweepRun,
    _clear_temporaries,
    _job,
    _kept_message,
    _log,
    adaptive_point,
    check_sweep_folder,
    finished,
    load_record,
)


def run_sweep(sweep: Sweep, out: str | Path, *, executor: str | ExecutorSpec = "serial",
              quiet: bool = False, report: bool = True,
              provenance: Mapping[str, Any] | None = None,
              time_limit: float | None = None) -> SweepRun:
    """Compute every unfinished point on the executor, then write sweep.nc (and the maps).

    ``time_limit`` (seconds; the command line's hour without ``--yes``, None: no limit): the
    estimate made before the run is a lower bound, so the run checks it against its own
    measured rate (:func:`check_rate`) and stops with OverTime, the records kept, when the
    projected wall time is over the limit.

    The folder is held for the whole run with the lock of every vifpk output folder
    (harness/outputs/outdir.py): a second run into it is refused; a folder holding another kind of
    output is refused (:func:`check_sweep_folder`). Raises SweepError (bad folder or executor,
    unreachable scheduler) before anything is computed or written. Ctrl-C or SIGTERM stop the
    workers and keep every record written so far (``signals.message()`` says how many).
    """
    from vifpk.harness.outputs import outdir, signals

    from vifpk.core.provenance import new_run_id

    spec = parse_executor(executor) if isinstance(executor, str) else executor
    require_output_libraries()
    target = check_sweep_folder(out)
    run_id = str((provenance or {}).get("run_id") or new_run_id())
    with outdir.hold(target, run_id=run_id, allowed=set(SWEEP_FILES), kind="sweep"):
        _clear_temporaries(target)
        if sweep.mode == "adaptive" and sweep.adaptive.get("method") == "band":
            from vifpk.harness.sweeps.bandrun import run_band

            return run_band(sweep, out, executor=spec, quiet=quiet, report=report,
                            provenance=provenance, time_limit=time_limit)
        if sweep.mode == "adaptive":
            return run_adaptive(sweep, out, executor=spec, quiet=quiet, report=report,
                                provenance=provenance, time_limit=time_limit)
        return _run_held(sweep, Path(out), spec, quiet=quiet, report=report,
                         provenance=provenance, signals=signals, time_limit=time_limit)


def _run_held(sweep: Sweep, out: Path, spec: ExecutorSpec, *, quiet: bool, report: bool,
              provenance: Mapping[str, Any] | None, signals: Any,
              time_limit: float | None = None) -> SweepRun:
    from vifpk.core.io import write_json

    done = finished(sweep, out)
    todo = [pt for pt in sweep.points if pt.key not in done]
    total = len(sweep.points)
    computed: list[str] = []
    signals.set_message(lambda: _kept_message(out, len(done), computed, len(todo)))
    runner = Runner(spec) if todo else None  # connects (or fails) before anything is written
    t0 = time.perf_counter()
    failed = [k for k, r in done.items() if r["status"] == "failed"]
    by_key = {pt.key: pt for pt in sweep.points}
    _log(quiet, f"sweep {sweep.name}: {total} points ({len(done)} done before, {len(todo)} to "
                f"compute) on {spec}, workflow {sweep.workflow}")
    handle = signals.on_interrupt(runner.stop) if runner is not None else None
    if spec.kind in ("dask", "tcp"):
        signals.set_grace(20.0)  # closing a client or a local cluster takes seconds
    made = [f for f in (out, out / "points") if not f.exists()]  # removed again if empty
    try:
        if runner is not None:
            (out / "points").mkdir(parents=True, exist_ok=True)
            for rec in runner.completed([_job(sweep, pt) for pt in todo]):
                write_json(out / "points" / f"{rec['key']}.json", rec)
                computed.append(rec["key"])
                if rec["status"] == "failed":
                    failed.append(rec["key"])
                n = len(computed)
                elapsed = time.perf_counter() - t0
                eta = elapsed / n * (len(todo) - n)
                what = "ok" if rec["status"] == "ok" else f"FAILED: {rec['message']}"
                _log(quiet, f"[{len(done) + n}/{total}] {by_key[rec['key']].label()}: {what} "
                            f"({rec['seconds']:.1f} s); failures {len(failed)}; "
                            f"ETA {_duration(eta)}")
                check_rate(elapsed, n, len(todo) - n, workers=spec.workers, limit=time_limit,
                           out=out)
    except (KeyboardInterrupt, OverTime):  # Ctrl-C, SIGTERM: the message says what was kept
        if runner is not None:
            runner.stop()  # no worker outlives the sweep
        _remove_empty(made)  # "nothing was kept": no empty out/ and out/points/ (issue 45)
        raise
    finally:
        if handle is not None:
            signals.forget(handle)
        if runner is not None:
            runner.close()
    files = write_results(sweep, out, executor=str(spec), report=report, provenance=provenance)
    return SweepRun(total=total, computed=tuple(computed), skipped=len(done),
                    failed=tuple(failed), seconds=time.perf_counter() - t0, files=files)


def _remove_empty(made: list[Path]) -> None:
    """Remove the folders this run made (``made``, outermost first) that are still empty."""
    for folder in reversed(made):
        try:
            folder.rmdir()  # only an empty folder
        except OSError:
            pass


def _reusable(rec: dict[str, Any] | None, pt: Point) -> bool:
    """A record on disk is this point's finished result (see ``finished``)."""
    return bool(rec and rec.get("fingerprint") == pt.fingerprint and (
        rec.get("status") == "ok" or rec.get("failure") == "numerical"))


def adaptive_value(rec: dict[str, Any], model: str) -> float:
    """f = log(L1 / (2 floor)) of ``model`` at a finished point (NaN for a failed one)."""
    from vifpk.harness.sweeps.adaptive import log_ratio

    m = (rec.get("result") or {}).get("models", {}).get(model, {})
    return log_ratio(m.get("averaging_error_A"), m.get("L1_floor_A"))


def run_adaptive(sweep: Sweep, out: str | Path, *, executor: ExecutorSpec,
                 quiet: bool = False, report: bool = True,
                 provenance: Mapping[str, Any] | None = None,
                 time_limit: float | None = None) -> SweepRun:
    """An adaptive sweep (mode = "adaptive"): the initial lattice, then batches of
    ``[adaptive] batch`` points chosen by harness.sweeps.adaptive from every finished point, until
    ``[adaptive] points`` or the resolution is reached; then sweep.nc (a ``point`` dimension)
    and the maps.

    The batches are replayed from the records on disk: a point with a record is not computed
    again, and since the choice of a batch depends only on the points before it and their
    results, a sweep started again (after Ctrl-C, a lost machine) chooses the same points and
    computes only those without a record. Progress and ETA on stderr, one line a point.
    """
    from dataclasses import replace

    from vifpk.harness.sweeps.adaptive import next_batch

    from vifpk.core.io import write_json

    require_output_libraries()
    out = Path(out)
    ad = sweep.adaptive
    budget, size, model = ad["points"], ad["batch"], ad["model"]
    if executor.kind in ("processes", "dask") and executor.workers > size:
        _log(quiet, f"note: {executor} has {executor.workers} workers but [adaptive] batch = "
                    f"{size}; set batch >= the workers to keep them busy (the batch size "
                    "chooses the points, the executor does not)")
    from vifpk.harness.outputs import signals

    runner = Runner(executor)  # connects (or fails) before anything is written
    handle = signals.on_interrupt(runner.stop)
    t0 = time.perf_counter()
    order: list[Point] = []
    units: list[tuple[float, ...]] = []
    values: list[float] = []
    computed: list[str] = []
    failed: list[str] = []
    skipped = 0
    spent = 0.0  # seconds of the points computed in this run (for the ETA)
    _log(quiet, f"sweep {sweep.name}: adaptive, up to {budget} points in batches of {size} on "
                f"{executor}, refining the {model} model's verdict (L1 < 2 x floor)")
    from vifpk.harness.sweeps.adaptive import initial_design

    batch_units = initial_design(len(sweep.vary), budget)
    batch_no = 0
    signals.set_message(lambda: _kept_message(out, skipped, computed, budget - skipped))
    try:
        while batch_units:
            pts = []
            for u in batch_units:
                pt = adaptive_point(sweep, u, first=not order and not pts)
                pts.append(replace(pt, batch=batch_no))
            recs: dict[str, dict[str, Any]] = {}
            todo = []
            for pt in pts:
                rec = load_record(out / "points" / f"{pt.key}.json")
                if _reusable(rec, pt):
                    recs[pt.key] = rec
                    skipped += 1
                    if rec["status"] == "failed":
                        failed.append(pt.key)
                else:
                    todo.append(pt)
            if todo:
                (out / "points").mkdir(parents=True, exist_ok=True)
                by_key = {pt.key: pt for pt in todo}
                for rec in runner.completed([_job(sweep, pt) for pt in todo]):
                    write_json(out / "points" / f"{rec['key']}.json", rec)
                    recs[rec["key"]] = rec
                    computed.append(rec["key"])
                    spent = time.perf_counter() - t0
                    if rec["status"] == "failed":
                        failed.append(rec["key"])
                    n = len(order) + len(recs)
                    # every remaining point costs what the computed ones did on average
                    eta = spent / len(computed) * max(budget - n, 0)
                    what = "ok" if rec["status"] == "ok" else f"FAILED: {rec['message']}"
                    f = adaptive_value(rec, model)
                    verdict = "" if math.isnan(f) else (
                        f"; {model} {'within' if f < 0 else 'outside'} the noise "
                        f"(L1 / 2 floor = {math.exp(f):.2f})")
                    _log(quiet, f"[{n}/{budget}] batch {batch_no}: {by_key[rec['key']].label()}"
                                f": {what}{verdict} ({rec['seconds']:.1f} s); failures "
                                f"{len(failed)}; ETA {_duration(eta)}")
                    check_rate(spent, len(computed), max(budget - n, 0),
                               workers=executor.workers, limit=time_limit, out=out)
            for pt, u in zip(pts, batch_units, strict=True):
                order.append(pt)
                units.append(tuple(u))
                values.append(adaptive_value(recs[pt.key], model))
            if len(order) >= budget:
                break
            batch_no += 1
            batch_units = next_batch(units, values, min(size, budget - len(order)),
                                     resolution=ad["resolution"])
            if not batch_units:
                _log(quiet, f"every triangle is finer than the resolution "
                            f"({ad['resolution']} x {ad['resolution']}): stopped at "
                            f"{len(order)} points")
    except (KeyboardInterrupt, OverTime):  # stop the workers; the message says why
        runner.stop()
        raise
    finally:
        signals.forget(handle)
        runner.close()
    done = replace(sweep, points=tuple(order))
    files = write_results(done, out, executor=str(executor), report=report,
                          provenance=provenance)
    return SweepRun(total=len(order), computed=tuple(computed), skipped=skipped,
                    failed=tuple(failed), seconds=time.perf_counter() - t0, files=files)
