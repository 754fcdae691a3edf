"""Reports of the time-domain workflows (harness/workflows/passage.py,
harness/workflows/transient.py):
report.html (self-contained, figures embedded), report.md (+ figures/*.png), metrics.json (a
public contract: docs/passage.md), arrays.npz (every curve and histogram in full).

Written as a unit with provenance, like a check report (harness/outputs/report.py, outdir.py): the
folder is built beside DIR and swapped in, every file stamped with the run id.
"""

from __future__ import annotations

import base64
import html
from pathlib import Path
from typing import Any

import numpy as np
from vifpk.harness.outputs import outdir
from vifpk.harness.outputs.report import MODEL_COLORS, scene_rows, write_figures
from vifpk.harness.outputs.runwarnings import KEY

from vifpk.core import provenance
from vifpk.core.io import dumps, png_bytes, pyplot

#: the files of a time-domain report; arrays-<workflow>.npz tells its kind (outdir.KINDS)
PASSAGE_FILES = ("report.html", "report.md", "metrics.json", "passage.npz", "reliability.csv",
                 "fpt_density.csv", "figures")
TRANSIENT_FILES = ("report.html", "report.md", "metrics.json", "transient.npz", "figures")


def _png(fig: Any, text: dict[str, str]) -> bytes:
    return png_bytes(fig, text=text, dpi=110)


def _km_step(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A Kaplan-Meier step function (t[0] = 0, value y[k] on [t[k], t[k+1])) for
    ``step(where="post")``."""
    return t, y


# ---------------------------------------------------------------------------- passage
def _passage_figures(res: Any, text: dict[str, str]) -> dict[str, bytes]:
    from vifpk.harness.workflows import survival
    from vifpk.harness.workflows.passage import _fpt

    plt = pyplot()
    mc = res.metrics["mfpt"]["original_system"]
    t_mc, cens = _fpt(res.solutions["mc:original"])
    km = survival.kaplan_meier(t_mc, cens)
    t_end = min(res.metrics["plan"]["horizon"], 5.0 * max(mc["value"], 1e-300))
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.4))
    for ax, log in zip(axes, (False, True), strict=True):
        tk = np.asarray(km["t"], float)
        x, lo = _km_step(tk, np.asarray(km["lower"], float))
        _, hi = _km_step(tk, np.asarray(km["upper"], float))
        _, R = _km_step(tk, np.asarray(km["R"], float))
        ax.fill_between(x, lo, hi, step="post", color="0.8", label="original system: 95% band")
        ax.step(x, R, where="post", color="k", lw=1.4, label="original system: Kaplan-Meier")
        for k, m in enumerate(res.models):
            col = MODEL_COLORS[k % len(MODEL_COLORS)]
            r = res.solutions[f"fpk:{m}"].data["R"]
            ax.plot(r["t"], r["R"], color=col, lw=1.5, label=f"{m} model: FPK")
            if f"sde:{m}" in res.solutions:
                ts, cs = _fpt(res.solutions[f"sde:{m}"])
                ks = survival.kaplan_meier(ts, cs)
                xs, Rs = _km_step(np.asarray(ks["t"], float), np.asarray(ks["R"], float))
                ax.step(xs, Rs, where="post", color=col, ls="--", lw=1.0,
                        label=f"{m} model: MC of its averaged SDE")
        ax.set_xlim(0, t_end)
        ax.set_xlabel("time t (scene time units)")
        ax.set_ylabel("reliability R(t) = P(no passage by t)")
        if log:
            ax.set_yscale("log")
            ax.set_ylim(max(1.0 / max(t_mc.size, 1), 1e-4), 1.2)
    axes[0].legend(fontsize=7, frameon=False)
    fig.suptitle(f"{res.scene.name}: reliability against the threshold Ac = {res.threshold:g}")
    fig.tight_layout()
    out = {"reliability": _png(fig, text)}
    done = t_mc[~cens]
    edges = np.linspace(0.0, t_end, 41)
    counts, _ = np.histogram(done, edges)
    w = np.diff(edges)
    n = max(t_mc.size, 1)
    c = 0.5 * (edges[1:] + edges[:-1])
    q, dq = counts / (n * w), 2 * np.sqrt(counts) / (n * w)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.4))
    for ax, log in zip(axes, (False, True), strict=True):
        ax.errorbar(c, q, yerr=dq, fmt="s", ms=3, color="k", capsize=1.5,
                    label="original system: MC (±2 s.e.)")
        top = float(np.max(q + dq)) if q.size else 1.0
        for k, m in enumerate(res.models):
            d = res.solutions[f"fpk:{m}"].data["fpt_density"]
            td, pd = np.asarray(d["t"], float), np.asarray(d["p"], float)
            ax.plot(td, pd, color=MODEL_COLORS[k % len(MODEL_COLORS)], label=f"{m} model")
            later = pd[(td >= edges[1]) & (td <= t_end)]
            top = max(top, float(np.max(later)) if later.size else 0.0)
        ax.set_xlim(0, t_end)
        ax.set_xlabel("first-passage time t (scene time units)")
        ax.set_ylabel("FPT density -dR/dt (1 / time unit)")
        if log:
            ax.set_yscale("log")
            ax.set_ylim(0.5 / (n * w[0]), 2 * top)
        else:
            # a start near Ac makes -dR/dt spike at t = 0: the axis shows the rest
            ax.set_ylim(0, 1.15 * top)
    axes[0].legend(fontsize=8, frameon=False)
    fig.suptitle(f"{res.scene.name}: first-passage time density to Ac = {res.threshold:g}")
    fig.tight_layout()
    out["fpt_density"] = _png(fig, text)
    fig, ax = plt.subplots(figsize=(7, 3.8))
    names = [*res.models, "original system"]
    vals = [res.metrics["mfpt"][m]["value"] for m in res.models] + [mc["value"]]
    errs = [0.0] * len(res.models) + [2 * mc["stderr"]]
    cols = [MODEL_COLORS[k % len(MODEL_COLORS)] for k in range(len(res.models))] + ["k"]
    ax.bar(range(len(names)), vals, yerr=errs, color=cols, capsize=4)
    ax.set_xticks(range(len(names)), names)
    ax.set_ylabel("MFPT (scene time units)")
    ax.set_title(f"MFPT to Ac = {res.threshold:g} (original system ±2 s.e."
                 + (", restricted mean" if mc["restricted"] else "") + ")")
    fig.tight_layout()
    out["mfpt"] = _png(fig, text)
    return out


def passage_rows(res: Any) -> tuple[list[str], list[list[str]]]:
    head = ["model", "class", "MFPT", "MFPT error vs original", "sup |R - R_MC| (floor)",
            "FPT density L1", "quadrature vs ∫R dt", "averaged SDE MFPT"]
    rows = []
    for m in res.models:
        e, mf = res.metrics["models"][m], res.metrics["mfpt"][m]
        err = e.get("mfpt_error_restricted", e["mfpt_error"])
        sde = e.get("sde")
        rows.append([m, e["verdict_class"], f"{mf['value']:.4g}",
                     f"{100 * err['value']:+.1f}% ± {100 * err['err']:.1f}%",
                     f"{e['R_sup']['value']:.3f} ({e['R_sup']['floor']:.3f})",
                     "n/a" if e["fpt_density_L1"].get("value") is None
                     else f"{e['fpt_density_L1']['value']:.3f}",
                     f"{100 * mf['routes_rel_diff']:+.2g}%",
                     f"{sde['mfpt']['value']:.4g} ± {sde['mfpt']['stderr']:.2g}" if sde
                     else "–"])
    o = res.metrics["mfpt"]["original_system"]
    rows.append(["original system", "", f"{o['value']:.4g} ± {o['stderr']:.2g}", "", "", "",
                 "", f"{o['paths']} paths, {o['censored']} censored"])
    return head, rows


def _arrays(res: Any) -> dict[str, np.ndarray]:
    """Every array of every solution, in full: ``<solution>__<record>__<key>`` (nested
    records joined by ``__``, e.g. ``mc_original__snapshots__A__p``)."""
    out: dict[str, np.ndarray] = {}

    def walk(prefix: str, rec: Any) -> None:
        for k, v in rec.items():
            if isinstance(v, np.ndarray):
                out[f"{prefix}__{k}"] = v
            elif isinstance(v, dict):
                walk(f"{prefix}__{k}", v)

    for name, sol in res.solutions.items():
        walk(name.replace(":", "_"), sol.data)
    return out


# ------------------------------------------------------------------------ passage CSV
RELIABILITY_COLUMNS = ("curve", "t", "R", "se", "lower", "upper")
DENSITY_COLUMNS = ("curve", "t_lo", "t_hi", "density", "err")


def _rows(columns: tuple[str, ...], rows: list[tuple[Any, ...]]) -> str:
    def cell(v: Any) -> str:
        return "" if v is None else (v if isinstance(v, str) else repr(float(v)))

    return "\n".join([",".join(columns), *(",".join(cell(v) for v in r) for r in rows)]) + "\n"


def passage_csv(res: Any) -> dict[str, str]:
    """reliability.csv and fpt_density.csv (docs/passage.md): R(t) of the original system
    (Kaplan-Meier steps with Greenwood's se and the 95% Hall-Wellner band), of each model's
    FPK and averaged SDE; the FPT density of the original system (KM mass per bin / width with
    its standard error, survival.fpt_bins) and of each model's FPK on the same bins
    (-(R(b) - R(a)) / (b - a))."""
    from vifpk.harness.workflows import survival

    def fpt(name: str) -> tuple[np.ndarray, np.ndarray]:
        f = res.solutions[name].data["fpt"]
        return np.asarray(f["time"], float), np.asarray(f["censored"], bool)

    rel: list[tuple[Any, ...]] = []
    t_mc, cens = fpt("mc:original")
    curves = [("original_system", t_mc, cens)] + [
        (f"sde:{m}", *fpt(f"sde:{m}")) for m in res.models if f"sde:{m}" in res.solutions]
    for name, t, c in curves:
        km = survival.kaplan_meier(t, c)
        rel += [(name, *row) for row in zip(km["t"], km["R"], km["se"], km["lower"],
                                            km["upper"], strict=True)]
    for m in res.models:
        r = res.solutions[f"fpk:{m}"].data["R"]
        rel += [(m, t, R, None, None, None) for t, R in zip(r["t"], r["R"], strict=True)]
    dens: list[tuple[Any, ...]] = []
    try:
        edges, q, sd = survival.fpt_bins(t_mc, cens)
    except ValueError:  # no path passed: no histogram (the header alone)
        edges = None
    if edges is not None:
        w = np.diff(edges)
        dens += [("original_system", a, b, qi / wi, si / wi)
                 for a, b, qi, si, wi in zip(edges[:-1], edges[1:], q, sd, w, strict=True)]
        for m in res.models:
            r = res.solutions[f"fpk:{m}"].data["R"]
            qm = -np.diff(np.interp(edges, np.asarray(r["t"], float),
                                    np.asarray(r["R"], float)))
            dens += [(m, a, b, qi / wi, None)
                     for a, b, qi, wi in zip(edges[:-1], edges[1:], qm, w, strict=True)]
    return {"reliability.csv": _rows(RELIABILITY_COLUMNS, rel),
            "fpt_density.csv": _rows(DENSITY_COLUMNS, dens)}


# --------------------------------------------------------------------------- transient
def _transient_figures(res: Any, text: dict[str, str]) -> dict[str, bytes]:
    from vifpk.harness.workflows.transient import fpk_snapshots, mean_of, snapshot_hists

    plt = pyplot()
    n = len(res.times)
    cols = min(n, 4)
    rows_ = -(-n // cols)
    fig, axes = plt.subplots(rows_, cols, figsize=(3.6 * cols, 3.1 * rows_), squeeze=False)
    hists = snapshot_hists(res.solutions["mc:original"])
    for k, t in enumerate(res.times):
        ax = axes[k // cols][k % cols]
        h = hists[k]
        ax.errorbar(h["x"], h["p"], yerr=2 * h["err"], fmt="s", ms=2, color="k",
                    elinewidth=0.7, label="original system: MC (±2 s.e.)")
        for j, m in enumerate(res.models):
            col = MODEL_COLORS[j % len(MODEL_COLORS)]
            d = fpk_snapshots(res.solutions[f"fpk:{m}"])[k]
            ax.plot(d["x"], d["p"], color=col, label=f"{m} model: FPK")
            if f"sde:{m}" in res.solutions:
                s = snapshot_hists(res.solutions[f"sde:{m}"])[k]
                ax.plot(s["x"], s["p"], color=col, ls="--", lw=0.9, drawstyle="steps-mid",
                        label=f"{m} model: MC of its averaged SDE")
        ax.set_title(f"t = {t:g}", fontsize=9)
        ax.set_xlabel("amplitude A")
    for k in range(n, rows_ * cols):
        axes[k // cols][k % cols].axis("off")
    axes[0][0].set_ylabel("p(A, t)")
    axes[0][0].legend(fontsize=6, frameon=False)
    fig.suptitle(f"{res.scene.name}: p(A, t) from A0 = {res.start:g}")
    fig.tight_layout()
    out = {"snapshots": _png(fig, text)}
    fig, ax = plt.subplots(figsize=(7, 4.2))
    means = [mean_of(h) for h in hists]
    ax.errorbar([0.0, *res.times], [res.start, *[m for m, _ in means]],
                yerr=[0.0, *[2 * e for _, e in means]], fmt="s", color="k",
                label="original system: MC (±2 s.e.)")
    tt = np.linspace(0.0, max(res.times), 200)
    meas = res.metrics["relaxation"]["original_system"]
    if meas:
        a = meas["a_inf"]
        ax.plot(tt, a + (res.start - a) * np.exp(-tt / meas["value"]), "k:",
                label=f"fit: tau = {meas['value']:.3g} ± {meas['err']:.2g}")
    for j, m in enumerate(res.models):
        d = fpk_snapshots(res.solutions[f"fpk:{m}"])
        mean = [float(np.trapezoid(s["x"] * s["p"], s["x"]) / np.trapezoid(s["p"], s["x"]))
                for s in d]
        ax.plot([0.0, *res.times], [res.start, *mean], "o-",
                color=MODEL_COLORS[j % len(MODEL_COLORS)], ms=3,
                label=f"{m} model (predicted tau "
                      f"{res.metrics['relaxation'][m]['predicted']:.3g})")
    ax.set_xlabel("time t (scene time units)")
    ax.set_ylabel("mean amplitude E[A(t)]")
    ax.legend(fontsize=7, frameon=False)
    fig.tight_layout()
    out["relaxation"] = _png(fig, text)
    return out


def transient_rows(res: Any) -> tuple[list[str], list[list[str]]]:
    head = ["model", "t", "class", "L1(A) ± err", "L1 floor", "KS ± err", "KS floor",
            "averaged SDE L1(A)"]
    rows = []
    for m in res.models:
        for r in res.metrics["models"][m]["snapshots"]:
            f = r["fpk"]
            rows.append([m, f"{r['t']:g}", r["class"], f"{f['L1']:.3f} ± {f.get('L1_err', 0):.3f}",
                         f"{f.get('L1_floor', 0):.3f}",
                         f"{f['ks']:.3f} ± {f.get('ks_err', 0):.3f}", f"{f.get('ks_floor', 0):.3f}",
                         f"{r['sde']['L1']:.3f}" if "sde" in r else "–"])
    return head, rows


# ------------------------------------------------------------------------------ common
def _precision(res: Any) -> str:
    """The run's precision line (harness/workflows/precision.py), "" when it has none."""
    from vifpk.harness.workflows.precision import line

    p = res.metrics.get("precision")
    return line(p) if p else ""


def _markdown(title: str, res: Any, figs: dict[str, str], head: list[str],
              rows: list[list[str]], extra: list[str]) -> str:
    out = [f"# {title}", ""]
    if res.provenance:
        out += [f"*{provenance.summary(res.provenance)}*", ""]
    out += [res.scene.description, "", "## Verdicts", ""]
    out += [f"- {v}" for v in res.verdicts]
    if _precision(res):
        out += ["", _precision(res)]
    rec = getattr(res, "recommendation", "")
    if rec:
        out += ["", f"**{rec}**"]
    if res.warnings:
        out += ["", "## Warnings", ""] + [f"- {w}" for w in res.warnings]
    out += ["", "## Numbers", "", "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    out += ["", *extra, ""]
    for k, f in figs.items():
        out += [f"## {k.replace('_', ' ')}", "", f"![{k}]({f})", ""]
    out += ["## Scene", "", "| field | value |", "|---|---|"]
    out += [f"| {a} | {b} |" for a, b in scene_rows(res.scene)]
    if res.provenance:
        out += ["", "## Provenance", "", "| field | value |", "|---|---|"]
        out += [f"| {a} | `{b.replace('|', chr(92) + '|')}` |"
                for a, b in provenance.rows(res.provenance)]
    return "\n".join(out) + "\n"


def _html(title: str, res: Any, pngs: dict[str, bytes], head: list[str],
          rows: list[list[str]], extra: list[str]) -> str:
    e = html.escape

    def table(h: list[str], rs: list[list[str]]) -> str:
        th = "".join(f"<th>{e(c)}</th>" for c in h)
        body = "".join("<tr>" + "".join(f"<td>{e(c)}</td>" for c in r) + "</tr>" for r in rs)
        return f"<table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table>"

    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             f"<title>vifpk: {e(title)}</title>",
             "<style>body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em}"
             "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;"
             "padding:3px 8px;text-align:right}th{background:#eee}img{max-width:100%}"
             ".warn{color:#a00}</style></head><body>", f"<h1>{e(title)}</h1>"]
    if res.provenance:
        parts.append(f'<p class="run">{e(provenance.summary(res.provenance))}</p>')
    parts += [f"<p>{e(res.scene.description)}</p>", "<h2>Verdicts</h2><ul>"]
    parts += [f"<li>{e(v)}</li>" for v in res.verdicts] + ["</ul>"]
    if _precision(res):
        parts.append(f'<p class="precision">{e(_precision(res))}</p>')
    rec = getattr(res, "recommendation", "")
    if rec:
        parts.append(f'<p class="recommendation"><b>{e(rec)}</b></p>')
    if res.warnings:
        parts += ["<h2>Warnings</h2><ul>"] + [f'<li class="warn">{e(w)}</li>'
                                               for w in res.warnings] + ["</ul>"]
    parts += ["<h2>Numbers</h2>", table(head, rows)] + [f"<p>{e(x)}</p>" for x in extra]
    for k, b in pngs.items():
        b64 = base64.b64encode(b).decode("ascii")
        parts += [f"<h2>{e(k.replace('_', ' '))}</h2>",
                  f'<img alt="{e(k)}" src="data:image/png;base64,{b64}">']
    parts += ["<h2>Scene</h2>", table(["field", "value"], scene_rows(res.scene))]
    if res.provenance:
        parts += ["<h2>Provenance</h2>",
                  table(["field", "value"], [list(r) for r in provenance.rows(res.provenance)])]
    parts.append("</body></html>")
    return "\n".join(parts)


def metrics_document(res: Any, prov: dict[str, Any],
                     runtime_warnings: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """metrics.json: the results (a function of scene, options and seed only), the run's
    counted RuntimeWarnings when recorded (``runtime_warnings``, harness/outputs/runwarnings.py,
    as `vifpk check` stores them), then ``timings`` and ``provenance``, the only keys that
    differ between identical runs."""
    doc = {k: v for k, v in res.metrics.items() if k != "timings"}
    doc["scene"] = res.scene.to_dict()
    if runtime_warnings is not None:
        doc[KEY] = runtime_warnings
    doc["timings"] = res.metrics.get("timings", {})
    doc["provenance"] = prov
    return doc


def write_time_report(res: Any, out_dir: str | Path, *, prov: dict[str, Any] | None = None,
                      runtime_warnings: list[dict[str, Any]] | None = None
                      ) -> dict[str, Path]:
    """Write the report folder of a PassageResult or a TransientResult as a unit;
    ``runtime_warnings``: the run's counted RuntimeWarnings, stored in metrics.json."""
    res, prov = provenance.stamped(res, prov)
    run_id = prov["run_id"]
    kind = res.metrics["workflow"]
    files = PASSAGE_FILES if kind == "passage" else TRANSIENT_FILES

    def fill(tmp: Path) -> None:
        text = {"vifpk run id": run_id, "Software": f"vifpk {prov['vifpk']}"}
        if kind == "passage":
            pngs = _passage_figures(res, text)
            head, rows = passage_rows(res)
            title = f"First passage: {res.scene.name}, Ac = {res.threshold:g}"
            p = res.metrics["plan"]
            extra = [f"Start: {res.metrics['start_law']}. Horizon {p['horizon']:.4g} "
                     f"({p['horizon_rule']}); {p['paths']} paths; censored fraction "
                     f"{p['censored_fraction']:.2%}. MFPT error = T_model / T_MC - 1 with "
                     "the Monte Carlo's error bar; sup |R - R_MC| against the Kaplan-Meier "
                     "band's noise floor."]
        else:
            pngs = _transient_figures(res, text)
            head, rows = transient_rows(res)
            title = f"Transient: {res.scene.name}, A0 = {res.start:g}"
            extra = [f"Start: {res.metrics['start_law']}. L1 and KS of p(A, t) against the "
                     "original system's histogram, with error bars and noise floors "
                     "(harness/workflows/compare.py)."]
        figs = write_figures(tmp, pngs)
        outdir._hook("fill")
        (tmp / "report.md").write_text(_markdown(title, res, figs, head, rows, extra),
                                       encoding="utf-8")
        (tmp / "report.html").write_text(_html(title, res, pngs, head, rows, extra),
                                         encoding="utf-8")
        np.savez_compressed(tmp / f"{kind}.npz", run_id=np.array(run_id),
                            **_arrays(res))
        if kind == "passage":
            for name, text in passage_csv(res).items():
                (tmp / name).write_text(text, encoding="utf-8")
        doc = metrics_document(res, prov, runtime_warnings)
        (tmp / "metrics.json").write_text(dumps(doc), encoding="utf-8")

    out = outdir.write_folder(out_dir, fill, run_id=run_id, allowed=files)
    return {k: out / k for k in ("report.html", "report.md", "metrics.json", f"{kind}.npz")}
