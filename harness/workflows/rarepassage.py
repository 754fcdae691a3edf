"""`vifpk passage --method splitting`: the MFPT of the original system at thresholds direct
simulation cannot reach, by splitting (harness.door.timedomain.passage_splitting,
montecarlo/splitting.py), against each averaged model's MFPT
(harness.door.timedomain.mfpt_averaged: the Pontryagin quadrature).

Splitting gives the MFPT with its interval, not the first-passage-time law, so this report has
no Kaplan-Meier R(t), no sup |R - R_MC| and no FPT-density L1: metrics.json holds "mfpt" (per
model {"value"}, "original_system" {"value", "stderr", "ci", "method": "splitting", ...}),
per model the relative MFPT error with its error bar (survival.relative_mfpt_error), the
method and why it was chosen; report.md a table of the same.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from vifpk.harness.door import timedomain
from vifpk.harness.workflows import survival

from vifpk.core import registry
from vifpk.core.io import write_atomic, write_json

#: the target 95% half-width of the original system's MFPT, relative, and the wall budget
REL_CI, BUDGET = 0.10, 900.0


def passage_splitting_report(scene: Any, *, threshold: float, start: float | str,
                             models: tuple[str, ...], out: str | Path, prov: dict[str, Any],
                             reason: str) -> dict[str, Any]:
    """Run and write DIR/metrics.json and DIR/report.md; returns the metrics."""
    t0 = time.perf_counter()
    mfpt: dict[str, Any] = {}
    for m in registry.applicable(scene, models)[0]:  # the models that apply to the scene
        q = timedomain.mfpt_averaged(scene, m, threshold=threshold, start=start)
        mfpt[m] = {"value": float(q["value"]), "error_estimate": q.get("error_estimate")}
    sp = timedomain.passage_splitting(scene, threshold=threshold, start=start, rel_ci=REL_CI,
                               budget=BUDGET)
    o = sp.info["mfpt"]
    orig = {"value": o["value"], "stderr": o["stderr"], "ci": o["ci"], "method": "splitting",
            "restricted": False, "groups": sp.info["groups"], "p_cycle": o["p"]["value"],
            "mean_cycle": o["mean_cycle"]}
    models_out = {m: {"mfpt": mfpt[m]["value"],
                      "mfpt_error": survival.relative_mfpt_error(
                          mfpt[m]["value"], orig,
                          model_err=float(mfpt[m]["error_estimate"] or 0.0))}
                  for m in models}
    keep = ("low", "entry", "levels_source", "target", "groups", "direct_cycles",
            "direct_successes", "seconds", "burn_in", "burn_in_rule", "settings")
    metrics = {"workflow": "passage", "method": "splitting", "method_reason": reason,
               "threshold": float(threshold),
               "start": start if start == "stationary" else float(start),
               "mfpt": {**mfpt, "original_system": orig}, "models": models_out,
               "splitting": {k: sp.info[k] for k in keep if k in sp.info},
               "timings": {"wall_seconds": time.perf_counter() - t0}, "provenance": prov}
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    write_json(folder / "metrics.json", metrics)
    rows = [f"| {m} | {mfpt[m]['value']:.4g} | {models_out[m]['mfpt_error']['value']:+.3f} "
            f"+- {models_out[m]['mfpt_error']['err']:.3f} |" for m in models]
    text = "\n".join([
        f"# First passage to Ac = {threshold:g} (method: splitting)", "",
        f"Method: splitting ({reason}). Original system: MFPT {o['value']:.4g} +- "
        f"{o['stderr']:.2g} (95% interval {o['ci'][0]:.4g} to {o['ci'][1]:.4g}; "
        f"{sp.info['target']}).", "",
        "| model | MFPT | relative error vs original (1 s.e.) |", "|---|---|---|", *rows, "",
        "Splitting estimates the MFPT only: no R(t), FPT density or their metrics here.", ""])
    write_atomic(folder / "report.md", text)
    return metrics
