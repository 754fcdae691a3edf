"""The generated error report of a cross-check: report.html (self-contained, figures
embedded), report.md (+ figures/*.png), metrics.json (a contract scripts read), arrays.npz.

The folder is written as a unit (harness/outputs/outdir.py): the whole new set is built beside DIR
and
swapped in with one atomic exchange, under a lock that refuses a second run into DIR. Every
file carries the run's provenance (vifpk/core/provenance.py): metrics.json ``provenance``, a
block in report.html and report.md, ``run_id`` in arrays.npz and a text chunk in each PNG.
"""

from __future__ import annotations

import base64
import html
import math
from pathlib import Path
from typing import Any

import numpy as np
from vifpk.harness.outputs import outdir
from vifpk.harness.outputs.report_figures import (  # noqa: F401 - MODEL_COLORS: timereport's
    KIND_TEXT,
    KINDS,
    MODEL_COLORS,
)
from vifpk.harness.outputs.report_figures import figure_decomposition as _figure_decomposition
from vifpk.harness.outputs.report_figures import figure_densities as _figure_densities
from vifpk.harness.outputs.runwarnings import KEY
from vifpk.harness.workflows.check import OBSERVABLES, CheckResult
from vifpk.harness.workflows.verdict import INDISTINGUISHABLE_FACTOR, LARGE_L1, SMALL_L1

from vifpk.core import provenance
from vifpk.core.io import dumps


def _column_format(values: list[float]) -> str:
    """One format for a whole column: fixed 3 decimals when every nonzero value is in
    [0.01, 1000), else scientific with 3 significant digits ("scientific where small")."""
    mags = [abs(v) for v in values if v is not None and math.isfinite(v) and abs(v) > TINY]
    return "fixed" if all(1e-2 <= m < 1e3 for m in mags) else "sci"


TINY = 1e-12  # below this a difference is rounding (sums of ~1e3 terms in double precision)


def _cell(v: float | None, fmt: str, *, signed: bool = False, floor: float | None = None
          ) -> str:
    if v is None:
        return "–"
    if not math.isfinite(v):
        return "n/a"
    if floor is not None and floor > 0 and v < floor:
        return "< floor"
    if abs(v) <= TINY:
        return "0 (< 1e-12)"
    sign = "+" if signed else ""
    return f"{v:{sign}.3f}" if fmt == "fixed" else f"{v:{sign}.2e}"


def _format_columns(raw: list[list[Any]], spec: list[dict[str, Any]],
                   fmts: list[str | None] | None = None) -> list[list[str]]:
    """Format a table of raw numbers, one format per column (see _column_format).

    spec[j]: {"text": True} for a text column, or {"signed": bool, "floor": k, "err_of": i}:
    k is the index of the column holding this one's noise floor (values below it show
    "< floor"), i the column this one is the error bar of (blank when that value is below its
    floor). fmts: the formats, when several tables share them."""
    cols = len(spec)
    if fmts is None:
        fmts = _column_formats([raw], spec)
    out = []
    for r in raw:
        row = []
        for j in range(cols):
            if spec[j].get("text"):
                row.append(str(r[j]))
                continue
            k = spec[j].get("floor")
            i = spec[j].get("err_of")
            if i is not None:
                k = spec[i].get("floor")
            floor = r[k] if k is not None else None
            if i is not None and r[i] is not None and floor and r[i] < floor:
                row.append("–")
                continue
            row.append(_cell(r[j], fmts[j], signed=spec[j].get("signed", False),
                             floor=floor if i is None else None))
        out.append(row)
    return out


def _column_formats(raws: list[list[list[Any]]], spec: list[dict[str, Any]]
                    ) -> list[str | None]:
    """One format per column over several tables of the same layout."""
    return [None if spec[j].get("text") else
            _column_format([r[j] for raw in raws for r in raw]) for j in range(len(spec))]


TABLE_HEAD = ["error", "obs.", "L1", "L1 error bar", "L1 floor", "Hellinger", "Hellinger floor",
              "KS", "KS floor", "W1", "W1 floor", "mean diff", "std diff"]
_TABLE_SPEC = [{"text": True}, {"text": True}, {"floor": 4}, {"err_of": 2}, {}, {"floor": 6}, {},
               {"floor": 8}, {}, {"floor": 10}, {}, {"signed": True}, {"signed": True}]


def _decomposition(entry: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """(row label, {observable: metrics}) of a model's metrics entry: the kinds of KINDS it
    has (no closed form: no FPK measured), then each plugin FPK solver's numerics
    (``solver_errors``, harness/workflows/check.py)."""
    out = [(KIND_TEXT[k].split(" (")[0], entry[k]) for k in KINDS if k in entry]
    out += [(f"numerics of {name}", rec) for name, rec in entry.get("solver_errors", {}).items()]
    return out


def _tables(res: CheckResult) -> list[tuple[str, list[str], list[list[str]]]]:
    """Per model, the error decomposition: every metric with its noise floor; a value below
    its floor reads "< floor"; the FPK comparison is deterministic (no floor: "–")."""
    raws = []
    models = tuple(res.metrics["models"])
    for m in models:
        raw = []
        for label, records in _decomposition(res.metrics["models"][m]):
            for o in OBSERVABLES:
                e = records[o]
                has = e.get("L1_floor", 0.0) > 0

                def fl(key: str, e=e, has=has) -> float | None:
                    return e[key] if has else None

                raw.append([label, o, e["L1"], fl("L1_err"),
                            fl("L1_floor"), e["hellinger"], fl("hellinger_floor"), e["ks"],
                            fl("ks_floor"), e.get("w1", math.nan), fl("w1_floor"),
                            e["mean_diff"], e["std_diff"]])
        raws.append(raw)
    fmts = _column_formats(raws, _TABLE_SPEC)
    return [(f"{m} model: error decomposition", TABLE_HEAD,
             _format_columns(raw, _TABLE_SPEC, fmts))
            for m, raw in zip(models, raws, strict=True)]


CLASS_TEXT = {
    "headline": "the class of a model is the worst of its observables' classes (p(A), p(x1), "
                "p(x2)), each judged by the thresholds below against its own noise floor",
    "indistinguishable": f"L1 < {INDISTINGUISHABLE_FACTOR:g} x its noise floor: no error "
                         "measurable at this sample size",
    "small": f"L1 < {SMALL_L1:g}: at most {50 * SMALL_L1:g}% of the probability mass misplaced",
    "moderate": f"{SMALL_L1:g} <= L1 < {LARGE_L1:g}: {50 * SMALL_L1:g}-{50 * LARGE_L1:g}% of "
                "the mass misplaced",
    "large": f"L1 >= {LARGE_L1:g}: {50 * LARGE_L1:g}% of the mass or more misplaced",
    "not an estimate": "the distance is not measured: the Monte Carlo has not converged, or "
                       "its own checks say the distance is the run's (the verdict says which)",
    "assumption": "where an averaging assumption fails, the class and the number stay: they "
                  "are the model's error on this scene, and the cell names the assumption and "
                  "the warnings say why",
}


#: one colour per verdict class (check.RANK and "not an estimate"; a sequential green-to-red scale,
#: distinct hues so that SMALL never reads as INDISTINGUISHABLE; grey: no estimate)
CLASS_COLOURS = {"indistinguishable": "#a6dba0", "small": "#d9f0a3", "moderate": "#fee391",
                 "large": "#fc9272", "not an estimate": "#d9d9d9"}


def _class_css() -> str:
    return "".join(f".{k.replace(' ', '-')}{{background:{v}}}" for k, v in CLASS_COLOURS.items())


def verdict_rows(res: CheckResult) -> list[list[str]]:
    """The ten-second verdict: per model, class (the worst over every observable), L1(A) +/-
    error bar, times the noise floor, share of the probability mass misplaced (L1 / 2, on
    L1's 0..2 scale), the class of each observable, dominant cause."""
    from vifpk.harness.workflows.verdict import observable_classes

    rows = []
    for m in res.metrics["models"]:
        entry = res.metrics["models"][m]
        e = entry["averaging_error"]["A"]
        floor = e["L1_floor"]
        ratio = f"{e['L1'] / floor:.1f} x floor {floor:.3f}" if floor > 0 else "–"
        per = entry.get("verdict_by_observable") or observable_classes(entry)
        rows.append([m, entry.get("verdict_class", "?").upper(),
                     f"{e['L1']:.3f} ± {e['L1_err']:.3f}", ratio, f"{50 * e['L1']:.1f}%",
                     ", ".join(f"p({o}) {c}" for o, c in per.items()),
                     entry.get("verdict_cause", "") + _assumption_cell(entry)])
    return rows


def _assumption_cell(entry: dict[str, Any]) -> str:
    """Beside a measured class: the averaging assumptions that fail here (issue 45)."""
    kinds = entry.get("verdict_assumptions") or []
    if not kinds:
        return ""
    return ("; measured where an averaging assumption fails: "
            + ", ".join(k.replace("_", " ") for k in kinds) + " (see warnings)")


VERDICT_HEAD = ["model", "class (worst observable)", "L1(A) vs original system",
                "against the noise floor", "mass misplaced (L1/2)", "each observable",
                "dominant cause"]


def _class_legend() -> list[str]:
    return [f"{k}: {v}" for k, v in CLASS_TEXT.items()]


def _scene_rows(res: CheckResult) -> list[list[str]]:
    return scene_rows(res.scene)


def scene_rows(scene: Any) -> list[list[str]]:
    """The report's scene table, [field, value] rows: the system (walls included), the noise
    and, when a parametric noise is on, its intensities (they are in the scene's dictionary
    then, Scene.to_dict: the reports listed the walls but not D_k and D_c, issue 45)."""
    d = scene.to_dict()
    return [[f"{sec}.{k}", str(v)] for sec in ("system", "noise", "parametric")
            for k, v in d.get(sec, {}).items()]


def _mc_rows(res: CheckResult) -> list[list[str]]:
    info = res.solutions["mc:original"].info
    st, ev = info["settings"], info.get("events", {})
    rows = [[k, str(v)] for k, v in st.items()]
    rows.append(["seed", str(info["seed"]["root"])])
    for k in ("impacts_per_time", "stuck_fraction", "chatter_entries_per_time"):
        if k in ev:
            rows.append([k, f"{ev[k]['value']:.4g} ± {ev[k]['err']:.2g}"])
    rows.append(["speed", f"{info['steps_per_second'] / 1e6:.0f} M steps/s"])
    return rows


def render_markdown(res: CheckResult, figures: dict[str, str]) -> str:
    out = [f"# Error report: {res.scene.name}", ""]
    if res.provenance:
        out += [f"*{provenance.summary(res.provenance)}*", ""]
    out += [res.scene.description, ""]
    if res.recommendation:  # the one-line answer first (issue 28, day-one path)
        out += [f"**{res.recommendation}**", ""]
    out += ["## Verdict: is each averaged model usable here?", "",
            "| " + " | ".join(VERDICT_HEAD) + " |", "|" + "---|" * len(VERDICT_HEAD)]
    out += ["| " + " | ".join(r) + " |" for r in verdict_rows(res)]
    out += ["", "L1 = ∫|p - q| runs from 0 (identical) to 2 (disjoint). Classes: "
            + "; ".join(_class_legend()) + ".", ""]
    out += [f"- {v}" for v in res.verdicts]
    if res.tolerance_lines:  # the tolerance verdict (harness/workflows/tolerance.py)
        out += ["", "Tolerance verdict (the error with the Monte Carlo noise removed):", ""]
        out += [f"- {v}" for v in res.tolerance_lines]
    if res.warnings:
        out += ["", "## Warnings: averaging assumptions that fail here", ""]
        out += [f"- {w.text}" for w in res.warnings]
    out += ["", "## Densities", "", f"![densities]({figures['densities']})", "",
            "## Error decomposition", "", f"![decomposition]({figures['decomposition']})", ""]
    for title, head, rows in _tables(res):
        out += [f"### {title}", "", "| " + " | ".join(head) + " |",
                "|" + "---|" * len(head)]
        out += ["| " + " | ".join(r) + " |" for r in rows]
        out.append("")
    out += ["## Scene", "", "| field | value |", "|---|---|"]
    out += [f"| {a} | {b} |" for a, b in _scene_rows(res)]
    out += ["", "## Monte Carlo of the original system", "", "| setting | value |", "|---|---|"]
    out += [f"| {a} | {b} |" for a, b in _mc_rows(res)]
    out += ["", "Metrics against a Monte Carlo histogram carry its noise floor (the distance "
            "sampling noise alone produces) and an error bar, both from a parametric bootstrap "
            "of the batch errors. A distance near its floor cannot be told from zero.", ""]
    if res.provenance:
        out += ["## Provenance", "", "| field | value |", "|---|---|"]
        # a pipe escaped as \| stays a pipe inside a GFM table cell, code span included
        out += [f"| {a} | `{b.replace('|', chr(92) + '|')}` |"
                for a, b in provenance.rows(res.provenance)]
        out.append("")
    return "\n".join(out)


def render_html(res: CheckResult, pngs: dict[str, bytes]) -> str:
    e = html.escape

    def table(head: list[str], rows: list[list[str]]) -> str:
        h = "".join(f"<th>{e(c)}</th>" for c in head)
        body = "".join("<tr>" + "".join(f"<td>{e(c)}</td>" for c in r) + "</tr>" for r in rows)
        return f"<table><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>"

    def img(name: str) -> str:
        b64 = base64.b64encode(pngs[name]).decode("ascii")
        return f'<img alt="{e(name)}" src="data:image/png;base64,{b64}">'

    parts = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        f"<title>vifpk error report: {e(res.scene.name)}</title>",
        "<style>body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em}"
        "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;"
        "text-align:right}th{background:#eee}img{max-width:100%}.warn{color:#a00}"
        "table.verdict td{text-align:left}.cls{font-weight:bold}" + _class_css()
        + "</style></head><body>",
        f"<h1>Error report: {e(res.scene.name)}</h1>",
        *([f'<p class="run">{e(provenance.summary(res.provenance))}</p>']
          if res.provenance else []),
        f"<p>{e(res.scene.description)}</p>",
        # the one-line answer first (issue 28, day-one path), then the verdicts behind it
        *([f'<p class="recommendation"><b>{e(res.recommendation)}</b></p>']
          if res.recommendation else []),
        "<h2>Verdict: is each averaged model usable here?</h2>",
    ]
    vh = "".join(f"<th>{e(c)}</th>" for c in VERDICT_HEAD)
    vb = "".join(
        "<tr>" + "".join(
            (f'<td class="cls {e(c.lower().replace(" ", "-"))}">{e(c)}</td>' if j == 1
             else f"<td>{e(c)}</td>") for j, c in enumerate(r)) + "</tr>"
        for r in verdict_rows(res))
    parts.append(f'<table class="verdict"><thead><tr>{vh}</tr></thead><tbody>{vb}</tbody>'
                 "</table>")
    parts.append("<p>L1 = ∫|p − q| runs from 0 (identical) to 2 (disjoint). Classes:</p><ul>"
                 + "".join(f"<li>{e(x)}</li>" for x in _class_legend()) + "</ul>")
    parts.append("<details><summary>The verdict in full</summary><ul>")
    parts += [f"<li>{e(v)}</li>" for v in res.verdicts]
    parts.append("</ul></details>")
    if res.tolerance_lines:
        parts.append("<p>Tolerance verdict (the error with the Monte Carlo noise removed):</p>"
                     "<ul>" + "".join(f"<li>{e(v)}</li>" for v in res.tolerance_lines)
                     + "</ul>")
    if res.warnings:
        parts.append("<h2>Warnings: averaging assumptions that fail here</h2><ul>")
        parts += [f'<li class="warn">{e(w.text)}</li>' for w in res.warnings]
        parts.append("</ul>")
    parts += ["<h2>Densities</h2>", img("densities"), "<h2>Error decomposition</h2>",
              img("decomposition")]
    for title, head, rows in _tables(res):
        parts += [f"<h3>{e(title)}</h3>", table(head, rows)]
    parts += ["<h2>Scene</h2>", table(["field", "value"], _scene_rows(res)),
              "<h2>Monte Carlo of the original system</h2>",
              table(["setting", "value"], _mc_rows(res)),
              "<p>Metrics against a Monte Carlo histogram carry its noise floor and an error bar, "
              "both from a parametric bootstrap of the batch errors.</p>"]
    if res.provenance:
        parts += ["<h2>Provenance</h2>",
                  table(["field", "value"], [list(r) for r in provenance.rows(res.provenance)])]
    parts.append("</body></html>")
    return "\n".join(parts)


def arrays(res: CheckResult) -> dict[str, np.ndarray]:
    out = {}
    for name, sol in res.solutions.items():
        for obs, rec in sol.data.items():
            for k, v in rec.items():
                if isinstance(v, np.ndarray):
                    out[f"{name.replace(':', '_')}__{obs}__{k}"] = v
    return out


REPORT_FILES = ("report.html", "report.md", "metrics.json", "arrays.npz", "figures")


def write_figures(folder: Path, pngs: dict[str, bytes]) -> dict[str, str]:
    """Write each figure as ``folder/figures/NAME.png``; {name: its path relative to the
    folder} for the markdown report (every report of vifpk lays its figures out so)."""
    (folder / "figures").mkdir()
    figs = {}
    for k, b in pngs.items():
        (folder / "figures" / f"{k}.png").write_bytes(b)
        figs[k] = f"figures/{k}.png"
    return figs


def write_report(res: CheckResult, out_dir: str | Path, *,
                 prov: dict[str, Any] | None = None,
                 runtime_warnings: list[dict[str, Any]] | None = None) -> dict[str, Path]:
    """Write the report folder out_dir as a unit (harness/outputs/outdir.py), every file stamped
    with the run's provenance ``prov`` (default: :func:`provenance.collect` for this process).
    ``runtime_warnings``: the run's counted RuntimeWarnings (harness/outputs/runwarnings.py),
    stored in metrics.json; None: not recorded, no key."""
    res, prov = provenance.stamped(res, prov)
    run_id = prov["run_id"]

    def fill(tmp: Path) -> None:
        text = {"vifpk run id": run_id, "Software": f"vifpk {prov['vifpk']}"}
        pngs = {"densities": _figure_densities(res, text),
                "decomposition": _figure_decomposition(res, text)}
        figs = write_figures(tmp, pngs)
        outdir._hook("fill")
        (tmp / "report.md").write_text(render_markdown(res, figs), encoding="utf-8")
        (tmp / "report.html").write_text(render_html(res, pngs), encoding="utf-8")
        np.savez_compressed(tmp / "arrays.npz", run_id=np.array(run_id), **arrays(res))
        (tmp / "metrics.json").write_text(dumps(metrics_document(res, prov, runtime_warnings)),
                                          encoding="utf-8")

    out = outdir.write_folder(out_dir, fill, run_id=run_id, allowed=REPORT_FILES)
    return {k: out / k for k in ("report.html", "report.md", "metrics.json", "arrays.npz")}


def metrics_document(res: CheckResult, prov: dict[str, Any],
                     runtime_warnings: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """metrics.json: the results (a function of scene, settings and seed only), the run's
    counted RuntimeWarnings when recorded (``runtime_warnings``), then ``timings`` and
    ``provenance``, the only two keys that differ between identical runs."""
    doc = {k: v for k, v in res.metrics.items() if k != "timings"}
    doc["scene"] = res.scene.to_dict()
    if runtime_warnings is not None:
        doc[KEY] = runtime_warnings
    doc["timings"] = res.metrics.get("timings", {})
    doc["provenance"] = prov
    return doc
