"""The generated error report of a cross-check: report.html (self-contained, figures
embedded), report.md (+ figures/*.png), metrics.json (a contract scripts read), arrays.npz.

Everything is first written into a temporary directory inside DIR, then moved into place
file by file with os.replace, metrics.json last; an interrupted run leaves the previous
report (or nothing), never a half-written file.
"""

from __future__ import annotations

import base64
import html
import io
import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from .check import MODELS, OBSERVABLES, CheckResult
from .io import jsonable

LABELS = {"A": "amplitude A", "x1": "displacement x1", "x2": "velocity x2"}
KINDS = ("discretisation_error", "sampling_error", "averaging_error")
KIND_TEXT = {"discretisation_error": "discretisation (FPK vs closed form)",
             "sampling_error": "sampling (MC of the averaged SDE vs closed form)",
             "averaging_error": "averaging (MC of the original system vs closed form)"}


def _figure_densities(res: CheckResult) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sol = res.solutions
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    colors = {"paper": "tab:red", "exact": "tab:blue"}
    for ax, o in zip(axes, OBSERVABLES, strict=True):
        mc = sol["mc:original"].data[o]
        ax.errorbar(mc["x"], mc["p"], yerr=2 * mc["err"], fmt="o", ms=2.5, color="k",
                    elinewidth=0.8, label="MC, original system (±2 s.e.)", zorder=3)
        for m in MODELS:
            d = sol[f"closed:{m}"].data[o]
            ax.plot(d["x"], d["p"], color=colors[m], lw=1.6, label=f"{m} model, closed form")
            f = sol[f"fpk:{m}"].data[o]
            ax.plot(f["x"], f["p"], color=colors[m], lw=0.9, ls="--", label=f"{m} model, FPK")
        ax.set_xlabel(LABELS[o])
        ax.set_ylabel("density")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{res.scene.name}: stationary densities")
    fig.tight_layout()
    return _png(fig)


def _figure_decomposition(res: CheckResult) -> bytes:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(MODELS), figsize=(11, 3.6), sharey=True)
    width = 0.25
    for ax, m in zip(np.atleast_1d(axes), MODELS, strict=True):
        entry = res.metrics["models"][m]
        for k, kind in enumerate(KINDS):
            vals = [max(entry[kind][o]["L1"], 1e-7) for o in OBSERVABLES]
            errs = [entry[kind][o].get("L1_err", 0.0) for o in OBSERVABLES]
            xs = np.arange(3) + (k - 1) * width
            ax.bar(xs, vals, width, yerr=errs, label=KIND_TEXT[kind])
            floors = np.array([entry[kind][o].get("L1_floor", 0.0) for o in OBSERVABLES])
            has = floors > 0  # the FPK comparison has no noise floor
            ax.scatter(xs[has], floors[has], marker="_", s=250, color="k", zorder=3,
                       label="MC noise floor" if k == 2 else None)
        ax.set_yscale("log")
        ax.set_xticks(range(3), [LABELS[o] for o in OBSERVABLES])
        ax.set_title(f"{m} model")
    np.atleast_1d(axes)[0].set_ylabel("L1 distance")
    handles, labels = np.atleast_1d(axes)[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    return _png(fig)


def _png(fig: Any) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def _num(v: float, signed: bool = False) -> str:
    """4 decimals, or 3 significant digits in scientific notation below 1e-3."""
    if v != 0 and abs(v) < 1e-3:
        return f"{v:+.2e}" if signed else f"{v:.2e}"
    return f"{v:+.4f}" if signed else f"{v:.4f}"


def _fmt(e: dict[str, float], key: str) -> str:
    v = e[key]
    err = e.get(f"{key}_err")
    return _num(v) + (f" ± {_num(err)}" if err else "")


def _tables(res: CheckResult) -> list[tuple[str, list[str], list[list[str]]]]:
    tables = []
    for m in MODELS:
        rows = []
        for kind in KINDS:
            for o in OBSERVABLES:
                e = res.metrics["models"][m][kind][o]
                floor = _num(e["L1_floor"]) if e["L1_floor"] > 0 else "–"
                rows.append([KIND_TEXT[kind].split(" (")[0], o, _fmt(e, "L1"), floor,
                             _fmt(e, "hellinger"), _fmt(e, "ks"),
                             _num(e["mean_diff"], signed=True)])
        tables.append((f"{m} model: error decomposition",
                       ["error", "obs.", "L1", "L1 noise floor", "Hellinger", "KS",
                        "mean diff"], rows))
    return tables


def _scene_rows(res: CheckResult) -> list[list[str]]:
    d = res.scene.to_dict()
    rows = []
    for sec in ("system", "noise"):
        for k, v in d[sec].items():
            rows.append([f"{sec}.{k}", str(v)])
    return rows


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
    out = [f"# Error report: {res.scene.name}", "", res.scene.description, "",
           "## Verdict", ""]
    out += [f"- {v}" for v in res.verdicts]
    if res.warnings:
        out += ["", "## Warnings: averaging assumptions that fail here", ""]
        out += [f"- {w}" for w in res.warnings]
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
        ".verdict{font-weight:bold}</style></head><body>",
        f"<h1>Error report: {e(res.scene.name)}</h1>", f"<p>{e(res.scene.description)}</p>",
        "<h2>Verdict</h2><ul>",
    ]
    parts += [f'<li class="verdict">{e(v)}</li>' for v in res.verdicts]
    parts.append("</ul>")
    if res.warnings:
        parts.append("<h2>Warnings: averaging assumptions that fail here</h2><ul>")
        parts += [f'<li class="warn">{e(w)}</li>' for w in res.warnings]
        parts.append("</ul>")
    parts += ["<h2>Densities</h2>", img("densities"), "<h2>Error decomposition</h2>",
              img("decomposition")]
    for title, head, rows in _tables(res):
        parts += [f"<h3>{e(title)}</h3>", table(head, rows)]
    parts += ["<h2>Scene</h2>", table(["field", "value"], _scene_rows(res)),
              "<h2>Monte Carlo of the original system</h2>",
              table(["setting", "value"], _mc_rows(res)),
              "<p>Metrics against a Monte Carlo histogram carry its noise floor and an error bar, "
              "both from a parametric bootstrap of the batch errors.</p>", "</body></html>"]
    return "\n".join(parts)


def arrays(res: CheckResult) -> dict[str, np.ndarray]:
    out = {}
    for name, sol in res.solutions.items():
        for obs, rec in sol.data.items():
            for k, v in rec.items():
                if isinstance(v, np.ndarray):
                    out[f"{name.replace(':', '_')}__{obs}__{k}"] = v
    return out


def write_report(res: CheckResult, out_dir: str | Path) -> dict[str, Path]:
    """Write the report files into out_dir (atomically, metrics.json last)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".partial-", dir=out))
    try:
        pngs = {"densities": _figure_densities(res), "decomposition": _figure_decomposition(res)}
        (tmp / "figures").mkdir()
        figs = {}
        for k, b in pngs.items():
            (tmp / "figures" / f"{k}.png").write_bytes(b)
            figs[k] = f"figures/{k}.png"
        (tmp / "report.md").write_text(render_markdown(res, figs), encoding="utf-8")
        (tmp / "report.html").write_text(render_html(res, pngs), encoding="utf-8")
        np.savez_compressed(tmp / "arrays.npz", **arrays(res))
        doc = dict(res.metrics, scene=res.scene.to_dict())
        (tmp / "metrics.json").write_text(json.dumps(jsonable(doc), indent=1, allow_nan=False)
                                          + "\n", encoding="utf-8")
        (out / "figures").mkdir(exist_ok=True)
        order = ["figures/densities.png", "figures/decomposition.png", "arrays.npz",
                 "report.md", "report.html", "metrics.json"]
        for rel in order:
            os.replace(tmp / rel, out / rel)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return {k: out / k for k in ("report.html", "report.md", "metrics.json", "arrays.npz")}
