"""sweep.nc and maps of a check sweep's error surfaces (issue 29 item 2): per point the
resolved error estimate, on the fine grid the surface, P(inside the tolerance) and the band, and
the figure drawing them; the fit itself is surface.py."""

from __future__ import annotations

from typing import Any

import numpy as np
from vifpk.harness.sweeps.surface import (
    FLOOR_FRACTION,
    Surface,
    SurfaceError,
    axes_for,
    fit_surface,
)

# --- sweep.nc: the surfaces of a check sweep, and their maps (issue 29 item 2) ---------------

#: the fine grid's dimensions in sweep.nc: "surface." + the parameter's name
GRID_PREFIX = "surface."
POINT_VARS = ("surface_error_estimate", "surface_error_estimate_log_sd",
              "surface_p_within_tolerance")


def resolved_error(estimate: Any, estimate_err: Any, measured_err: Any, floor: Any
                   ) -> np.ndarray:
    """The standard error a point's estimate enters the surface with: its own, but at least
    the point's resolution r = sqrt(2 F sigma + sigma^2) = debias(F + sigma, F) where the
    estimate is below r (F the Monte Carlo noise floor of L1, sigma the measured L1's error).

    Why: tolerance.py's interval is clamped at 0, so an estimate well below its noise reads
    0 +/- 0 (a quarter of the corrected model's points in docs/data/maps-r-mu-adaptive.nc),
    which as data says "the error is exactly 0" and made the surface's fit collapse (length
    scales and nugget at their bounds). A perfect model's L1 scatters about F by sigma, and
    r is the estimate a draw one sigma high gives: the smallest error the point tells from
    0. Below r the point says "0, give or take r"."""
    L = np.asarray(estimate, float)
    s = np.asarray(estimate_err, float)
    sg = np.asarray(measured_err, float)
    F = np.asarray(floor, float)
    r = np.sqrt(np.maximum(2 * F * sg + sg * sg, 0.0))
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(r) & (L < r), np.maximum(s, r), s)


def dataset_surfaces(ds: Any, *, resolution: int | None = None
                     ) -> tuple[dict[str, Surface], list[str]]:
    """The surface of every model of a check sweep's Dataset (variables ``error_estimate``,
    ``error_estimate_err``, ``p_within_tolerance`` per point and model, attribute
    ``tolerance``), and notes (one line each) for the models that have none: fewer than
    MIN_POINTS points with an estimate, or not one or two varied parameters. Axes: an adaptive
    sweep's ranges (linear, as it refines them); else the span of the values, logarithmic
    where they are log-spaced (:func:`log_spaced`)."""
    import json

    names = list(json.loads(ds.attrs.get("varied", "[]")))
    if "error_estimate" not in ds or "tolerance" not in ds.attrs:
        return {}, []
    if len(names) not in (1, 2):
        return {}, [f"no error surface: {len(names)} varied parameters (it needs one or two)"]
    tol = float(ds.attrs["tolerance"])
    point_dims = [d for d in ds["error_estimate"].dims if d != "model"]
    have = [k for k in ("error_estimate", "error_estimate_err", "p_within_tolerance",
                        "averaging_error_A_err", "L1_floor_A") if k in ds]
    flat = ds[have].stack(
        _pt=point_dims) if point_dims != ["point"] else ds.rename({"point": "_pt"})
    coords = [np.asarray(flat[n].values, float) for n in names]
    ranges = None
    if ds.attrs.get("mode") == "adaptive" and "adaptive" in ds.attrs:
        r = json.loads(ds.attrs["adaptive"])["ranges"]
        ranges = [tuple(r[n]) for n in names]
    values = [np.asarray(ds[n].values, float).ravel() for n in names]
    try:
        axes = axes_for(names, values, ranges=ranges)
    except SurfaceError as exc:
        return {}, [f"no error surface: {exc}"]
    x = np.column_stack(coords)
    out, notes = {}, []
    for m in ds["model"].values:
        sel = flat.sel(model=m)
        est, err = sel["error_estimate"].values.ravel(), sel["error_estimate_err"].values.ravel()
        if (ds.attrs.get("tolerance_metric", "L1"), ds.attrs.get("tolerance_observable", "A")
                ) == ("L1", "A") and {"averaging_error_A_err", "L1_floor_A"} <= set(have):
            err = resolved_error(est, err, sel["averaging_error_A_err"].values.ravel(),
                                 sel["L1_floor_A"].values.ravel())
        try:
            out[str(m)] = fit_surface(
                x, est, err,
                tolerance=tol, axes=axes, p_within_tolerance=sel["p_within_tolerance"].values,
                resolution=resolution)
        except SurfaceError as exc:
            notes.append(f"{m} model: no error surface: {exc}")
    return out, notes


def add_surfaces(ds: Any, surfaces: dict[str, Surface]) -> Any:
    """``ds`` with the surfaces: on the fine grid (dims ``surface.<param>``, model)
    ``surface_error`` (exp mu), ``surface_error_log_sd`` (sd of log L), ``surface_p_inside``
    (P(L <= tolerance)) and ``surface_band`` (1 where BAND[0] < P < BAND[1]); per point and
    model POINT_VARS (the surface at the points); the fit of each model in the attribute
    ``surface`` (JSON: kernel, hyperparameters, band levels, floor, method)."""
    import json

    if not surfaces:
        return ds
    models = [str(m) for m in ds["model"].values]
    first = next(iter(surfaces.values()))
    gdims = [GRID_PREFIX + a.name for a in first.axes]
    shape = first.log_error.shape
    grid = {"surface_error": np.full(shape + (len(models),), np.nan),
            "surface_error_log_sd": np.full(shape + (len(models),), np.nan),
            "surface_p_inside": np.full(shape + (len(models),), np.nan),
            "surface_band": np.full(shape + (len(models),), -1, dtype=np.int8)}
    point_dims = [d for d in ds["error_estimate"].dims if d != "model"]
    pshape = tuple(ds.sizes[d] for d in point_dims)
    per_point = {k: np.full(pshape + (len(models),), np.nan) for k in POINT_VARS}
    fits = {}
    for m, s in surfaces.items():
        j = models.index(m)
        grid["surface_error"][..., j] = s.error
        grid["surface_error_log_sd"][..., j] = s.log_error_sd
        grid["surface_p_inside"][..., j] = s.p_inside
        grid["surface_band"][..., j] = s.band.astype(np.int8)
        for k, v in zip(POINT_VARS, (s.surface_error_estimate, s.surface_error_estimate_sd,
                                     s.surface_p_within_tolerance), strict=True):
            per_point[k][..., j] = v.reshape(pshape)
        fits[m] = {"kernel": s.kernel, **s.hyperparameters,
                   "log_marginal_likelihood": s.log_marginal_likelihood,
                   "band_area": s.band_area, "inside_area": s.inside_area,
                   "floored_points": int(s.floored.sum())}
    out = ds.assign_coords({d: (d, g) for d, g in zip(gdims, first.grid, strict=True)})
    for k, v in grid.items():
        out[k] = (gdims + ["model"], v)
    for k, v in per_point.items():
        out[k] = (point_dims + ["model"], v)
    out["surface_band"].attrs["flag_values"] = (
        f"1: {first.band_levels[0]:g} < P(inside) < {first.band_levels[1]:g} (the band), 0: "
        "not, -1: no surface for this model")
    out.attrs["surface"] = json.dumps({
        "method": "Gaussian process of log(error_estimate) over the varied parameters (unit "
                  "axes; log10 where log-spaced), each point's error_estimate_err as its own "
                  "noise through exp(g) linearised at the surface; P(inside) = "
                  "Phi((log tolerance - mu) / sd); boundary: P = 1/2 (harness/sweeps/surface.py)",
        "band": list(first.band_levels), "floor": FLOOR_FRACTION * first.tolerance,
        "axes": [{"name": a.name, "lo": a.lo, "hi": a.hi, "log": a.log} for a in first.axes],
        "models": fits})
    return out


def surface_figure(ds: Any, *, axis: Any = None) -> str | None:
    """The maps of the surfaces in ``ds`` (add_surfaces) as a base64 PNG, models side by side
    (None without surfaces). Two parameters: colour the surface exp(mu) (one log scale for all
    models), white line the boundary P(inside) = 1/2, hatched and lighter the band, points
    coloured by their own verdict (white circle inside, black dot outside, grey triangle
    undecided) with marker area growing with their Monte Carlo noise floor / tolerance. One
    parameter: the surface with its 90% interval, the points' estimates with their error bars
    and noise floors, the tolerance, the band shaded. ``axis(name, values) -> (values, label)``
    transforms an axis for display (sweepmaps: system.r as 1 - r)."""
    import base64
    import json

    from matplotlib.colors import LogNorm

    from vifpk.core.io import figures, png_bytes

    if "surface_error" not in ds:
        return None
    axis = axis or (lambda name, v: (np.asarray(v, float), name))
    meta = json.loads(ds.attrs["surface"])
    names = [a["name"] for a in meta["axes"]]
    tol = float(ds.attrs["tolerance"])
    models = [m for m in ds["model"].values if str(m) in meta["models"]]
    lo, hi = meta["band"]
    plt = figures()
    fig, axs = plt.subplots(1, len(models), figsize=(4.6 * len(models) + 1, 4), squeeze=False,
                            constrained_layout=True)
    gx, xl = axis(names[0], ds[GRID_PREFIX + names[0]].values)
    px, _ = axis(names[0], ds[names[0]].values)
    point_dims = [d for d in ds["error_estimate"].dims if d != "model"]
    if point_dims != ["point"] and len(names) == 2:  # a product grid: every point's coordinates
        px, _ = axis(names[0], ds[names[0]].broadcast_like(ds["error_estimate"].isel(model=0))
                     .transpose(*point_dims).values.ravel())
    own_cls = ds["tolerance_class"] if "tolerance_class" in ds else None
    floor = ds["L1_floor_A"] if "L1_floor_A" in ds else None
    if len(names) == 1:
        ax = axs[0][0]
        fig.set_size_inches(6.4, 4.2)
        for m in models:
            mu = np.log(ds["surface_error"].sel(model=m).values)
            sd = ds["surface_error_log_sd"].sel(model=m).values
            line, = ax.plot(gx, np.exp(mu), label=f"{m} model")
            ax.fill_between(gx, np.exp(mu - 1.645 * sd), np.exp(mu + 1.645 * sd),
                            color=line.get_color(), alpha=0.2, lw=0)
            est = ds["error_estimate"].sel(model=m).values.ravel()
            err = ds["error_estimate_err"].sel(model=m).values.ravel()
            ax.errorbar(px, np.maximum(est, meta["floor"]), yerr=err, fmt="o",
                        color=line.get_color(), ms=4, capsize=2)
            if floor is not None:
                ax.plot(px, floor.sel(model=m).values.ravel(), "_", color=line.get_color(),
                        ms=8)
            band = ds["surface_band"].sel(model=m).values == 1
            ax.fill_between(gx, 0, 1, where=band, transform=ax.get_xaxis_transform(),
                            color=line.get_color(), alpha=0.08, hatch="//", lw=0)
        ax.axhline(tol, color="0.3", ls="--", label=f"tolerance {tol:g}")
        ax.set_yscale("log")
        ax.set_xlabel(xl)
        ax.set_ylabel("error estimate (noise removed)")
        ax.legend(fontsize=8)
        return base64.b64encode(png_bytes(fig, dpi=110, bbox_inches="tight")).decode()
    gy, yl = axis(names[1], ds[GRID_PREFIX + names[1]].values)
    if point_dims != ["point"]:
        py, _ = axis(names[1], ds[names[1]].broadcast_like(ds["error_estimate"].isel(model=0))
                     .transpose(*point_dims).values.ravel())
    else:
        py, _ = axis(names[1], ds[names[1]].values)
    surf = np.asarray(ds["surface_error"].sel(model=models).values, float)
    vmin, vmax = float(np.nanmin(surf)), float(np.nanmax(surf))
    norm = LogNorm(min(vmin, tol), max(vmax, tol * 1.0001))
    X, Y = np.meshgrid(gx, gy, indexing="ij")
    mesh = None
    for ax, m in zip(axs[0], models, strict=True):
        z = ds["surface_error"].sel(model=m).values
        p = ds["surface_p_inside"].sel(model=m).values
        mesh = ax.pcolormesh(X, Y, z, norm=norm, cmap="viridis", shading="gouraud")
        ax.contourf(X, Y, p, levels=[lo, hi], colors=["white"], alpha=0.25)
        ax.contourf(X, Y, p, levels=[lo, hi], colors="none", hatches=["///"])
        ax.contour(X, Y, p, levels=[lo, hi], colors="white", linewidths=0.6,
                   linestyles=":")
        ax.contour(X, Y, p, levels=[0.5], colors="white", linewidths=2)
        fl = (floor.sel(model=m).transpose(*point_dims).values.ravel() if floor is not None
              else np.full(px.size, tol / 4))
        size = 5 + 20 * np.clip(fl / tol, 0, 2)
        cls = (own_cls.sel(model=m).transpose(*point_dims).values.ravel()
               if own_cls is not None else np.full(px.size, ""))
        for c, kw in (("inside", {"marker": "o", "facecolors": "white",
                                  "edgecolors": "black", "linewidths": 0.5}),
                      ("outside", {"marker": "o", "facecolors": "black",
                                   "edgecolors": "white", "linewidths": 0.5}),
                      ("undecided", {"marker": "^", "facecolors": "0.6",
                                     "edgecolors": "black", "linewidths": 0.5})):
            sel = cls == c
            if sel.any():
                ax.scatter(px[sel], py[sel], s=size[sel], clip_on=False, **kw)
            if ax is axs[0][0]:  # the legend's keys, every class whether present or not
                ax.scatter([], [], s=12, label=c, **kw)
        fit = meta["models"][str(m)]
        ax.set_title(f"{m} model: band {100 * fit['band_area']:.0f}% of the map", fontsize=10)
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
    axs[0][0].legend(fontsize=7, loc="best", title="the point's own verdict",
                     title_fontsize=7)
    bar = fig.colorbar(mesh, ax=axs[0].tolist(), label=f"error surface (tolerance {tol:g})")
    bar.ax.axhline(tol, color="white", lw=2)
    return base64.b64encode(png_bytes(fig, dpi=110, bbox_inches="tight")).decode()


def with_surfaces(ds: Any) -> Any:
    """``ds`` with every model's error surface (dataset_surfaces, add_surfaces) and the notes
    of the models without one in the attribute ``surface_notes`` (one line each, ``; ``)."""
    try:
        import sklearn  # noqa: F401
    except ImportError:
        ds.attrs["surface_notes"] = ("no error surface: scikit-learn is not installed (pip "
                                     "install scikit-learn)")
        return ds
    surfaces, notes = dataset_surfaces(ds)
    if surfaces:
        ds = add_surfaces(ds, surfaces)
    if notes:
        ds.attrs["surface_notes"] = "; ".join(notes)
    return ds
