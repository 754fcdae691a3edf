"""Maps of a sweep: ``DIR/report.html``, one self-contained page (PNG figures inlined).

check sweep over two parameters: for each model the averaging error L1 of p(A) as a colour map
(one colour scale and colour bar for all models, the paper and the exact model side by side),
the contour averaging_error_A = 2 L1_floor_A (inside it the model cannot be told from the
original system at the Monte Carlo's noise floor: averaging holds; the check's verdict uses the
same factor), hatching on points with an assumption warning or without convergence, a cross on
failed points. Over one parameter (or zipped points) the same numbers as curves.
averaging sweep: the mean amplitude of each model and the L1 distance between the models.
bifurcation sweep: the critical value of each model against the varied parameter, with the
Monte Carlo checks on both sides (filled: crater, open: single peak; red: a model disagrees).
"""

from __future__ import annotations

import base64
import html
import json
from pathlib import Path
from typing import Any

import numpy as np
from vifpk.harness.sweeps.timesweep import KEYS
from vifpk.harness.workflows.verdict import (
    INDISTINGUISHABLE_FACTOR as WITHIN_NOISE,  # the check's "indistinguishable"
)

FLAG_VARS = ("warn_narrow_band", "warn_sticking", "warn_strong_damping", "warn_strong_noise",
             "warn_strong_dissipation", "warn_not_converged")


def _png(fig: Any) -> str:
    from vifpk.core.io import png_bytes

    return base64.b64encode(png_bytes(fig, dpi=110, bbox_inches="tight")).decode()


def _axis(ds: Any, name: str) -> tuple[np.ndarray, str]:
    """Plot coordinate and label: system.r is shown as the impact loss 1 - r."""
    v = np.asarray(ds[name].values, float)
    if name == "system.r":
        return 1.0 - v, "1 - r  (system.r)"
    return v, name


def _edges(c: np.ndarray) -> np.ndarray:
    if c.size == 1:
        return np.array([c[0] - 0.5, c[0] + 0.5]) if c[0] == 0 else c[0] * np.array([0.9, 1.1])
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[2 * c[0] - mid[0]], mid, [2 * c[-1] - mid[-1]]])


def _flagged(ds: Any) -> np.ndarray:
    names = [k for k in FLAG_VARS if k in ds]
    if not names:
        return np.zeros(ds["failed"].shape, bool)
    return np.any([np.asarray(ds[k].values) == 1 for k in names], axis=0)


def _verdict_boundary(ax: Any, inside: np.ndarray, known: np.ndarray, xe: np.ndarray,
                      ye: np.ndarray) -> None:
    """The validity boundary of a grid as the cell edges between a point within the noise
    (L1 < 2 x floor) and one outside it: on a coarse, noisy grid an interpolated contour
    breaks into short dashes between isolated points, while the cells are what was measured.
    ``inside`` and ``known`` are (y, x) arrays; the edge grids ``xe``, ``ye`` bound them."""
    segs = []
    both = known[:, :-1] & known[:, 1:]
    for j, i in zip(*np.nonzero(both & (inside[:, :-1] != inside[:, 1:])), strict=True):
        segs.append([(xe[i + 1], ye[j]), (xe[i + 1], ye[j + 1])])
    both = known[:-1, :] & known[1:, :]
    for j, i in zip(*np.nonzero(both & (inside[:-1, :] != inside[1:, :])), strict=True):
        segs.append([(xe[i], ye[j + 1]), (xe[i + 1], ye[j + 1])])
    if segs:
        from matplotlib.collections import LineCollection

        ax.add_collection(LineCollection(segs, colors="white", linewidths=2,
                                         capstyle="projecting"))


def _no_values(ax: Any) -> None:
    """A panel whose model has no value at any point says so, rather than staying blank
    (issue 28: the paper model's panel where it does not apply)."""
    ax.text(0.5, 0.5, "no value at any point:\nthe model does not apply to these scenes\n"
            "(or failed: see the table of points)", transform=ax.transAxes, ha="center",
            va="center", fontsize=9, bbox={"facecolor": "white", "alpha": 0.8})


def _map_figure(ds: Any, var: str, title: str, *, contour: bool) -> str:
    """Colour maps of ``var`` (dims: two parameters and model), models side by side."""
    from vifpk.core.io import figures

    plt = figures()
    from matplotlib.patches import Rectangle

    px, py = [d for d in ds[var].dims if d != "model"]
    x, xl = _axis(ds, px)
    y, yl = _axis(ds, py)
    models = list(ds["model"].values) if "model" in ds[var].dims else [None]
    vals = np.asarray(ds[var].transpose(py, px, ...).values, float)
    finite = vals[np.isfinite(vals)]
    vmin, vmax = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    fig, axes = plt.subplots(1, len(models), figsize=(4.6 * len(models) + 1, 4), squeeze=False,
                             constrained_layout=True)
    flags = _flagged(ds.transpose(py, px, ...)) if "failed" in ds else None
    failed = np.asarray(ds["failed"].transpose(py, px).values) == 1
    xe, ye = _edges(x), _edges(y)
    mesh = None
    # one scale for every model; logarithmic when the values span more than a decade (the
    # paper and the exact model differ by about that much at the base scene)
    from matplotlib.colors import LogNorm, Normalize

    norm = LogNorm(vmin, vmax) if vmin > 0 and vmax > 10 * vmin else Normalize(vmin, vmax)
    for ax, m in zip(axes[0], models, strict=True):
        z = vals[..., models.index(m)] if m is not None else vals
        mesh = ax.pcolormesh(xe, ye, np.ma.masked_invalid(z), norm=norm, cmap="viridis",
                             shading="flat")
        if contour and "L1_floor_A" in ds and min(x.size, y.size) >= 2:
            fl = np.asarray(ds["L1_floor_A"].sel(model=m).transpose(py, px).values, float)
            ratio = z / fl
            inside = ratio < WITHIN_NOISE
            _verdict_boundary(ax, inside, np.isfinite(ratio), xe, ye)
            gx, gy = np.meshgrid(x, y)
            ax.plot(gx[inside], gy[inside], "o", mfc="none", mec="white", ms=5, ls="none")
        if flags is not None:
            for j, i in zip(*np.nonzero(flags), strict=True):
                ax.add_patch(Rectangle((xe[i], ye[j]), xe[i + 1] - xe[i], ye[j + 1] - ye[j],
                                       fill=False, hatch="///", edgecolor="0.85", lw=0))
        for j, i in zip(*np.nonzero(failed), strict=True):
            ax.plot(x[i], y[j], "x", color="red", ms=9, mew=2)
        if not np.isfinite(z).any():
            _no_values(ax)
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_title(f"{m} model" if m is not None else title)
    fig.colorbar(mesh, ax=axes[0].tolist(), label=title)
    return _png(fig)


def _scattered_map_figure(ds: Any, var: str, title: str) -> str:
    """An adaptive sweep over two parameters: for each model the error field interpolated
    linearly on the Delaunay triangulation of the points (in range-scaled coordinates, as the
    points were chosen: harness/sweeps/adaptive.py), the contour L1 = 2 x noise floor (white), and
    the points (white circles: within the noise; black dots: outside; red crosses: failed)."""
    from matplotlib.colors import LogNorm, Normalize
    from matplotlib.tri import Triangulation
    from scipy.spatial import Delaunay

    from vifpk.core.io import figures

    plt = figures()
    px, py = json.loads(ds.attrs["varied"])
    x, xl = _axis(ds, px)
    y, yl = _axis(ds, py)
    models = list(ds["model"].values)
    vals = np.asarray(ds[var].transpose("point", "model").values, float)
    floor = np.asarray(ds["L1_floor_A"].transpose("point", "model").values, float)
    failed = np.asarray(ds["failed"].values) == 1
    finite = vals[np.isfinite(vals)]
    vmin, vmax = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
    norm = LogNorm(vmin, vmax) if vmin > 0 and vmax > 10 * vmin else Normalize(vmin, vmax)
    fig, axes = plt.subplots(1, len(models), figsize=(4.6 * len(models) + 1, 4), squeeze=False,
                             constrained_layout=True)
    mesh = None
    for ax, m in zip(axes[0], models, strict=True):
        j = models.index(m)
        ok = np.isfinite(vals[:, j]) & np.isfinite(floor[:, j]) & (floor[:, j] > 0)
        if ok.sum() >= 3:
            unit = np.stack([(x[ok] - x.min()) / max(np.ptp(x), 1e-300),
                             (y[ok] - y.min()) / max(np.ptp(y), 1e-300)], axis=1)
            tri = Triangulation(x[ok], y[ok], triangles=Delaunay(unit).simplices)
            mesh = ax.tripcolor(tri, vals[ok, j], norm=norm, cmap="viridis", shading="gouraud")
            ratio = vals[ok, j] / floor[ok, j]
            if ratio.min() < WITHIN_NOISE < ratio.max():
                cs = ax.tricontour(tri, ratio, levels=[WITHIN_NOISE], colors="white",
                                   linewidths=2)
                ax.clabel(cs, fmt={WITHIN_NOISE: f"{WITHIN_NOISE:g} x floor"}, fontsize=8)
        inside = np.zeros_like(failed)
        inside[ok] = vals[ok, j] < WITHIN_NOISE * floor[ok, j]
        # clip_on=False: a point on the range's edge is drawn whole (issue 28: half-clipped)
        ax.plot(x[inside], y[inside], "o", mfc="none", mec="white", ms=4, ls="none",
                clip_on=False)
        ax.plot(x[ok & ~inside], y[ok & ~inside], ".", color="black", ms=3, ls="none",
                clip_on=False)
        ax.plot(x[failed], y[failed], "x", color="red", ms=8, mew=2, ls="none", clip_on=False)
        if not ok.any():
            _no_values(ax)
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.set_title(f"{m} model ({int(ok.sum())} points)")
    if mesh is not None:
        fig.colorbar(mesh, ax=axes[0].tolist(), label=title)
    return _png(fig)


def _curve_figure(ds: Any, var: str, err: str | None, title: str) -> str:
    from vifpk.core.io import figures

    plt = figures()

    dims = [d for d in ds[var].dims if d != "model"]
    fig, ax = plt.subplots(figsize=(6, 3.8), constrained_layout=True)
    if dims == ["point"] and ds.attrs.get("mode") == "adaptive":  # along its one parameter
        (name,) = json.loads(ds.attrs["varied"])
        ds = ds.sortby(name)
        x, xl = _axis(ds, name)
    elif dims == ["point"]:
        x, xl = np.arange(ds.sizes["point"]), "point"
    else:
        x, xl = _axis(ds, dims[0])
    models = list(ds["model"].values) if "model" in ds[var].dims else [None]
    for m in models:
        sel = ds[var].sel(model=m) if m is not None else ds[var]
        e = ds[err].sel(model=m).values if err and m is not None else None
        ax.errorbar(x, sel.values, yerr=e, marker="o", capsize=3, label=m or var)
        if m is not None and "L1_floor_A" in ds and var == "averaging_error_A":
            ax.plot(x, WITHIN_NOISE * ds["L1_floor_A"].sel(model=m).values, ":", color="0.5")
    if var == "averaging_error_A":
        ax.plot([], [], ":", color="0.5", label="2 x MC noise floor")
    ax.set_xlabel(xl)
    ax.set_ylabel(title)
    ax.legend()
    return _png(fig)


def _bifurcation_figure(ds: Any) -> str:
    from vifpk.core.io import figures

    plt = figures()

    dims = [d for d in ds["critical"].dims if d != "model"]
    fig, ax = plt.subplots(figsize=(6.4, 4.2), constrained_layout=True)
    x, xl = (np.arange(ds.sizes["point"]), "point") if dims == ["point"] else _axis(ds, dims[0])
    for m in ds["model"].values:
        ax.plot(x, ds["critical"].sel(model=m).values, "-o", label=f"{m} model: critical")
    if "mc_check_value" in ds and ds.sizes.get("check", 0):
        v = np.asarray(ds["mc_check_value"].values, float)
        crater = np.asarray(ds["mc_check_crater"].values)
        agree = np.all(np.asarray(ds["mc_check_agrees"].values) == 1, axis=-1)
        xx = np.broadcast_to(x[:, None], v.shape)
        for cr, fill in ((1, True), (0, False)):
            for ok, colour in ((True, "black"), (False, "red")):
                sel = (crater == cr) & (agree == ok) & np.isfinite(v)
                if sel.any():
                    ax.plot(xx[sel], v[sel], "s", ms=7, mec=colour,
                            mfc=colour if fill else "none", ls="none",
                            label=f"MC: {'crater' if cr else 'single peak'}"
                                  + ("" if ok else " (a model disagrees)"))
    ax.set_xlabel(xl)
    ax.set_ylabel(f"critical {json.loads(ds.attrs.get('bifurcation', '{}')).get('find', '')}")
    ax.legend(fontsize=8)
    return _png(fig)


def figures(ds: Any) -> list[tuple[str, str]]:
    """(caption, base64 PNG) for the sweep's workflow and shape."""
    wf = ds.attrs.get("workflow")
    params = json.loads(ds.attrs.get("varied", "[]"))
    two = ds.attrs.get("mode") == "product" and len(params) == 2
    out = []
    if wf == "check" and "averaging_error_A" in ds:
        if ds.attrs.get("mode") == "adaptive" and len(params) == 2:
            n = int(ds.sizes["point"])
            out.append((f"Adaptive sweep, {n} points: the averaging error L1 of p(A) "
                        "interpolated linearly between the points (Delaunay triangles). White "
                        "contour: L1 = 2 x noise floor; white circles: points within the Monte "
                        "Carlo noise (averaging holds), black dots: outside; red cross: failed "
                        "point.", _scattered_map_figure(ds, "averaging_error_A", "L1 of p(A)")))
        elif two:
            out.append(("Averaging error L1 of p(A) against the simulated original system. "
                        "White circles: within the Monte Carlo noise (L1 < 2 x noise floor), "
                        "averaging holds; white lines: the cell edges between such a point and "
                        "one outside it (the validity boundary at the grid's resolution). "
                        "Hatched: an assumption warning or no convergence. Red cross: failed "
                        "point.",
                        _map_figure(ds, "averaging_error_A", "L1 of p(A)", contour=True)))
        elif len(params) == 1 or ds.attrs.get("mode") == "zip":
            out.append(("Averaging error L1 of p(A) with its error bar; dotted: 2 x noise "
                        "floor.", _curve_figure(ds, "averaging_error_A",
                                                "averaging_error_A_err", "L1 of p(A)")))
    if wf == "check" and "surface_p_inside" in ds:
        from vifpk.harness.sweeps.surfacemaps import surface_figure

        img = surface_figure(ds)
        if img is not None:
            out.append((f"The averaging error surface at tolerance {ds.attrs['tolerance']:g} "
                        "(docs/maps.md, 'The error surface and its band'): colour exp(mu), the "
                        "Gaussian-process estimate of L1 of p(A) with the noise removed; white "
                        "line the boundary P(inside) = 1/2; hatched the band where P(inside) is "
                        "between 5% and 95%; white circles inside, black dots outside, grey "
                        "triangles undecided, marker area growing with the point's noise "
                        "floor.", img))
    if wf == "averaging" and "mean_A" in ds:
        if two:
            out.append(("Mean amplitude of each averaged model (closed forms).",
                        _map_figure(ds, "mean_A", "mean A", contour=False)))
            if "L1_paper_exact_A" in ds:
                out.append(("L1 between the paper and the exact model's p(A).",
                            _map_figure(ds, "L1_paper_exact_A", "L1(paper, exact)",
                                        contour=False)))
        else:
            out.append(("Mean amplitude of each averaged model.",
                        _curve_figure(ds, "mean_A", None, "mean A")))
    if wf in ("passage", "transient"):

        out += time_figures(ds)
    if wf == "bifurcation" and "critical" in ds and len(params) == 1:
        out.append(("Critical value of each model along the varied parameter, with the Monte "
                    "Carlo checks of the original system on both sides of it.",
                    _bifurcation_figure(ds)))
    return out


def render(sweep: Any, ds: Any) -> str:
    e = html.escape
    parts = ["<!doctype html><html><head><meta charset='utf-8'>",
             f"<title>vifpk sweep: {e(sweep.name)}</title>",
             "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;}"
             "table{border-collapse:collapse;font-size:90%}td,th{border:1px solid #ccc;"
             "padding:2px 6px;text-align:right}pre{background:#f6f6f6;padding:8px}</style>",
             "</head><body>", f"<h1>Sweep {e(sweep.name)}: workflow {e(sweep.workflow)}</h1>"]
    n = int(ds["failed"].size)
    bad = int((ds["failed"] == 1).sum())
    missing = int((ds["status"] == "missing").sum())
    parts.append(f"<p>{n} points, {bad} failed, {missing} missing; seed {sweep.seed}.</p>")
    for cap, img in figures(ds):
        parts.append(f"<figure><img src='data:image/png;base64,{img}' style='max-width:100%'>"
                     f"<figcaption>{e(cap)}</figcaption></figure>")
    # a check sweep's table gives each model's L1 of p(A) with its error bar and floor and
    # its verdict (and tolerance class), not the status alone (issue 28, day-one path)
    per_model = ([str(m) for m in ds["model"].values]
                 if "averaging_error_A" in ds and "model" in ds.dims else [])
    heads = [*sweep.names, *(f"{m}: L1(A) ± err [floor], verdict" for m in per_model),
             "status", "message"]
    parts.append("<h2>Points</h2><table><tr>" + "".join(f"<th>{e(k)}</th>" for k in heads)
                 + "</tr>")
    key_dims = ds["key"].dims

    def at(var: str, m: str, flat: Any) -> Any:
        return ds[var].sel(model=m).transpose(*key_dims).values[flat][0]

    for pt in sweep.points:
        flat = ds["key"].values == pt.key
        st = str(ds["status"].values[flat][0])
        msg = str(ds["message"].values[flat][0])
        cells = [f"{v:g}" for _, v in pt.params]
        for m in per_model:
            l1 = float(at("averaging_error_A", m, flat))
            if not np.isfinite(l1):
                cells.append("")
                continue
            text = (f"{l1:.3g} ± {float(at('averaging_error_A_err', m, flat)):.1g} "
                    f"[{float(at('L1_floor_A', m, flat)):.2g}]")
            for var in ("verdict_class", "tolerance_class"):
                if var in ds and str(at(var, m, flat)):
                    text += f", {at(var, m, flat)}"
            cells.append(text)
        cells += [st, msg]
        parts.append("<tr>" + "".join(f"<td>{e(c)}</td>" for c in cells) + "</tr>")
    parts.append("</table><h2>Sweep file</h2><pre>" + e(sweep.text) + "</pre>")
    prov = ds.attrs.get("provenance")
    if prov:
        parts.append("<h2>Provenance</h2><pre>" + e(json.dumps(json.loads(prov), indent=1))
                     + "</pre>")
    parts.append("</body></html>")
    return "\n".join(parts)


def write_maps(sweep: Any, ds: Any, out: Path) -> Path:
    from vifpk.core.io import write_atomic

    return write_atomic(Path(out) / "report.html", render(sweep, ds))


def time_figures(ds: Any) -> list[tuple[str, str]]:
    """The sweep figures of passage and transient sweeps along one parameter."""
    import json

    wf = ds.attrs.get("workflow")
    params = json.loads(ds.attrs.get("varied", "[]"))
    if wf not in KEYS or len(params) != 1 or ds.attrs.get("mode") == "adaptive":
        return []
    var, orig, label = (("mfpt", "mfpt_original", "MFPT (time units, log scale)")
                        if wf == "passage" else
                        ("relaxation_time", "relaxation_original",
                         "relaxation time (time units, log scale)"))
    if var not in ds or orig not in ds:
        return []
    from vifpk.core.io import figures

    plt = figures()
    x, xl = _axis(ds, params[0]) if params[0] in ds.coords else (
        np.arange(ds.sizes["point"]), "point")
    fig, ax = plt.subplots(figsize=(6.4, 4.2), constrained_layout=True)
    for m in ds["model"].values:
        ax.plot(x, ds[var].sel(model=m).values, "-o", ms=4, label=f"{m} model")
    ax.errorbar(x, ds[orig].values, yerr=2 * ds[f"{orig}_err"].values, fmt="s", color="k",
                capsize=3, label="original system: MC (±2 s.e.)")
    ax.set_yscale("log")
    ax.set_xlabel(xl)
    ax.set_ylabel(label)
    ax.legend(fontsize=8)
    what = ("Mean first-passage time of each averaged model (Pontryagin quadrature) against "
            "the Monte Carlo of the original system" if wf == "passage" else
            "Relaxation time each averaged model predicts (its FPK's slowest decay) against "
            "the one fitted on the original system")
    return [(what + ", log scale.", _png(fig))]
