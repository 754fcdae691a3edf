"""The report folder of `vifpk passage --method splitting` (harness/workflows/rarepassage.py):
the files of a direct run's report that splitting can fill -- report.html (self-contained),
report.md and metrics.json, written as a unit (outputs/outdir.py) -- with the direct run's
sections (verdicts with their classes and percent errors, the recommendation, warnings, a
numbers table, scene, provenance) and metrics.json's ``runtime_warnings`` when the run's
warnings were recorded (harness/outputs/runwarnings.py). Splitting estimates the MFPT only:
no R(t), FPT density, figures, passage.npz or CSV files.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from vifpk.harness.outputs import outdir
from vifpk.harness.outputs.timereport import (
    PASSAGE_FILES,
    _html,
    _markdown,
    metrics_document,
)

from vifpk.core import provenance
from vifpk.core.io import dumps

SPLITTING_FILES = ("report.html", "report.md", "metrics.json")


def splitting_rows(res: Any) -> tuple[list[str], list[list[str]]]:
    """The numbers table: the original system's MFPT with its error bar and 95% interval,
    then each model's MFPT, its relative error (percent, one standard error) and class."""
    met = res.metrics
    o = met["mfpt"]["original_system"]
    head = ["", "MFPT", "relative error vs original (1 s.e.)", "class"]
    rows = [["original system (splitting)", f"{o['value']:.4g} +- {o['stderr']:.2g}",
             f"95% interval {o['ci'][0]:.4g} to {o['ci'][1]:.4g}", ""]]
    rows += [[f"{m} model", f"{e['mfpt']:.4g}", f"{100 * e['mfpt_error']['value']:+.1f}% +- "
              f"{100 * e['mfpt_error']['err']:.1f}%", e["verdict_class"]]
             for m, e in met["models"].items()]
    return head, rows


def write_splitting_report(res: Any, out_dir: str | Path, *, prov: dict[str, Any] | None = None,
                           runtime_warnings: list[dict[str, Any]] | None = None
                           ) -> dict[str, Path]:
    """Write DIR/report.html, report.md and metrics.json of a SplittingResult as a unit;
    ``runtime_warnings``: the run's counted RuntimeWarnings, stored in metrics.json."""
    res, prov = provenance.stamped(res, prov)
    met = res.metrics
    sp = met["splitting"]
    title = f"First passage: {res.scene.name}, Ac = {res.threshold:g} (method: splitting)"
    start = ("the stationary law restricted to A < Ac" if res.start == "stationary"
             else f"amplitude A0 = {res.start:g}")
    extra = [f"Method: splitting ({met['method_reason']}); start: {start}; levels low "
             f"{sp.get('low', float('nan')):.4g}, entry {sp.get('entry', float('nan')):.4g} "
             f"({sp.get('levels_source', '')}); target: {sp.get('target', '')}. MFPT error = "
             "T_model / T_original - 1 with the splitting's error bar.",
             "Splitting estimates the MFPT only: no R(t), FPT density or their metrics here."]
    head, rows = splitting_rows(res)

    def fill(tmp: Path) -> None:
        outdir._hook("fill")
        (tmp / "report.md").write_text(_markdown(title, res, {}, head, rows, extra),
                                       encoding="utf-8")
        (tmp / "report.html").write_text(_html(title, res, {}, head, rows, extra),
                                         encoding="utf-8")
        doc = metrics_document(res, prov, runtime_warnings)
        (tmp / "metrics.json").write_text(dumps(doc), encoding="utf-8")

    out = outdir.write_folder(out_dir, fill, run_id=prov["run_id"], allowed=PASSAGE_FILES)
    return {k: out / k for k in SPLITTING_FILES}


def passage_splitting_report(req: Any, *, out: str | Path, prov: dict[str, Any], reason: str,
                             quiet: bool = True, run_warnings: Any = None) -> dict[str, Any]:
    """Run the splitting workflow (progress lines unless ``quiet``) and write its report;
    ``run_warnings``: the command line's RunWarnings (its records go in metrics.json).
    Returns the run's metrics with its provenance."""
    from vifpk.harness.workflows import rarepassage

    res = rarepassage.run(req, reason=reason, quiet=quiet)
    recorded = run_warnings.records() if run_warnings is not None else None
    write_splitting_report(res, out, prov=prov, runtime_warnings=recorded)
    return dict(res.metrics, provenance=prov)
