"""First passage out of the safe domain A < Ac: how wrong is each averaged model's reliability?

For each averaged model M (default: the check models that apply to the scene) and the original
system, from a start at amplitude A0 (or the stationary law restricted to A < Ac):

    M by its FPK     R_M(t) (absorbing wall at Ac), FPT density -dR_M/dt, MFPT by the Pontryagin
                     quadrature and by int R_M dt (two routes; door.solvers.passage_averaged)
    M by its SDE     Monte Carlo of M's averaged SDE stopped at Ac (sampling check of the
                     routes above: the same model, another method)
    original system  Monte Carlo stopped at the first energy crossing U(A) = U(Ac), censored at
                     a horizon: Kaplan-Meier R(t) with its band, restricted mean MFPT
                     (harness/workflows/survival.py)

Plan (:func:`plan`): the horizon is HORIZON_FACTOR x the largest MFPT the averaged models give,
so that a first-passage time distributed like an exponential of that mean is censored with
probability exp(-HORIZON_FACTOR) = 3e-4 (a model short by half still leaves exp(-4) = 2%);
the expected cost is paths x E[min(tau, H)] / dt path-steps, at most paths x T_max / dt, priced
by the cost guard before the Monte Carlo (exit 2 with the estimate when out of reach). The
censoring is measured at run time: above CENSORED_WARN of the paths the run warns and the MFPT
errors compare restricted means over [0, H] on both sides.

Verdict classes of the relative MFPT error e = T_M / T_MC - 1 (docs/passage.md): within
INDISTINGUISHABLE_FACTOR error bars of zero "indistinguishable", |e| < MFPT_SMALL "small",
< MFPT_LARGE "moderate", else "large".
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from vifpk.harness.door import solvers, timedomain
from vifpk.harness.workflows import precision
from vifpk.harness.workflows.assumptions import compounded_tail
from vifpk.harness.workflows.check import models_of
from vifpk.harness.workflows.checkruns import sde_seed
from vifpk.harness.workflows.precision import _fpt, not_measured
from vifpk.harness.workflows.stages import Stages
from vifpk.harness.workflows.verdict import RECOMMENDABLE

from vifpk.core.defaults import BURN_FACTOR, CHECK_MODELS

HORIZON_FACTOR = 8.0  # horizon = 8 x the largest model MFPT (censoring e^-8 if a model is right)
CENSORED_WARN = 0.01  # more censored paths than this: warn, compare restricted means
# the time domain's one rule (precision.model_error_class), kept here under their old names
INDISTINGUISHABLE_FACTOR = precision.ERROR_BAR_FACTOR  # |e| < 2 error bars: not told from zero
MFPT_SMALL = precision.MFPT_SMALL  # |T_M / T_MC - 1| below 10%
MFPT_LARGE = precision.MFPT_LARGE  # at or above 30%
SAMPLING_Z = 3.0  # the averaged SDE's MFPT within 3 standard errors of its quadrature
CURVE_POINTS = 200  # points of each R(t) curve kept in metrics.json (all in arrays.npz)


@dataclass(frozen=True)
class PassageResult:
    scene: Any
    threshold: float
    start: float | str
    models: tuple[str, ...]
    solutions: dict[str, Any]  # "fpk:M", "sde:M", "mc:original" -> Result
    metrics: dict[str, Any]
    warnings: list[str]
    verdicts: list[str]
    recommendation: str = ""
    provenance: dict[str, Any] | None = None


def applicable(scene: Any, models: tuple[Any, ...]
               ) -> tuple[dict[str, Any], tuple[str, ...], dict[str, str]]:
    """({label: model}, the labels that apply, {label: why not}) for registered names (their
    own ``applies``: check.models_of) and model objects (the averaged-model protocol; kept)."""
    named = {solvers.model_label(m): m for m in models}
    kept, absent = models_of(scene, tuple(k for k, m in named.items() if isinstance(m, str)))
    labels = tuple(k for k, m in named.items() if not isinstance(m, str) or k in kept)
    return named, labels, absent


def start_label(start: float | str) -> str:
    return "the stationary law restricted to A < Ac" if start == "stationary" \
        else f"amplitude A0 = {start:g}"


# ----------------------------------------------------------------------------------- plan
def plan(scene: Any, mfpts: dict[str, float], *, paths: int | None = None,
         horizon: float | None = None, relaxation: float | None = None,
         inside: float = 1.0) -> dict[str, Any]:
    """The Monte Carlo plan from the averaged models' MFPTs (module docstring): horizon,
    paths, dt and the expected path-steps of one run (original system or averaged SDE).

    ``relaxation`` (a "stationary" start): the largest relaxation time of the models' FPKs.
    The original system's paths then run a burn-in before the clock starts (the scene's
    montecarlo.burn_in when it is a number, else "auto": BURN_FACTOR x the relaxation time the
    Monte Carlo measures), priced here at BURN_FACTOR x ``relaxation``; those ending at or
    above Ac start again: 1 / ``inside`` burn-ins a path on average, ``inside`` the smallest
    stationary mass below Ac among the models."""
    mc = scene.montecarlo
    finite = [v for v in mfpts.values() if math.isfinite(v) and v > 0]
    t_max = max(finite) if finite else math.inf
    h = float(horizon) if horizon is not None else HORIZON_FACTOR * t_max
    n = int(paths or mc.paths)
    dt = timedomain.time_step(scene)
    # E[min(tau, H)] <= min(T, H) for each model's T: the largest of them bounds the run
    mean_run = min(t_max, h) if math.isfinite(t_max) else h
    out = {"horizon": h, "paths": n, "dt": dt, "seed": int(mc.seed), "blocks": int(mc.blocks),
           "largest_model_mfpt": t_max,
           "horizon_rule": ("given (--horizon)" if horizon is not None else
                            f"{HORIZON_FACTOR:g} x the largest averaged-model MFPT "
                            f"({t_max:.4g}): an exponential FPT of that mean is censored with "
                            f"probability exp(-{HORIZON_FACTOR:g}) = "
                            f"{math.exp(-HORIZON_FACTOR):.1e}")}
    burn = 0.0
    if relaxation is not None:
        given = mc.burn_in != "auto"
        burn = float(mc.burn_in) if given else BURN_FACTOR * relaxation
        if given:
            out["burn_in"] = burn
            out["burn_in_rule"] = "the scene's montecarlo.burn_in"
        else:  # the Monte Carlo measures its own (burn_in "auto"): this prices it
            out["burn_in"] = "auto"
            out["burn_in_rule"] = ("auto: BURN_FACTOR x the relaxation time the Monte Carlo's "
                                   "pilot measures on the original system; priced at "
                                   f"{BURN_FACTOR:g} x the largest averaged-model relaxation "
                                   f"time ({relaxation:.4g})")
            out["burn_in_estimate"] = burn
        out["burn_ins_per_path"] = 1.0 / max(inside, 1e-300)
    out["expected_path_steps"] = (n * (mean_run + burn * out.get("burn_ins_per_path", 0.0))
                                  / dt if dt == dt else math.inf)
    return out


def stationary_numbers(scene: Any, model: Any, threshold: float) -> tuple[float, float]:
    """(relaxation time of the model's FPK, its stationary mass below Ac): what a "stationary"
    start's burn-in is planned and priced from (the FPK direct solve: milliseconds)."""
    m = solvers.averaged_model(scene, model)
    tau = float(solvers.fpk_stationary(m.drift, m.diffusion, method="direct").info[
        "relaxation_time"])
    d = solvers.amplitude_density(scene, model)
    A, p = np.asarray(d.A, float), np.asarray(d.p, float)
    total = float(np.trapezoid(p, A))
    k = A < threshold
    below = float(np.trapezoid(p[k], A[k])) / total if total > 0 else 1.0
    return tau, below


def worst_case(p: dict[str, Any], max_paths: int | None) -> dict[str, Any]:
    """The plan as the cost guard prices it: with a precision target (``max_paths`` given), at
    the paths cap, the most the growth can run (the original system and each averaged SDE);
    else ``p`` itself."""
    if not max_paths or int(max_paths) <= p["paths"]:
        return p
    return dict(p, paths=int(max_paths),
                expected_path_steps=p["expected_path_steps"] * int(max_paths) / p["paths"])


def run_seconds(p: dict[str, Any], runs: int, speed: float, cores: int) -> float:
    """Wall seconds of ``runs`` Monte Carlo runs of the plan at ``speed`` path-steps per second
    per core (the original system's; the averaged SDE is faster: a bound)."""
    return runs * p["expected_path_steps"] / (speed * max(cores, 1))


# ------------------------------------------------------------------------------- workflow
def run(req: Any, *, quiet: bool = True, price: Any = None,
        reference: Any = None) -> PassageResult:
    """The workflow on a checked request (harness.request.timedomain.PassageRequest): every
    front end builds one and calls this. ``reference``: passage()'s."""
    return passage(req.scene, threshold=req.threshold, start=req.start, models=req.models,
                   paths=req.paths, horizon=req.horizon, sde=req.sde, quiet=quiet,
                   price=price, quadratures=req.quadratures, at=req.at, rel_se=req.rel_se,
                   max_paths=req.max_paths, reference=reference)


def passage(scene: Any, *, threshold: float, start: float | str = "stationary",
            models: tuple[str, ...] = CHECK_MODELS, paths: int | None = None,
            horizon: float | None = None, sde: bool = True, quiet: bool = True,
            price: Any = None, quadratures: Mapping[str, Any] | None = None,
            at: tuple[float, ...] = (), rel_se: float | None = None,
            max_paths: int | None = None, reference: Any = None) -> PassageResult:
    """The first-passage cross-check (module docstring). ``price(plan)`` is called with the
    Monte Carlo plan before any Monte Carlo and may raise (the CLI's cost guard).
    ``quadratures``: {model label: fpk.mfpt's record} already computed to price the run
    (request.timedomain.with_quadratures), reused. ``at``: mission times T whose R(T) is
    reported for every model and the original system (metrics["at"]). ``rel_se``: the
    original system's paths grow in units of ``paths`` (or the scene's) until the relative
    standard error of its MFPT is at most ``rel_se`` or ``max_paths`` / the scene's budget is
    reached (harness/workflows/precision.py; None: exactly ``paths``); metrics["precision"]
    says which. ``reference``: a stand-in for timedomain.passage_montecarlo with its
    signature (the testing API's on-disk cache of the original system's runs)."""
    from vifpk.harness.workflows import survival

    named, models, absent = applicable(scene, models)
    stages = Stages(2 + len(models) * (1 + int(sde)), quiet)
    sol: dict[str, Any] = {}
    mfpt: dict[str, Any] = {}
    for m in models:
        stages(f"reliability of the {m} model (FPK + quadrature)")
        r = timedomain.passage_averaged(scene, named[m], threshold=threshold, start=start,
                                        quadrature=(quadratures or {}).get(m))
        sol[f"fpk:{m}"] = r
        mfpt[m] = _model_mfpt(r)
    relax, inside = None, 1.0
    if start == "stationary":
        nums = [stationary_numbers(scene, named[m], threshold) for m in models]
        relax, inside = max(n[0] for n in nums), min(n[1] for n in nums)
    p = plan(scene, {m: v["value"] for m, v in mfpt.items()}, paths=paths, horizon=horizon,
             relaxation=relax, inside=inside)
    if price is not None:  # the worst case: the growth may run up to the paths cap
        price(worst_case(p, max_paths if rel_se is not None else None))
    stages("Monte Carlo of the original system (first passage)")
    burn = {"burn_in": p["burn_in"]} if isinstance(p.get("burn_in"), float) else {}
    mc, prec = precision.original_system(scene, threshold=threshold, start=start, plan=p,
                                         burn=burn, rel_se=rel_se, max_paths=max_paths,
                                         quiet=quiet, reference=reference)
    p = dict(p, paths=int(prec["paths"]), first_paths=p["paths"],  # the plan of all paths run
             expected_path_steps=p["expected_path_steps"] * int(prec["paths"]) / p["paths"])
    sol["mc:original"] = mc
    t_mc, cens = _fpt(mc)
    km = survival.kaplan_meier(t_mc, cens)
    rmean = survival.restricted_mean(t_mc, cens, p["horizon"])
    frac = float(np.mean(cens)) if cens.size else 0.0
    warnings: list[str] = precision.unmet(prec)
    if "corrected" in models and (tail := compounded_tail(scene, threshold)):
        warnings.append(tail)  # issue 45: corrected's loss is first order in -ln e^2
    if frac > CENSORED_WARN:
        warnings.append(
            f"{100 * frac:.1f}% of the original system's paths did not pass Ac = {threshold:g} "
            f"within the horizon {p['horizon']:.4g}: its MFPT is a restricted mean over "
            f"[0, {p['horizon']:.4g}] (a lower bound), and the MFPT errors compare restricted "
            "means on both sides; raise --horizon for the full mean")
    orig = {"value": float(rmean["value"]), "stderr": float(rmean["stderr"]),
            "paths": int(t_mc.size), "censored": int(np.sum(cens)),
            "restricted": bool(rmean.get("restricted", frac > 0)), "horizon": p["horizon"]}
    unmeasured = not_measured(t_mc, cens, threshold, p["horizon"], p["dt"],
                              float(rmean["stderr"]))
    if unmeasured:
        orig["not_an_estimate"] = unmeasured
        warnings.append(f"NOT AN ESTIMATE: {unmeasured}")
    entries: dict[str, Any] = {}
    for m in models:
        r = sol[f"fpk:{m}"]
        e = _compare_model(survival, r, mfpt[m], km, rmean, t_mc, cens, p["horizon"], frac)
        if sde:
            stages(f"Monte Carlo of the {m} averaged SDE (first passage)")
            s = timedomain.passage_sde(scene, named[m], threshold=threshold,
                                start=sde_start(scene, named[m], start, threshold, p["paths"],
                                                sde_seed(scene.montecarlo.seed, m)),
                                horizon=p["horizon"], paths=p["paths"],
                                seed=sde_seed(scene.montecarlo.seed, m))
            sol[f"sde:{m}"] = s
            e["sde"] = _sde_check(survival, s, r, mfpt[m], p["horizon"])
            if not e["sde"]["sampling_ok"]:
                warnings.append(
                    f"the Monte Carlo of the {m} averaged SDE gives an MFPT of "
                    f"{e['sde']['mfpt']['value']:.4g} +/- {e['sde']['mfpt']['stderr']:.2g}, "
                    f"{abs(e['sde']['z']):.1f} standard errors from the {m} model's "
                    f"quadrature {mfpt[m]['value']:.4g}: the two routes of one model disagree "
                    "(time step of the SDE, or the FPK grid)")
        if unmeasured:
            e["not_an_estimate"] = unmeasured
        entries[m] = e
    stages("metrics")
    for e in entries.values():
        e["verdict_class"], e["verdict_cause"] = verdict_class(e, frac)
    verdicts = [verdict(m, entries[m]) for m in models]
    verdicts += [f"{m} model: not checked, {why}" for m, why in absent.items()]
    rec_model, rec_line = recommend(entries)
    stages.done()
    metrics: dict[str, Any] = {
        "workflow": "passage", "threshold": float(threshold),
        "start": start if start == "stationary" else float(start),
        "start_law": start_label(start),
        "mfpt": {**mfpt, "original_system": orig},
        "models": entries, "plan": dict(p, censored_fraction=frac), "precision": prec,
        "R": _curves(sol, km, models, sde),
        "verdicts": verdicts, "recommended_model": rec_model, "recommendation": rec_line,
        "warnings": warnings,
        "monte_carlo": plain_info(mc.info),
        "timings": {"wall_seconds": float(sum(stages.seconds.values())),
                    "stages": stages.seconds},
    }
    if at:
        metrics["at"] = survival.mission(km, {m: sol[f"fpk:{m}"] for m in models}, at,
                                         p["horizon"])
    if absent:
        metrics["models_absent"] = dict(absent)
    return PassageResult(scene=scene, threshold=float(threshold), start=start, models=models,
                         solutions=sol, metrics=metrics, warnings=warnings, verdicts=verdicts,
                         recommendation=rec_line)


def plain_info(info: dict[str, Any]) -> dict[str, Any]:
    """A run's info for metrics.json: numbers, strings, lists and dicts of them (arrays and
    objects dropped: the arrays are in the .npz)."""
    def ok(v: Any) -> Any:
        if isinstance(v, dict):
            return {str(k): x for k, x in ((k, ok(x)) for k, x in v.items()) if x is not _DROP}
        if isinstance(v, list | tuple):
            kept = [ok(x) for x in v]
            return _DROP if any(x is _DROP for x in kept) else kept
        if v is None or isinstance(v, bool | int | float | str | np.integer | np.floating):
            return v
        return _DROP

    out = ok({k: v for k, v in info.items() if k != "status"})
    return out if isinstance(out, dict) else {}


_DROP = object()


def sde_start(scene: Any, model: Any, start: float | str, threshold: float, paths: int,
              seed: int) -> float | np.ndarray:
    """The averaged SDE's start: the amplitude A0, or for "stationary" ``paths`` amplitudes
    drawn from the model's own stationary p(A) restricted to A < Ac (inverse CDF of its
    trapezoid interpolant, seeded), the start law of the model's FPK route it checks."""
    if start != "stationary":
        return float(start)
    d = solvers.amplitude_density(scene, model)
    A, p = np.asarray(d.A, float), np.asarray(d.p, float)
    inside = A < threshold
    A, p = np.append(A[inside], threshold), np.append(p[inside], np.interp(threshold, d.A, d.p))
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(A))])
    u = np.random.default_rng(np.random.SeedSequence([seed, 0x57A7])).random(paths)
    return np.minimum(np.interp(u * cdf[-1], cdf, A), np.nextafter(threshold, 0.0))


def _scalar(v: Any) -> float:
    return float(v["value"]) if isinstance(v, dict) else float(v)


def _model_mfpt(r: Any) -> dict[str, Any]:
    """The model's MFPT by quadrature and by int R dt, and how far apart the two routes are."""
    q = r.info["mfpt"]
    out = {"value": _scalar(q), "integral": _scalar(r.info["mfpt_integral"])}
    est = q.get("error_estimate") if isinstance(q, dict) else r.info.get("mfpt_error")
    if est is not None:
        out["error_estimate"] = float(est)
    out["routes_rel_diff"] = (out["integral"] / out["value"] - 1.0 if out["value"] > 0
                              else math.nan)
    return out


def restricted_model_mean(r: Any, horizon: float) -> float:
    """int_0^H R_M dt of a model's reliability curve (``survival.restricted_model_mean`` over
    the curve's own times; beyond its last time R_M decays at its slowest rate,
    info["decay_rate"], as the FPK's own int R dt assumes)."""
    from vifpk.harness.workflows import survival

    t, R = np.asarray(r.data["R"]["t"], float), np.asarray(r.data["R"]["R"], float)
    total = survival.restricted_model_mean(t, R, min(horizon, float(t[-1])))
    if t[-1] < horizon:
        lam = float(r.info.get("decay_rate", math.nan))
        if math.isfinite(lam) and lam > 0:
            total += float(R[-1]) * (1.0 - math.exp(-lam * (horizon - t[-1]))) / lam
    return total


def _keep(d: dict[str, Any], *keys: str) -> dict[str, Any]:
    return {k: d[k] for k in keys if k in d}


def _compare_model(survival: Any, r: Any, mf: dict[str, Any], km: dict[str, Any],
                   rmean: dict[str, Any], t_mc: np.ndarray, cens: np.ndarray, horizon: float,
                   frac: float) -> dict[str, Any]:
    t, R = np.asarray(r.data["R"]["t"], float), np.asarray(r.data["R"]["R"], float)
    e: dict[str, Any] = {"mfpt": mf["value"]}
    merr = float(mf.get("error_estimate", 0.0) or 0.0)
    e["mfpt_error"] = _keep(survival.relative_mfpt_error(mf["value"], rmean, model_err=merr),
                            "value", "err", "restricted", "horizon")
    if frac > CENSORED_WARN:  # like with like: restricted means over [0, H] on both sides
        e["mfpt_error_restricted"] = _keep(survival.relative_mfpt_error(
            restricted_model_mean(r, horizon), rmean), "value", "err", "restricted", "horizon")
    e["R_sup"] = _keep(survival.sup_distance(t, R, km), "value", "at", "floor", "inside_band",
                       "t_max")
    try:
        e["fpt_density_L1"] = _keep(survival.fpt_density_l1(t, R, t_mc, cens), "value",
                                    "floor", "err")
    except ValueError as exc:  # no passage at all within the horizon
        e["fpt_density_L1"] = {"value": None, "why": str(exc)}
    return e


def _sde_check(survival: Any, s: Any, r: Any, mf: dict[str, Any], horizon: float
               ) -> dict[str, Any]:
    """The model's averaged SDE by Monte Carlo against the model's own FPK/quadrature routes:
    the MFPT z-score and sup|R_FPK - R_SDE| against the SDE's Kaplan-Meier floor."""
    ts, cs = _fpt(s)
    km = survival.kaplan_meier(ts, cs)  # for the sup distance below
    rm = survival.restricted_mean(ts, cs, horizon)
    frac = float(np.mean(cs)) if cs.size else 0.0
    target = restricted_model_mean(r, horizon) if frac > CENSORED_WARN else mf["value"]
    se = float(rm["stderr"])
    unmeasured = bool(cs.size == 0 or np.all(cs) or not se > 0)  # nothing to sample-check
    # no z-score where nothing is measured (every path censored on a wall scene gave se > 0
    # from the Kaplan-Meier tail and a NaN value: "not finite: models.exact.sde.z", exit 3)
    z = None if unmeasured or not math.isfinite(float(rm["value"])) else (
        (float(rm["value"]) - target) / se)
    unmeasured = unmeasured or z is None
    sup = survival.sup_distance(np.asarray(r.data["R"]["t"], float),
                                np.asarray(r.data["R"]["R"], float), km)
    return {"mfpt": {"value": float(rm["value"]), "stderr": se, "paths": int(ts.size),
                     "censored": int(np.sum(cs))},
            "z": z, "R_sup_vs_fpk": _keep(sup, "value", "floor", "inside_band"),
            "sampling_ok": bool(unmeasured or abs(z) <= SAMPLING_Z),
            **({"not_an_estimate": "every path of the averaged SDE censored, or no spread in "
                                   "its passage times: no sampling check"}
               if unmeasured else {})}


def _thin(t: np.ndarray, *ys: np.ndarray) -> dict[str, list[float]]:
    idx = np.unique(np.linspace(0, t.size - 1, min(t.size, CURVE_POINTS)).astype(int)) \
        if t.size else np.array([], int)
    return {"t": t[idx].tolist(), **{f"y{i}": np.asarray(y)[idx].tolist()
                                     for i, y in enumerate(ys)}}


def _curves(sol: dict[str, Any], km: dict[str, Any], models: tuple[str, ...], sde: bool
            ) -> dict[str, Any]:
    """R(t) curves for metrics.json, each thinned to CURVE_POINTS points."""
    out: dict[str, Any] = {}
    k = _thin(np.asarray(km["t"], float), np.asarray(km["R"]), np.asarray(km["lower"]),
              np.asarray(km["upper"]))
    out["original_system"] = {"t": k["t"], "R": k["y0"], "lower": k["y1"], "upper": k["y2"]}
    for m in models:
        r = sol[f"fpk:{m}"].data["R"]
        c = _thin(np.asarray(r["t"], float), np.asarray(r["R"]))
        out[m] = {"t": c["t"], "R": c["y0"]}
        if sde and f"sde:{m}" in sol:
            ts, cs = _fpt(sol[f"sde:{m}"])
            from vifpk.harness.workflows import survival

            ks = survival.kaplan_meier(ts, cs)
            c = _thin(np.asarray(ks["t"], float), np.asarray(ks["R"]))
            out[f"sde:{m}"] = {"t": c["t"], "R": c["y0"]}
    return out


# ------------------------------------------------------------------------------- verdicts
def _error_used(e: dict[str, Any]) -> dict[str, float]:
    return e.get("mfpt_error_restricted", e["mfpt_error"])


def verdict_class(e: dict[str, Any], censored_fraction: float = 0.0) -> tuple[str, str]:
    """(class, cause) of one model's relative MFPT error (module docstring)."""
    if e.get("not_an_estimate"):
        return "not an estimate", e["not_an_estimate"]
    err = _error_used(e)
    v, bar = float(err["value"]), float(err["err"])
    if not (math.isfinite(v) and math.isfinite(bar)):
        return "not an estimate", "the MFPT error is not finite"
    cls = precision.model_error_class(v, bar)  # the one rule of the time domain
    if cls == precision.WITHIN:
        return "indistinguishable", "Monte Carlo noise (the error is within 2 error bars)"
    side = "too short (the model predicts failure too early)" if v < 0 else \
        "too long (the model predicts failure too late: unsafe)"
    return cls, f"the averaged model itself: its MFPT is {side}"


def verdict(model: str, e: dict[str, Any]) -> str:
    """One line: class, relative MFPT error with its error bar, sup|dR| against its floor."""
    if e["verdict_class"] == "not an estimate":
        return f"{model} model: NOT AN ESTIMATE -- {e['verdict_cause']}"
    err = _error_used(e)
    what = "restricted MFPT" if "mfpt_error_restricted" in e else "MFPT"
    s = e["R_sup"]
    pct = f"{100 * err['value']:+.1f}% +/- {100 * err['err']:.1f}%"
    if e["verdict_class"] == "indistinguishable":  # the rule: no model error below 2 bars
        pct = f"within the error bar ({pct})"
    line = (f"{model} model: {e['verdict_class'].upper()} -- {what} error {pct} against the "
            f"original system; sup|R_model - R_MC| = {s['value']:.3f} (noise floor {s['floor']:.3f}"
            + ("" if s.get("inside_band", True) else ", outside the 95% band") + ")")
    d = e["fpt_density_L1"]
    if d.get("value") is not None:
        line += f"; FPT density L1 = {d['value']:.3f} (floor {d['floor']:.3f})"
    if e["verdict_class"] not in ("indistinguishable", "not an estimate"):
        line += f"; {e['verdict_cause']}"
    return line


def recommend(entries: dict[str, Any]) -> tuple[str, str]:
    """(model, one line): the model whose MFPT is nearest the original system's, of those check
    may recommend (``paper`` drops the sgn(y) of the excitation: never) and any plugin model;
    "none" when the nearest is not small or indistinguishable."""
    head = "recommended model for first passage: "
    cand = {m: e for m, e in entries.items() if m in RECOMMENDABLE or m not in CHECK_MODELS}
    if not cand:
        return "none", head + "none -- no recommendable model was checked"
    why = next((e["verdict_cause"] for e in cand.values()
                if e["verdict_class"] == "not an estimate"), "")
    cand = {m: e for m, e in cand.items() if e["verdict_class"] != "not an estimate"}
    if not cand:
        return "none", head + f"none -- NOT AN ESTIMATE: {why}"
    best = min(cand, key=lambda m: abs(_error_used(cand[m])["value"]))
    desc = ", ".join(f"{m} {100 * _error_used(cand[m])['value']:+.1f}%" for m in cand)
    cls = cand[best]["verdict_class"]
    if cls in ("moderate", "large", "not an estimate"):
        return "none", (head + f"none -- the best model, {best}, misses the MFPT by "
                        f"{100 * _error_used(cand[best])['value']:+.1f}% ({desc})")
    return best, head + f"{best} -- nearest MFPT to the original system's ({desc})"
