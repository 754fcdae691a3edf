"""Running a band sweep (``mode = "adaptive"`` with a tolerance, ``[adaptive] method =
"band"``): the initial lattice, then batches of new points and of extensions of the points'
Monte Carlo runs chosen by band.py from the error surface of the points so far, until the
budget is spent; then sweep.nc and the maps (dataset.py) from each point's last record.

**The budget.** ``[adaptive] points = N`` buys the Monte Carlo of N points: N times the median
path-steps of the initial lattice's points. A new point costs its path-steps, an extension
those of its continued run (its sampled windows again, about), so the sweep ends at about the
CPU time of N plain points, spent where the band is.

**Records and resume.** A point's first run is ``points/KEY.json``, its k-th extension
``points/KEY.ext<k>.json`` (the fingerprint of the point and k), and where its Monte Carlo
stopped ``points/KEY.state<k>.npz`` (montecarlo/checkpoint.py; the last one only). A batch is a
pure function of the records before it, so a sweep started again replays the same batches
from the records, computes only what has none, and continues an extension from the state file
its previous stage left. The surfaces are fitted in the main process with BLAS on one thread:
the same points, floors and numbers on every executor.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from vifpk.harness.sweeps.errors import OverTime, SweepError, _duration, check_rate
from vifpk.harness.sweeps.executors import ExecutorSpec, Runner, require_output_libraries
from vifpk.harness.sweeps.points import Point, Sweep
from vifpk.harness.sweeps.store import (
    SweepRun,
    _job,
    _kept_message,
    _log,
    adaptive_point,
    load_record,
    record_name,
    stage_fingerprint,
    state_name,
)


def run_band(sweep: Sweep, out: str | Path, *, executor: ExecutorSpec, quiet: bool = False,
             report: bool = True, provenance: Mapping[str, Any] | None = None,
             time_limit: float | None = None) -> SweepRun:
    """A band sweep (module docstring); progress on stderr, one line a point and a batch."""
    from vifpk.harness.outputs import signals
    from vifpk.harness.sweeps.adaptive import initial_design
    from vifpk.harness.sweeps.dataset import write_results

    from vifpk.core.io import write_json

    require_output_libraries()
    out = Path(out)
    conflict = resume_conflict(out, sweep.tolerance)
    if conflict:
        raise SweepError(conflict)
    ad = sweep.adaptive
    n_budget, size, model = ad["points"], ad["batch"], ad["model"]
    runner = Runner(executor)
    handle = signals.on_interrupt(runner.stop)
    t0 = time.perf_counter()
    st = _State(sweep, model)
    computed: list[str] = []
    failed: list[str] = []
    skipped = 0
    _log(quiet, f"sweep {sweep.name}: band refiner, the Monte Carlo of {n_budget} points in "
                f"batches of {size} on {executor}: shrinking the band of P({model} L1(A) <= "
                f"{sweep.tolerance:g}) between 5% and 95%")
    actions: list[tuple[tuple[float, ...], str | None]] = [
        (u, None) for u in initial_design(len(sweep.vary), n_budget)]
    batch_no = 0
    signals.set_message(lambda: _kept_message(out, skipped, computed, None))
    try:
        while actions:
            jobs, reused = [], []
            for unit, key in actions:
                rec, job = st.prepare(unit, key, batch_no, out)
                if rec is not None:
                    reused.append(rec)
                else:
                    jobs.append(job)
            skipped += len(reused)
            for note in st.notes:
                _log(quiet, note)
            st.notes.clear()
            for rec in reused:
                st.take(rec)
            if jobs:
                (out / "points").mkdir(parents=True, exist_ok=True)
                for rec in runner.completed(jobs):
                    _store(out, rec, write_json, sweep.tolerance)
                    computed.append(f"{rec['key']}:{rec.get('stage', 0)}")
                    if rec["status"] == "failed":
                        failed.append(rec["key"])
                    st.take(rec)
                    elapsed = time.perf_counter() - t0
                    left = st.left(n_budget)
                    _log(quiet, f"[{st.used(n_budget)}] batch {batch_no}: "
                                f"{st.describe(rec)} ({rec['seconds']:.1f} s); failures "
                                f"{len(failed)}; ETA {_duration(elapsed / len(computed) * left)}"
                         if computed else "")
                    check_rate(elapsed, len(computed), int(math.ceil(left)),
                               workers=executor.workers, limit=time_limit, out=out)
            if batch_no == 0:
                st.lattice_done()
            if st.spent >= st.budget(n_budget):
                break
            batch_no += 1
            actions = st.next_actions(size, n_budget)
            _log(quiet, st.summary(batch_no, actions))
    except (KeyboardInterrupt, OverTime):
        runner.stop()
        raise
    finally:
        signals.forget(handle)
        runner.close()
    over = overspent(st.spent, st.unit_cost, n_budget)
    if over:
        _log(quiet, over)
    done = replace(sweep, points=tuple(st.points[k] for k in st.order))
    files = write_results(done, out, executor=str(executor), report=report,
                          provenance=provenance, stages=dict(st.stage))
    keys, skipped = point_counts(st.order, computed)
    return SweepRun(total=len(st.order), computed=keys, skipped=skipped,
                    failed=tuple(dict.fromkeys(failed)), seconds=time.perf_counter() - t0,
                    files=files)


def point_counts(order: list[str], computed: list[str]) -> tuple[tuple[str, ...], int]:
    """(the points this run computed, the points done before), in points: a point counts as
    computed when any of its runs ("KEY:STAGE") was, else as done before, so the two add up to
    the points (issue 39: runs were counted, "11 points: 6 computed, 7 done before")."""
    keys = tuple(dict.fromkeys(c.rpartition(":")[0] for c in computed))
    return keys, len(order) - len(keys)


def _store(out: Path, rec: dict[str, Any], write_json: Any, tolerance: float | None = None
           ) -> None:
    """The record, and its Monte Carlo's checkpoint as the point's only state file. The record
    keeps the checkpoint's sha256 (``state_sha256``: a resume uses only the file it names,
    B46-B49) and the sweep's tolerance (``tolerance``: a resume asking another refuses, B50).
    A write that fails (a full disk) is an OSError naming the file (B39: it read "cannot write
    the standard output")."""
    import hashlib

    from vifpk.core.io import atomic_path

    stage = int(rec.get("stage", 0))
    state = (rec.get("result") or {}).pop("state", None)
    if tolerance is not None:
        rec["tolerance"] = tolerance
    target = out / "points" / state_name(rec["key"], stage)
    try:
        if state is not None:
            rec["state_sha256"] = hashlib.sha256(state).hexdigest()
            with atomic_path(target) as tmp:
                Path(tmp).write_bytes(state)
        target = out / "points" / record_name(rec["key"], stage)
        write_json(target, rec)
    except OSError as exc:
        if exc.filename is None:
            raise OSError(exc.errno, exc.strerror or str(exc), str(target)) from exc
        raise
    if state is not None and stage > 0:
        (out / "points" / state_name(rec["key"], stage - 1)).unlink(missing_ok=True)


def _usable_state(path: Path, rec: dict[str, Any] | None) -> bytes | None:
    """The checkpoint a point's next extension continues from, or None when it cannot be used:
    missing (deleted, or removed when a later stage was stored and that stage's record is now
    unreadable), unreadable, or not the file the record names (``state_sha256``: truncated,
    or another run's). A record written before the hash was kept: any readable .npz archive."""
    import hashlib
    import io
    import zipfile

    try:
        data = path.read_bytes()
    except OSError:
        return None
    want = (rec or {}).get("state_sha256")
    if want is not None:
        return data if hashlib.sha256(data).hexdigest() == want else None
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            return data if z.testzip() is None and "meta.npy" in z.namelist() else None
    except (zipfile.BadZipFile, OSError, ValueError):
        return None


def resume_conflict(out: Path, tolerance: float) -> str | None:
    """One line when ``out``/points holds band records computed for another tolerance (issue
    39, B50: a resume with a changed tolerance continued silently in the same folder)."""
    from vifpk.harness.sweeps.store import load_record

    for p in sorted((out / "points").glob("*.json")) if (out / "points").is_dir() else ():
        rec = load_record(p)
        old = rec.get("tolerance") if isinstance(rec, dict) else None
        if isinstance(old, int | float) and old != tolerance:
            return (f"--out {out}: its points were computed for tolerance = {old:g}, this sweep "
                    f"asks tolerance = {tolerance:g}; a band sweep's choices depend on it: "
                    "give another --out, or delete that folder to start afresh")
    return None


def overspent(spent: float, unit_cost: float | None, n_points: int) -> str | None:
    """The line saying the Monte Carlo ended above its budget, and by how much (B43). The
    rule: a batch starts only while the spent path-steps are below N x unit_cost, and takes
    only actions whose predicted cost (a new point: the lattice's median; an extension: its
    previous run's sampled steps) fits in what is left, so the budget is exceeded only by the
    last batch's runs costing more than predicted."""
    if unit_cost is None or spent <= n_points * unit_cost:
        return None
    return (f"the Monte Carlo spent {spent / unit_cost:.1f} of the budget's {n_points} points "
            f"({100 * (spent / (n_points * unit_cost) - 1):.0f}% over): the last batch's runs "
            "cost more than predicted (docs/maps.md, the band sweep's budget)")


class _State:
    """The sweep so far: points in the order added, each one's latest record and stage, the
    path-steps spent, the surface of the last batch."""

    def __init__(self, sweep: Sweep, model: str):
        self.sweep, self.model = sweep, model
        self.order: list[str] = []
        self.points: dict[str, Point] = {}
        self.units: dict[str, tuple[float, ...]] = {}
        self.stage: dict[str, int] = {}
        self.recs: dict[str, dict[str, Any]] = {}
        self.spent = 0.0
        self.unit_cost: float | None = None  # median path-steps of the initial lattice
        self.new_err: float | None = None  # median error bar of the initial lattice
        self.surface: Any = None
        self.kernel: Any = None
        self.failed_extension: set[str] = set()
        self.notes: list[str] = []  # what a resume found and did instead (prepare)

    # -- one action -> a reusable record or a job
    def prepare(self, unit: tuple[float, ...], key: str | None, batch: int, out: Path
                ) -> tuple[dict[str, Any] | None, Any]:
        sweep = self.sweep
        if key is None:  # a new point
            pt = replace(adaptive_point(sweep, unit, first=not self.order), batch=batch)
            self.points[pt.key] = pt
            self.order.append(pt.key)
            self.units[pt.key] = unit
            self.stage[pt.key] = -1  # until its record is taken
            stage, scene, state = 0, pt.scene, None
        else:
            pt = self.points[key]
            stage = self.stage[key] + 1
            rec = self.recs[key]
            floor = rec["result"]["models"][self.model]["L1_floor_A"]
            from vifpk.harness.sweeps.band import EXTEND_VARIANCE

            target = floor * math.sqrt(EXTEND_VARIANCE)
            scene = pt.scene.with_values({"montecarlo.floor": target})
            state = None
        fp = stage_fingerprint(pt.fingerprint, stage)
        rec = load_record(out / "points" / record_name(pt.key, stage))
        if rec and rec.get("fingerprint") == fp and (
                rec.get("status") == "ok" or rec.get("failure") == "numerical"):
            return rec, None
        if stage > 0:
            path = out / "points" / state_name(pt.key, stage - 1)
            state = _usable_state(path, self.recs[key])
            if state is None:  # B46-B49: the extension's target floor, reached afresh
                self.notes.append(f"{pt.label()}: extension {stage}: the checkpoint "
                                  f"{path.name} is missing, unreadable or not this point's; "
                                  "its Monte Carlo runs afresh to the extension's floor")
        job = replace(_job(sweep, replace(pt, scene=scene)), fingerprint=fp, keep_state=True,
                      state=state, stage=stage, sde=pt.sde and stage == 0)
        return None, job

    def take(self, rec: dict[str, Any]) -> None:
        """A finished record. A failed extension leaves the point at its last good stage (its
        numbers and state file stay) and it is not extended again."""
        key, stage = rec["key"], int(rec.get("stage", 0))
        res = rec.get("result") or {}
        self.spent += float(res.get("mc_path_steps_run", 0.0))
        if stage > 0 and rec.get("status") != "ok":
            self.failed_extension.add(key)
            return
        self.stage[key] = stage
        self.recs[key] = rec

    # -- the budget
    def lattice_done(self) -> None:
        """The cost of a point and its error bar, from the initial lattice's points."""
        ok = [self.recs[k]["result"] for k in self.order
              if k in self.recs and self.recs[k]["status"] == "ok"]
        if not ok:
            return
        self.unit_cost = float(np.median([r["mc_path_steps"] for r in ok]))
        errs = [r["models"][self.model].get("error_estimate_err") for r in ok]
        errs = [e for e in errs if e is not None and math.isfinite(e)]
        self.new_err = float(np.median(errs)) if errs else math.nan

    def budget(self, n_points: int) -> float:
        return math.inf if self.unit_cost is None else n_points * self.unit_cost

    def left(self, n_points: int) -> float:
        """Points' worth of Monte Carlo still to spend (before the lattice is done: a point
        each for the rest of the budget)."""
        if self.unit_cost is None:
            return float(n_points - sum(1 for k in self.order if self.stage.get(k, -1) >= 0))
        return max(self.budget(n_points) - self.spent, 0.0) / self.unit_cost

    def used(self, n_points: int) -> str:
        if self.unit_cost is None:
            done = sum(1 for k in self.order if self.stage.get(k, -1) >= 0)
            return f"{done}/{len(self.order)} initial points"
        return (f"{self.spent / self.unit_cost:.1f}/{n_points} points' Monte Carlo, "
                f"{len(self.order)} points")

    def describe(self, rec: dict[str, Any]) -> str:
        pt = self.points[rec["key"]]
        what = "new" if int(rec.get("stage", 0)) == 0 else f"extension {rec['stage']}"
        if rec["status"] != "ok":
            return f"{pt.label()} ({what}): FAILED: {rec['message']}"
        m = rec["result"]["models"].get(self.model, {})
        est = m.get("error_estimate")
        if est is None:
            return f"{pt.label()} ({what}): ok"
        return (f"{pt.label()} ({what}): {self.model} error {est:.4f} +/- "
                f"{m.get('error_estimate_err', math.nan):.4f} (floor "
                f"{m.get('L1_floor_A', math.nan):.4f}), P(<= {self.sweep.tolerance:g}) = "
                f"{m.get('p_within_tolerance', math.nan):.2f}")

    # -- the next batch
    def next_actions(self, size: int, n_points: int
                     ) -> list[tuple[tuple[float, ...], str | None]]:
        from vifpk.harness.sweeps.band import MAX_STAGE, Candidate, choose, lattice
        from vifpk.harness.sweeps.surface import SurfaceError, axes_for, fit_surface

        keys = [k for k in self.order if self.recs.get(k, {}).get("status") == "ok"
                and self.recs[k]["result"]["models"].get(self.model, {}).get(
                    "error_estimate") is not None]
        if len(keys) < 3 or self.unit_cost is None:
            return []
        vals = [[self.recs[k]["result"]["models"][self.model][f] for k in keys]
                for f in ("error_estimate", "error_estimate_err")]
        x = np.array([[v for _, v in self.points[k].params] for k in keys], float)
        ranges = [r for _, r in self.sweep.vary]
        axes = axes_for(self.sweep.names, x.T, ranges=ranges)
        try:
            self.surface = fit_surface(x, vals[0], vals[1], tolerance=self.sweep.tolerance,
                                       axes=axes, start=self.kernel)
        except SurfaceError:
            return []
        self.kernel = self.surface._model.kernel
        have = set(self.units.values())
        cands = [Candidate(unit=u, cost=self.unit_cost)
                 for u in lattice(len(axes), self.sweep.adaptive["resolution"]) if u not in have]
        tau = {k: t for k, t in zip(keys, self.surface.log_noise_sd, strict=True)}
        for k in keys:
            res = self.recs[k]["result"]
            if (self.stage[k] < MAX_STAGE and math.isfinite(tau[k])
                    and k not in self.failed_extension):
                cands.append(Candidate(unit=self.units[k], key=k, noise_sd=float(tau[k]),
                                       cost=float(res["mc_sampled_steps"])))
        left = self.budget(n_points) - self.spent
        cands = [c for c in cands if c.cost <= left]  # B43: no run predicted to overrun
        if not cands:
            return []
        picked = choose(self.surface, cands, size, new_noise_sd=self.new_err, budget=left)
        return [(c.unit, c.key) for c in picked]

    def summary(self, batch: int, actions: list[tuple[tuple[float, ...], str | None]]) -> str:
        sf = self.surface
        if sf is None:
            return f"batch {batch}: no surface yet; stopping"
        new = sum(1 for _, k in actions if k is None)
        return (f"batch {batch}: band {100 * sf.band_area:.1f}% of the map, inside "
                f"{100 * sf.inside_area:.1f}%; next: {new} new points, {len(actions) - new} "
                "extensions" + ("" if actions else " (nothing shrinks the band: done)"))
