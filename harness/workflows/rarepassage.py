"""`vifpk passage --method splitting`: the MFPT of the original system at thresholds direct
simulation cannot reach, by splitting (harness.door.timedomain.passage_splitting,
montecarlo/splitting.py), against each averaged model's MFPT
(harness.door.timedomain.mfpt_averaged: the Pontryagin quadrature).

Splitting gives the MFPT with its interval, not the first-passage-time law, so this report has
no Kaplan-Meier R(t), no sup |R - R_MC| and no FPT-density L1: metrics.json holds "mfpt" (per
model {"value"}, "original_system" {"value", "stderr", "ci", "method": "splitting", ...}),
per model the relative MFPT error with its error bar (survival.relative_mfpt_error), its
verdict class (passage.verdict_class: the same classes as a direct run), the recommendation
(passage.recommend), the method and why it was chosen, the splitting attempts; the report
(report.html, report.md, metrics.json) is harness/outputs/splitreport.py's.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from typing import Any

from vifpk.harness.door import timedomain
from vifpk.harness.workflows import survival

from vifpk.core import registry

#: the target 95% half-width of the original system's MFPT, relative, and the wall budget
REL_CI, BUDGET = 0.10, 900.0


@dataclass(frozen=True)
class SplittingResult:
    """A splitting run's answer: metrics (metrics.json's), one verdict line per model, the
    recommendation, warnings."""

    scene: Any
    threshold: float
    start: float | str
    models: tuple[str, ...]
    metrics: dict[str, Any]
    verdicts: list[str]
    recommendation: str
    warnings: list[str]
    provenance: dict[str, Any] | None = None


def run(req: Any, *, reason: str, quiet: bool = True) -> SplittingResult:
    """The splitting workflow on a checked PassageRequest (harness/request/timedomain.py):
    its models' MFPTs (the request's quadratures when priced, else computed here), the
    original system's by splitting (``req.particles``, ``req.groups`` when given). Progress
    lines on the standard error unless ``quiet`` (the direct run's). When every AMS run dies
    out at the default particles, the splitting runs again with twice as many while the next
    run (priced at twice the last) fits in BUDGET; with ``req.particles`` given, or out of
    budget, door.timedomain.SplittingDiedOut (exit 3, naming --particles)."""
    from vifpk.harness.workflows.passage import recommend, verdict_class
    from vifpk.harness.workflows.stages import Stages

    t0 = time.perf_counter()
    scene, threshold, start = req.scene, req.threshold, req.start
    # the levels are a caller's choice: refused (one line) before the first progress line
    timedomain.checked_splitting_levels(scene, threshold=threshold, start=start)
    names = tuple(m for m in req.models if isinstance(m, str))
    kept = registry.applicable(scene, names)[0]  # the models that apply to the scene
    stages = Stages(len(kept) + 2, quiet)
    mfpt: dict[str, Any] = {}
    for m in kept:
        stages(f"MFPT of the {m} model (quadrature)")
        q = (req.quadratures or {}).get(m) or timedomain.mfpt_averaged(
            scene, m, threshold=threshold, start=start)
        mfpt[m] = {"value": float(q["value"]), "error_estimate": q.get("error_estimate")}
    sp, attempts = _split(req, stages)
    o = sp.info["mfpt"]
    orig = {"value": o["value"], "stderr": o["stderr"], "ci": o["ci"], "method": "splitting",
            "restricted": False, "groups": sp.info["groups"], "p_cycle": o["p"]["value"],
            "mean_cycle": o["mean_cycle"]}
    models_out: dict[str, Any] = {}
    for m in mfpt:  # the models that apply
        e = {"mfpt": mfpt[m]["value"], "mfpt_error": survival.relative_mfpt_error(
            mfpt[m]["value"], orig, model_err=float(mfpt[m]["error_estimate"] or 0.0))}
        e["verdict_class"], e["verdict_cause"] = verdict_class(e)
        models_out[m] = e
    verdicts = [_verdict(m, e) for m, e in models_out.items()]
    rec_model, rec_line = recommend(models_out)
    keep = ("low", "entry", "levels_source", "target", "groups", "direct_cycles",
            "direct_successes", "seconds", "burn_in", "burn_in_rule", "settings")
    stages("metrics")
    stages.done()
    warnings = [f"every AMS run died out with {a['particles']} particles: run again with "
                f"{2 * a['particles']}" for a in attempts[:-1]]
    metrics = {"workflow": "passage", "method": "splitting", "method_reason": reason,
               "threshold": float(threshold),
               "start": start if start == "stationary" else float(start),
               "mfpt": {**mfpt, "original_system": orig}, "models": models_out,
               "splitting": {**{k: sp.info[k] for k in keep if k in sp.info},
                             "attempts": attempts},
               "warnings": warnings,
               "verdicts": verdicts, "recommended_model": rec_model,
               "recommendation": rec_line,
               "timings": {"wall_seconds": time.perf_counter() - t0}}
    return SplittingResult(scene=scene, threshold=float(threshold), start=start,
                           models=tuple(mfpt), metrics=metrics, verdicts=verdicts,
                           recommendation=rec_line, warnings=warnings)


def _split(req: Any, stages: Any) -> tuple[Any, list[dict[str, Any]]]:
    """door.timedomain.passage_splitting with the request's knobs and what is left of BUDGET
    (its batches stop there); on SplittingDiedOut at the default particles, again with twice
    as many while twice the last run's seconds fit in what is left (run's docstring).
    Returns (result, attempts: [{"particles", "seconds", "outcome"}])."""
    given = req.particles is not None
    particles = int(req.particles if given else timedomain.SPLITTING_PARTICLES)
    knobs = {} if req.groups is None else {"groups": req.groups}
    attempts: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    while True:
        groups = knobs.get("groups", timedomain.SPLITTING_GROUPS)
        stages(f"splitting of the original system ({particles} particles x {groups} groups, "
               f"to a 95% half-width of {REL_CI:.0%} within "
               f"{BUDGET - (time.perf_counter() - t0):.0f} s)")
        t = time.perf_counter()
        mine = {"particles": particles} if given or attempts else {}
        try:
            sp = timedomain.passage_splitting(
                req.scene, threshold=req.threshold, start=req.start, rel_ci=REL_CI,
                budget=max(BUDGET - (t - t0), 1.0), **knobs, **mine)
        except timedomain.SplittingDiedOut as exc:
            spent = time.perf_counter() - t
            attempts.append({"particles": particles, "seconds": spent, "outcome": "died out"})
            left = BUDGET - (time.perf_counter() - t0)
            if given or 2.0 * spent > left:
                if not stages.quiet:  # end the stage's line: the failure's line comes next
                    print(f" died out, {spent:.1f} s", file=sys.stderr, flush=True)
                tried = ", ".join(str(a["particles"]) for a in attempts)
                why = "" if given else (f" (tried {tried} particles; twice the last run would "
                                        f"exceed the {BUDGET:g} s budget)")
                raise timedomain.SplittingDiedOut(f"{exc}{why}", particles=particles) from None
            particles *= 2
            stages.total += 1
            continue
        attempts.append({"particles": particles, "seconds": time.perf_counter() - t,
                         "outcome": "finished"})
        return sp, attempts


def _verdict(model: str, e: dict[str, Any]) -> str:
    err = e["mfpt_error"]
    line = (f"{model} model: {e['verdict_class'].upper()} -- MFPT error "
            f"{100 * err['value']:+.1f}% +/- {100 * err['err']:.1f}% against the original "
            "system (by splitting)")
    if e["verdict_class"] not in ("indistinguishable", "not an estimate"):
        line += f"; {e['verdict_cause']}"
    return line
