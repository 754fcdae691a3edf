"""A sweep's folder and its records: ``DIR/points/<key>.json`` written atomically per point;
a record whose fingerprint matches is a finished point and a sweep started again skips it.
Also the sweep's price (``sweep_seconds``) and the message when a run stops early.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vifpk.harness.sweeps.errors import SweepError
from vifpk.harness.sweeps.points import Job, Point, Sweep

from vifpk.core.defaults import BIFURCATION_MODELS, CHECK_MODELS
from vifpk.core.scene import Scene, SceneError


# --------------------------------------------------------------------------------------------
def load_record(path: Path) -> dict[str, Any] | None:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def record_name(key: str, stage: int = 0) -> str:
    """A point's record file in DIR/points: ``KEY.json``, and ``KEY.ext<k>.json`` for the
    k-th extension of its Monte Carlo (band sweeps)."""
    return f"{key}.json" if stage == 0 else f"{key}.ext{stage}.json"


def state_name(key: str, stage: int = 0) -> str:
    """Where a band sweep keeps a point's Monte Carlo checkpoint after ``stage``."""
    return f"{key}.state{stage}.npz"


def stage_fingerprint(fingerprint: str, stage: int) -> str:
    """The fingerprint of a point's k-th extension: the point's, and k."""
    return fingerprint if stage == 0 else f"{fingerprint}+ext{stage}"


def finished(sweep: Sweep, out: Path) -> dict[str, dict[str, Any]]:
    """Records of this sweep's points already on disk (matching fingerprints), by key.

    A numerical failure is a result (the same point fails the same way again) and counts as
    finished; a point that failed with any other error (a bug, a missing library) is retried.
    """
    done = {}
    for pt in sweep.points:
        rec = load_record(out / "points" / f"{pt.key}.json")
        if rec and rec.get("fingerprint") == pt.fingerprint and (
                rec.get("status") == "ok" or rec.get("failure") == "numerical"):
            done[pt.key] = rec
    return done


def _job(sweep: Sweep, pt: Point) -> Job:
    return Job(key=pt.key, fingerprint=pt.fingerprint, params=pt.params, seed=pt.seed,
               workflow=sweep.workflow, scene=pt.scene, bifurcation=sweep.bifurcation,
               sde=pt.sde, models=sweep.models, tolerance=sweep.tolerance,
               tolerance_question=sweep.tolerance_question)


def adaptive_point(sweep: Sweep, unit: Any, *, first: bool) -> Point:
    """The point of an adaptive sweep at unit coordinates ``unit`` (spec.adaptive_params); the
    sweep's first point as load_sweep built it (it runs the averaged SDEs' check)."""
    from vifpk.harness.sweeps.points import make_point
    from vifpk.harness.sweeps.spec import adaptive_params

    if first:
        return sweep.points[0]
    return make_point(sweep.base, sweep.fixed, seed=sweep.seed, workflow=sweep.workflow,
                      bifurcation=sweep.bifurcation, params=adaptive_params(sweep.vary, unit),
                      where=sweep.name, models=sweep.models, tolerance=_tolerance(sweep))


def _tolerance(sweep: Sweep) -> Any:
    """The sweep's tolerance question as a harness.request.tolerance.Tolerance."""
    from vifpk.harness.request.tolerance import Tolerance

    metric, observable, confidence = sweep.tolerance_question
    return Tolerance(value=sweep.tolerance, metric=metric, observable=observable,
                     confidence=confidence)


@dataclass(frozen=True, kw_only=True)
class SweepRun:
    """What a run of a sweep did: the keys it computed (in order), skipped and failed."""

    total: int
    computed: tuple[str, ...]
    skipped: int
    failed: tuple[str, ...]
    seconds: float
    files: Mapping[str, Path]


def _log(quiet: bool, text: str) -> None:
    if not quiet:
        print(text, file=sys.stderr, flush=True)


#: what a sweep writes into its folder (outdir.KINDS["sweep"] tells such a folder apart)
SWEEP_FILES = {"points": "folder", "sweep.nc": "file", "report.html": "file"}


def check_sweep_folder(out: str | Path) -> Path:
    """Refuse, before any work, an output folder a sweep cannot use: a file; a folder holding
    another kind of output (a check report) or foreign files; ``points`` that is not a folder,
    ``sweep.nc`` or ``report.html`` that are not files (SweepError naming them)."""
    from vifpk.harness.outputs import outdir

    target = outdir.resolve(out)
    try:
        outdir.check_replaceable(target, set(SWEEP_FILES), "sweep")
    except SceneError as exc:
        raise SweepError(f"--out {exc}") from None
    for name, what in SWEEP_FILES.items():
        p = target / name
        if p.is_symlink() or (p.exists() and (p.is_dir() != (what == "folder"))):
            raise SweepError(f"--out {out}: {name} exists and is not a {what}; a sweep writes "
                             f"its {'point records' if what == 'folder' else name} there; "
                             "move it away or choose another --out")
    return target


def sweep_seconds(sweep: Sweep, *, speed: float | None = None) -> float:
    """Lower bound of the wall time of the sweep's points on this machine (validate.py's
    estimates: a check point is its Monte Carlo and closed forms, an averaging point its
    closed forms, a bifurcation point its Monte Carlo checks (two per model) or, without
    them, ~20 closed-form evaluations per model). Local executors share the same cores, so
    the points' times add up; a remote cluster may be faster (confirm with --yes)."""
    from vifpk.harness.request import cost
    from vifpk.harness.workflows.check import models_of

    wanted = sweep.models or (BIFURCATION_MODELS if sweep.workflow == "bifurcation"
                              else CHECK_MODELS)
    total = 0.0
    seen: dict[Any, float] = {}

    def mc_seconds(sc: Scene) -> float:
        # with a fixed step the estimate depends on [montecarlo] and omega0 only
        key = ((sc.montecarlo, sc.system.restoring_law[0]) if sc.montecarlo.dt != "auto"
               else None)  # k1 = omega0^2
        if key is None or key not in seen:
            value = cost.montecarlo_seconds(sc, speed=speed)
            if key is None:
                return value
            seen[key] = value
        return seen[key]

    for pt in sweep.points:
        sc = pt.scene
        models = models_of(sc, wanted)[0]
        closed = sum(cost.averaging_seconds(sc, m) for m in models)
        if sweep.workflow == "check":
            total += mc_seconds(sc) + closed
        elif sweep.workflow in ("passage", "transient"):
            total += closed  # the Monte Carlo is priced at the point, from the models' MFPT
        elif sweep.workflow == "averaging":
            total += closed
        elif sweep.bifurcation.get("mc"):
            total += 4 * mc_seconds(sc) + 20 * closed
        else:
            total += 20 * closed
    if sweep.mode == "adaptive" and sweep.points:  # the lattice stands for the whole budget
        total *= max(sweep.adaptive["points"] / len(sweep.points), 1.0)
    return total


def sweep_size(sweep: Sweep) -> str:
    """The points a sweep is priced for, in words: '81 points', or for an adaptive sweep
    '100000 points: 81 initial, the rest adaptive' (sweep_seconds prices the whole budget)."""
    n = len(sweep.points)
    if sweep.mode == "adaptive":
        total = max(int(sweep.adaptive["points"]), n)
        return f"{total} points: {n} initial, the rest adaptive"
    return f"{n} points"


def _clear_temporaries(out: Path) -> None:
    """Remove the temporary files of killed atomic writes (call with the folder held)."""
    for folder in (out, out / "points"):
        if folder.is_dir():
            for p in folder.glob(".*.tmp*"):  # io._temp_beside: .NAME.<hex>.tmp<suffix>
                p.unlink(missing_ok=True)


def _kept_message(out: Path, done: int, computed: list[str], todo: int | None) -> str:
    """The Ctrl-C line. ``todo``: the points this run had to compute; None for a band sweep,
    whose records are runs (a point's extensions too) and whose rest is not a count of points
    until the budget is spent (issue 39: it read "compute the other -7")."""
    n = done + len(computed)
    if n == 0:
        return "vifpk: interrupted; no point had finished, nothing was kept"
    if todo is None:
        return (f"vifpk: interrupted; {n} finished Monte Carlo run{'s' if n != 1 else ''} "
                f"({len(computed)} from this run) kept in {out / 'points'}; no sweep.nc "
                "written; run the same command again to continue (the kept runs are reused)")
    rest = todo - len(computed)
    return (f"vifpk: interrupted; {n} finished point{'s' if n != 1 else ''} "
            f"({len(computed)} from this run) kept in {out / 'points'}; no sweep.nc written; "
            f"run the same command again to compute the other {rest}")
