"""Transients: the law of the amplitude at given times from a start at amplitude A0, by each
averaged model (its FPK time-stepped, and its averaged SDE by Monte Carlo) against the Monte
Carlo of the original system started alike (energy U(A0), phase uniform in time along that
orbit, noise state from its stationary law: montecarlo.snapshots).

Per snapshot and model: L1 and KS of p(A, t) with error bars and noise floors
(harness/workflows/compare.py,
as check does for the stationary law), the class of the L1 as check's
(:func:`harness.workflows.verdict.observable_class`). Relaxation: each model's predicted relaxation
time (1 / the slowest decay rate of its FPK, fpk.transient) against the one measured on the original
system: the mean amplitude fitted by

    a(t) = a_inf + (A0 - a_inf) exp(-t / tau)            (a(0) = A0 exactly)

by weighted least squares on the snapshot means and their standard errors (scipy curve_fit,
absolute sigma; the error bar of tau from its covariance). The same fit on each model's FPK
snapshots gives the model's ``fitted`` tau, the like-with-like comparison (the mean need not
decay at the slowest rate alone).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from vifpk.harness.door import solvers, timedomain
from vifpk.harness.request.timedomain import MIN_FIT_TIMES  # the fit's fewest times (3)
from vifpk.harness.workflows import precision
from vifpk.harness.workflows.checkruns import sde_seed
from vifpk.harness.workflows.compare import compare
from vifpk.harness.workflows.passage import applicable, plain_info
from vifpk.harness.workflows.stages import Stages
from vifpk.harness.workflows.verdict import observable_class

from vifpk.core.defaults import CHECK_MODELS

EDGE_MARGIN = 1.1  # histogram edges 10% beyond the farthest amplitude any model reaches
TAIL = 1e-8  # a model "reaches" A while p(A, t) > TAIL x its peak at some snapshot


@dataclass(frozen=True)
class TransientResult:
    scene: Any
    start: float
    times: tuple[float, ...]
    models: tuple[str, ...]
    solutions: dict[str, Any]  # "fpk:M", "sde:M", "mc:original" -> Result
    metrics: dict[str, Any]
    warnings: list[str]
    verdicts: list[str]
    provenance: dict[str, Any] | None = None


def snapshot_bins(paths: int, most: int) -> int:
    """Bins of a snapshot histogram: Rice's rule 2 N^(1/3) for the N = ``paths`` samples a
    snapshot has (one a path), at least 10, at most the scene's montecarlo.bins. A stationary
    histogram pools many samples a path; a snapshot has one, so the scene's bins (100) would
    put its L1 noise floor near sqrt(2 bins / (pi N)): 0.25 at N = 1024."""
    return int(min(most, max(10, round(2.0 * paths ** (1.0 / 3.0)))))


def snapshot_edges(scene: Any, fpks: dict[str, Any], start: float, bins: int
                   ) -> dict[str, np.ndarray]:
    """Shared histogram edges: A on [0, 1.1 x the farthest amplitude any model's snapshots
    reach (or A0)], x1 on [-top or 0 with the barrier, top], x2 within +/- the speed at the
    energy U(top)."""
    top = start
    for r in fpks.values():
        s = r.data["snapshots"]
        x, P = np.asarray(s["x"], float), np.asarray(s["p"], float)
        for p in np.atleast_2d(P):
            reach = x[p > TAIL * np.max(p)] if np.max(p) > 0 else x[:1]
            top = max(top, float(reach[-1]))
    top *= EDGE_MARGIN
    v = math.sqrt(2.0 * float(solvers.potential_energy(scene, top)))
    lo = 0.0 if scene.system.barrier else -top
    return {"edges_A": np.linspace(0.0, top, bins + 1), "edges_x": np.linspace(lo, top, bins + 1),
            "edges_v": np.linspace(-v, v, bins + 1)}


def run(req: Any, *, quiet: bool = True, price: Any = None) -> TransientResult:
    """The workflow on a checked request (harness.request.timedomain.TransientRequest)."""
    return transient(req.scene, start=req.start, times=req.times, models=req.models,
                     paths=req.paths, sde=req.sde, quiet=quiet, price=price,
                     rel_se=req.rel_se, max_paths=req.max_paths)


def transient(scene: Any, *, start: float, times: tuple[float, ...],
              models: tuple[str, ...] = CHECK_MODELS, paths: int | None = None,
              sde: bool = True, quiet: bool = True, price: Any = None,
              rel_se: float | None = None, max_paths: int | None = None) -> TransientResult:
    """The transient cross-check (module docstring). ``price(edges)`` is called before any
    Monte Carlo and may raise (the CLI's cost guard). ``rel_se``: the original system's
    paths grow in units of ``paths`` (or the scene's) until the relative standard error of its
    relaxation time is at most ``rel_se``, or ``max_paths`` / the scene's budget is reached
    (harness/workflows/precision.py; None: exactly ``paths``); metrics["precision"] says
    which. The histogram grid is fixed by the first unit's paths (snapshot_bins)."""
    named, models, absent = applicable(scene, models)
    times = tuple(float(t) for t in times)
    stages = Stages(2 + len(models) * (1 + int(sde)), quiet)
    sol: dict[str, Any] = {}
    for m in models:
        stages(f"FPK of the {m} model (time stepping)")
        sol[f"fpk:{m}"] = timedomain.transient_averaged(scene, named[m], start=start, times=times)
    n = int(paths or scene.montecarlo.paths)
    edges = snapshot_edges(scene, {m: sol[f"fpk:{m}"] for m in models}, start,
                           snapshot_bins(n, scene.montecarlo.bins))
    if price is not None:
        price(n)
    stages("Monte Carlo of the original system (snapshots)")
    mc, prec = _original(scene, start=start, times=times, edges=edges, paths=n, rel_se=rel_se,
                         max_paths=max_paths, quiet=quiet)
    n = int(prec["paths"])
    sol["mc:original"] = mc
    hists = snapshot_hists(mc)
    for m in models if sde else ():
        stages(f"Monte Carlo of the {m} averaged SDE (snapshots)")
        sol[f"sde:{m}"] = timedomain.transient_sde(scene, named[m], start=start, times=times,
                                            edges_A=edges["edges_A"], paths=n,
                                            seed=sde_seed(scene.montecarlo.seed, m))
    stages("metrics")
    entries: dict[str, Any] = {}
    warnings: list[str] = precision.unmet(prec)
    measured = fit_relaxation(times, [mean_of(h) for h in hists], start)
    if measured is not None and not measured["err"] > 0:  # no error bar: not a measurement
        measured = None
        warnings.append("the original system's relaxation time has no error bar (its snapshot "
                        "means have none: each law sits in one or two bins of the shared "
                        "grid): NOT AN ESTIMATE, not reported")
    elif measured is not None and not (
            measured["value"] > measured["err"]):
        # an error bar as large as the value (one bar reaches tau <= 0) pins no time scale
        # (issue 45:
        # "3.232e+04 +/- 9.3e+08 (within the error bar: -99.9% +/- 1617.8%)" was printed as a
        # measurement): not reported, and the warning says what would pin it
        warnings.append(f"the original system's relaxation time is not measured: its fit gives "
                        f"{measured['value']:.4g} +/- {measured['err']:.2g}, an error bar as "
                        "large as the value (the "
                        "snapshot times do not resolve the decay: give times around the "
                        "models' relaxation times, or more paths): NOT AN ESTIMATE, not "
                        "reported")
        measured = None
    # a snapshot law narrower than a few bins of the shared grid has an L1 of ~0 whatever the
    # models say (all its mass in one or two bins): not a measurement
    occupied = [int(np.count_nonzero(np.asarray(h["p"]) > 0)) for h in hists]
    for k, t in enumerate(times):
        if occupied[k] < MIN_RESOLVED_BINS:
            warnings.append(f"the original system's law at t = {t:g} occupies {occupied[k]} of "
                            f"the shared grid's bins (fewer than {MIN_RESOLVED_BINS}): its "
                            "distances are not measured there (NOT AN ESTIMATE); give later "
                            "times, where the law has spread, or a start nearer the bulk")
    for m in models:
        fpk = sol[f"fpk:{m}"]
        smooth = fpk_snapshots(fpk)
        rows = []
        for k, t in enumerate(times):
            row: dict[str, Any] = {"t": t, "fpk": _metrics(compare(smooth[k], hists[k]))}
            if f"sde:{m}" in sol:
                sh = snapshot_hists(sol[f"sde:{m}"])[k]
                row["sde"] = _metrics(compare(sh, hists[k]))
                row["sampling"] = _metrics(compare(smooth[k], sh))
            row["class"] = (observable_class(row["fpk"]) if occupied[k] >= MIN_RESOLVED_BINS
                            else "not an estimate")
            row["bins_occupied"] = occupied[k]
            rows.append(row)
        worst = max(rows, key=lambda r: (_RANK[r["class"]], r["fpk"]["L1"]))
        fitted = fit_relaxation(times, [(_smooth_mean(d), 0.0) for d in smooth], start)
        pred = float(fpk.info.get("relaxation_time", math.nan))
        entries[m] = {"snapshots": rows, "verdict_class": worst["class"],
                      "worst_time": worst["t"],
                      "relaxation": _relaxation(pred, fitted, measured)}
    if measured is None and not any("no error bar" in w or "is not measured: its fit" in w
                                    for w in warnings):
        warnings.append(f"no relaxation time measured on the original system: the fit of its "
                        f"mean amplitude needs at least {MIN_FIT_TIMES} snapshot times that "
                        "resolve the decay (give times around the models' relaxation times)")
    verdicts = [transient_verdict(m, entries[m], measured) for m in models]
    verdicts += [f"{m} model: not checked, {why}" for m, why in absent.items()]
    stages.done()
    metrics: dict[str, Any] = {
        "workflow": "transient", "start": float(start), "times": list(times),
        "start_law": f"energy U(A0) with A0 = {start:g}, phase uniform in time along that "
                     "orbit, noise state from its stationary law",
        "models": entries,
        "relaxation": {"original_system": measured,
                       **{m: entries[m]["relaxation"] for m in models}},
        "original_system": {"mean_A": [mean_of(h)[0] for h in hists],
                            "mean_A_err": [mean_of(h)[1] for h in hists], "paths": n},
        "verdicts": verdicts, "warnings": warnings, "precision": prec,
        "monte_carlo": plain_info(mc.info),
        "timings": {"wall_seconds": float(sum(stages.seconds.values())),
                    "stages": stages.seconds},
    }
    if absent:
        metrics["models_absent"] = dict(absent)
    return TransientResult(scene=scene, start=float(start), times=times, models=models,
                           solutions=sol, metrics=metrics, warnings=warnings, verdicts=verdicts)


_RANK = {"indistinguishable": 0, "small": 1, "moderate": 2, "large": 3, "not an estimate": 4}
#: the fewest bins a snapshot law must occupy for its distances to mean anything
MIN_RESOLVED_BINS = 5
_KEYS = ("L1", "L1_err", "L1_floor", "ks", "ks_err", "ks_floor", "mean_diff")


def _metrics(c: dict[str, float]) -> dict[str, float]:
    return {k: float(c[k]) for k in _KEYS if k in c}


def snapshot_hists(res: Any, obs: str = "A") -> list[dict[str, Any]]:
    """The Monte Carlo snapshots of ``obs`` as one histogram record per time."""
    s = res.data["snapshots"]
    h = s[obs]
    P, E = np.atleast_2d(np.asarray(h["p"], float)), np.atleast_2d(np.asarray(h["err"], float))
    x = np.asarray(h.get("x", 0.5 * (h["edges"][1:] + h["edges"][:-1])), float)
    return [{"x": x, "p": P[k], "err": E[k], "edges": np.asarray(h["edges"], float)}
            for k in range(P.shape[0])]


def fpk_snapshots(res: Any) -> list[dict[str, Any]]:
    s = res.data["snapshots"]
    x = np.asarray(s["x"], float)
    return [{"x": x, "p": p} for p in np.atleast_2d(np.asarray(s["p"], float))]


def _smooth_mean(d: dict[str, Any]) -> float:
    m = np.trapezoid(d["p"], d["x"])
    return float(np.trapezoid(d["x"] * d["p"], d["x"]) / m)


def mean_of(h: dict[str, Any]) -> tuple[float, float]:
    """(mean, standard error) of a histogram snapshot: sum c p w over the bins' mass, the
    error from the bins' standard errors taken as independent."""
    w = np.diff(h["edges"])
    c = 0.5 * (h["edges"][1:] + h["edges"][:-1])
    mass = float(np.sum(h["p"] * w))
    mean = float(np.sum(c * h["p"] * w) / mass)
    err = float(math.sqrt(np.sum(((c - mean) * h["err"] * w) ** 2)) / mass)
    return mean, err


def fit_relaxation(times: tuple[float, ...], means: list[tuple[float, float]], start: float
                   ) -> dict[str, Any] | None:
    """tau (and a_inf) of a(t) = a_inf + (A0 - a_inf) exp(-t/tau) fitted to the means (module
    docstring); None when fewer than MIN_FIT_TIMES times or the fit does not converge."""
    from scipy.optimize import curve_fit

    t = np.asarray(times, float)
    y = np.array([m for m, _ in means])
    s = np.array([e for _, e in means])
    if t.size < MIN_FIT_TIMES or not np.all(np.isfinite(y)):
        return None

    def f(tt: np.ndarray, a_inf: float, log_tau: float) -> np.ndarray:
        return a_inf + (start - a_inf) * np.exp(-tt * np.exp(-log_tau))

    weighted = bool(np.all(s > 0))
    guess = (float(y[-1]), math.log(max(float(np.median(t)), 1e-12)))
    try:
        with np.errstate(all="ignore"):
            popt, pcov = curve_fit(f, t, y, p0=guess, sigma=s if weighted else None,
                                   absolute_sigma=weighted, maxfev=20000)
    except (RuntimeError, ValueError):
        return None
    tau = float(math.exp(popt[1]))
    err = float(tau * math.sqrt(pcov[1, 1])) if weighted and np.isfinite(pcov[1, 1]) else 0.0
    if not math.isfinite(tau):
        return None
    resid = (y - f(t, *popt)) / (s if weighted else 1.0)
    chi2 = float(np.sum(resid**2) / max(t.size - 2, 1)) if weighted else None
    # the mean need not decay with one rate: a misfit beyond the noise (chi^2 per degree of
    # freedom > 1) widens the error bar by sqrt(chi^2 / dof) (the Birge ratio), so that it
    # covers the model's inadequacy as well as the noise
    if chi2 is not None and chi2 > 1.0:
        err *= math.sqrt(chi2)
    return {"value": tau, "err": err, "a_inf": float(popt[0]), "chi2_per_dof": chi2,
            "dof": int(max(t.size - 2, 1)),
            "method": "fit of the mean amplitude a(t) = a_inf + (A0 - a_inf) exp(-t/tau), "
                      "error bar widened by sqrt(chi2/dof) when above 1"}


def _tau_error(fitted: dict[str, Any] | None, measured: dict[str, Any] | None
               ) -> dict[str, float] | None:
    """Relative error of the model's fitted tau against the measured one, with its error bar
    (from the measured tau's)."""
    if not fitted or not measured or measured["value"] <= 0:
        return None
    r = fitted["value"] / measured["value"]
    return {"value": r - 1.0, "err": r * measured["err"] / measured["value"]}


def _original(scene: Any, *, start: float, times: tuple[float, ...], edges: dict[str, Any],
              paths: int, rel_se: float | None, max_paths: int | None, quiet: bool
              ) -> tuple[Any, dict[str, Any]]:
    """(the original system's snapshots, metrics.json's "precision"): one run of ``paths``
    (``rel_se`` None) or units of ``paths`` grown to the relaxation time's target
    (harness/workflows/precision.py; the misfit stop applies)."""
    quantity = "relaxation time of the original system"

    def one(k: int, seed: int | None) -> Any:
        return timedomain.transient_montecarlo(scene, start=start, times=times, edges=edges,
                                               paths=paths, seed=seed, progress=not quiet)

    def measure(units: list[Any]) -> dict[str, Any]:
        f = fit_relaxation(times, [mean_of(h) for h in snapshot_hists(
            precision.pool_snapshots(units))], start)
        if f is None or not f["err"] > 0:
            return {"measured": False}
        return f

    if rel_se is None:
        mc = one(0, None)
        m = measure([mc])
        rse = m["err"] / m["value"] if m.get("measured", True) else math.nan
        return mc, precision.record(quantity=quantity, target=None, rse=rse, paths=paths,
                                    unit=paths, max_paths=None, stopped="paths given")
    units, prec = precision.grow(one, measure, seed=int(scene.montecarlo.seed), unit=paths,
                                 target=rel_se, max_paths=int(max_paths or paths),
                                 budget=float(scene.montecarlo.budget), quantity=quantity,
                                 misfit=True)
    return precision.pool_snapshots(units), prec


def _relaxation(pred: float, fitted: dict[str, Any] | None, measured: dict[str, Any] | None
                ) -> dict[str, Any]:
    """A model's relaxation record: predicted (its FPK's slowest rate), fitted (the same fit
    on its FPK snapshots), the relative error of the fitted one against the measured one with
    its error bar, and its class by the time domain's rule (precision.model_error_class:
    "within the error bar" unless |error| >= 2 error bars)."""
    err = _tau_error(fitted, measured)
    return {"predicted": pred, "fitted": fitted["value"] if fitted else None, "error": err,
            "class": precision.model_error_class(err["value"], err["err"]) if err else None}


def transient_verdict(model: str, e: dict[str, Any], measured: dict[str, Any] | None) -> str:
    """One line: the worst snapshot's class with its L1 and KS (none when no snapshot is an
    estimate: a law in fewer than MIN_RESOLVED_BINS bins has an L1 of ~0 whatever the model
    says), the relaxation time predicted, fitted and measured."""
    w = next(r for r in e["snapshots"] if r["t"] == e["worst_time"])["fpk"]
    rel = e["relaxation"]
    if all(r["class"] == "not an estimate" for r in e["snapshots"]):
        line = (f"{model} model: NOT AN ESTIMATE at every time (the original system's law "
                f"occupies fewer than {MIN_RESOLVED_BINS} bins of the shared grid at each: no "
                "distance is measured); relaxation time predicted "
                f"{rel['predicted']:.4g}")
    else:
        line = (f"{model} model: {e['verdict_class'].upper()} at worst (t = "
                f"{e['worst_time']:g}: L1(A) = {w['L1']:.3f} +/- {w.get('L1_err', 0):.3f}, "
                f"floor {w.get('L1_floor', 0):.3f}, KS {w['ks']:.3f}); relaxation time "
                f"predicted {rel['predicted']:.4g}")
    if rel["fitted"] is not None:
        line += f" (its mean amplitude decays with tau = {rel['fitted']:.4g})"
    if measured is None:
        line += "; not measured on the original system (its fit failed: see the warnings)"
    else:
        line += f", measured on the original system {measured['value']:.4g} +/- " \
                f"{measured['err']:.2g}"
        if rel["error"] is not None:
            pct = (f"{100 * rel['error']['value']:+.1f}% +/- "
                   f"{100 * rel['error']['err']:.1f}%")
            cls = rel.get("class") or precision.model_error_class(rel["error"]["value"],
                                                                  rel["error"]["err"])
            line += (f" ({cls}: {pct})" if cls == precision.WITHIN else
                     f" ({pct}: {cls.upper()} relaxation-time error)")
    return line
