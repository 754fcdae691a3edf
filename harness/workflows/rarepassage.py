"""`vifpk passage --method splitting`: the MFPT of the original system at thresholds direct
simulation cannot reach, by splitting (harness.door.timedomain.passage_splitting,
montecarlo/splitting.py), against each averaged model's MFPT
(harness.door.timedomain.mfpt_averaged: the Pontryagin quadrature).

Splitting gives the MFPT with its interval, not the first-passage-time law, so this report has
no Kaplan-Meier R(t), no sup |R - R_MC| and no FPT-density L1: metrics.json holds "mfpt" (per
model {"value"}, "original_system" {"value", "stderr", "ci", "method": "splitting", ...}),
per model the relative MFPT error with its error bar (survival.relative_mfpt_error), its
verdict class (passage.verdict_class: the same classes as a direct run), the recommendation
(passage.recommend), the method and why it was chosen; report.md a table of the same.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vifpk.harness.door import timedomain
from vifpk.harness.workflows import survival

from vifpk.core import registry
from vifpk.core.io import write_atomic, write_json

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


def run(req: Any, *, reason: str) -> SplittingResult:
    """The splitting workflow on a checked PassageRequest (harness/request/timedomain.py):
    its models' MFPTs (the request's quadratures when priced, else computed here), the
    original system's by splitting (``req.particles``, ``req.groups`` when given)."""
    from vifpk.harness.workflows.passage import recommend, verdict_class

    t0 = time.perf_counter()
    scene, threshold, start = req.scene, req.threshold, req.start
    names = tuple(m for m in req.models if isinstance(m, str))
    mfpt: dict[str, Any] = {}
    for m in registry.applicable(scene, names)[0]:  # the models that apply to the scene
        q = (req.quadratures or {}).get(m) or timedomain.mfpt_averaged(
            scene, m, threshold=threshold, start=start)
        mfpt[m] = {"value": float(q["value"]), "error_estimate": q.get("error_estimate")}
    knobs = {k: v for k, v in (("particles", req.particles), ("groups", req.groups))
             if v is not None}
    sp = timedomain.passage_splitting(scene, threshold=threshold, start=start, rel_ci=REL_CI,
                                      budget=BUDGET, **knobs)
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
    metrics = {"workflow": "passage", "method": "splitting", "method_reason": reason,
               "threshold": float(threshold),
               "start": start if start == "stationary" else float(start),
               "mfpt": {**mfpt, "original_system": orig}, "models": models_out,
               "splitting": {k: sp.info[k] for k in keep if k in sp.info},
               "verdicts": verdicts, "recommended_model": rec_model,
               "recommendation": rec_line,
               "timings": {"wall_seconds": time.perf_counter() - t0}}
    return SplittingResult(scene=scene, threshold=float(threshold), start=start,
                           models=tuple(mfpt), metrics=metrics, verdicts=verdicts,
                           recommendation=rec_line, warnings=[])


def _verdict(model: str, e: dict[str, Any]) -> str:
    err = e["mfpt_error"]
    line = (f"{model} model: {e['verdict_class'].upper()} -- MFPT error "
            f"{100 * err['value']:+.1f}% +/- {100 * err['err']:.1f}% against the original "
            "system (by splitting)")
    if e["verdict_class"] not in ("indistinguishable", "not an estimate"):
        line += f"; {e['verdict_cause']}"
    return line


def write_report(res: SplittingResult, out: str | Path, prov: dict[str, Any]) -> None:
    """DIR/metrics.json and DIR/report.md of a splitting run."""
    metrics = dict(res.metrics, provenance=prov)
    o = metrics["mfpt"]["original_system"]
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    write_json(folder / "metrics.json", metrics)
    rows = [f"| {m} | {e['mfpt']:.4g} | {100 * e['mfpt_error']['value']:+.1f}% +- "
            f"{100 * e['mfpt_error']['err']:.1f}% | {e['verdict_class']} |"
            for m, e in metrics["models"].items()]
    text = "\n".join([
        f"# First passage to Ac = {res.threshold:g} (method: splitting)", "",
        f"Method: splitting ({metrics['method_reason']}). Original system: MFPT "
        f"{o['value']:.4g} +- {o['stderr']:.2g} (95% interval {o['ci'][0]:.4g} to "
        f"{o['ci'][1]:.4g}; {metrics['splitting']['target']}).", "",
        "| model | MFPT | relative error vs original (1 s.e.) | class |", "|---|---|---|---|",
        *rows, "", res.recommendation, "",
        "Splitting estimates the MFPT only: no R(t), FPT density or their metrics here.", ""])
    write_atomic(folder / "report.md", text)


def passage_splitting_report(req: Any, *, out: str | Path, prov: dict[str, Any], reason: str
                             ) -> dict[str, Any]:
    """Run and write DIR/metrics.json and DIR/report.md; returns the metrics."""
    res = run(req, reason=reason)
    write_report(res, out, prov)
    return dict(res.metrics, provenance=prov)
