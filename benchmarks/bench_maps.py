"""Validity maps against a dense reference (issue 29, item 4): the area each method
misclassifies, its band, its points and CPU seconds.

    python benchmarks/bench_maps.py --reference REF.nc --tolerance 0.04 \\
        --method NAME=SWEEP.nc=CPU_SECONDS [--method ...] [--out benchmarks/results/maps.json]

The reference is a dense grid sweep at a floor well below the tolerance
(benchmarks/r-mu-reference.toml: 40 x 40 at floor 0.01 for T = 0.04). Its classification is
its own error surface (harness/sweeps/surface.py: the Gaussian process of the log error with
each point's error bar) on the common 101 x 101 grid of the ranges: inside where
P(L1 <= T) > 1/2; its own band (5-95%) is reported as the reference's uncertainty.

Each method's map is classified the same way from its own points (error_estimate and its
error bar of the exact model; for a sweep made before the tolerance verdict existed, the
verdict is computed from its stored L1, error bar and floor, harness/workflows/tolerance.py).
For a sweep with the old verdict (adaptive.py: "within the noise", L1 < 2 x floor) the area
that verdict misclassifies is reported too ("verdict"): f = log(L1 / 2 floor) interpolated
linearly between the points (nearest outside their hull), inside where f < 0 -- the old
map's white contour.

Misclassified area = share of the 101 x 101 grid where a method's class differs from the
reference's. CPU seconds are what the caller measured for the sweep (``/usr/bin/time``'s user
+ system of ``vifpk sweep``), written beside it.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
import xarray as xr
from vifpk.harness.request.tolerance import Tolerance
from vifpk.harness.sweeps.surface import Axis, fit_surface
from vifpk.harness.workflows.tolerance import tolerance_verdict

MODEL = "exact"
AXES = (Axis(name="system.r", lo=0.95, hi=0.99), Axis(name="system.mu", lo=0.0, hi=0.004))


def _points(ds: xr.Dataset) -> np.ndarray:
    if "point" in ds.dims:
        return np.column_stack([ds[a.name].values for a in AXES])
    r, mu = np.meshgrid(ds[AXES[0].name].values, ds[AXES[1].name].values, indexing="ij")
    return np.column_stack([r.ravel(), mu.ravel()])


def _flat(ds: xr.Dataset, name: str) -> np.ndarray:
    return ds[name].sel(model=MODEL).values.ravel()


def estimates(ds: xr.Dataset, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """(error_estimate, its error bar) per point: stored, or from L1, err and floor."""
    if "error_estimate" in ds and float(ds.attrs.get("tolerance", math.nan)) == tol:
        return _flat(ds, "error_estimate"), _flat(ds, "error_estimate_err")
    L1, err, floor = (_flat(ds, k) for k in ("averaging_error_A", "averaging_error_A_err",
                                             "L1_floor_A"))
    est, se = np.full(L1.size, np.nan), np.full(L1.size, np.nan)
    for i in range(L1.size):
        if np.isfinite(L1[i]) and np.isfinite(floor[i]):
            v = tolerance_verdict({"L1": L1[i], "L1_err": err[i], "L1_floor": floor[i]},
                                  Tolerance(value=tol))
            est[i], se[i] = v["error_estimate"], v["error_estimate_err"]
    return est, se


def surface_class(ds: xr.Dataset, tol: float) -> tuple[np.ndarray, float, int, object]:
    """(inside on the grid, band area, points, the surface) from the sweep's own points."""
    x = _points(ds)
    est, se = estimates(ds, tol)
    sf = fit_surface(x, est, se, tolerance=tol, axes=AXES)
    return sf.p_inside > 0.5, sf.band_area, int(np.isfinite(est).sum()), sf


def figure(path: str, ref_sf: object, fits: dict[str, tuple[object, np.ndarray, object]],
           tol: float) -> None:
    """The reference's P(inside) with its boundary (white), each method's boundary over it,
    and the points of each method (one panel a method)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(fits)
    fig, axs = plt.subplots(1, n, figsize=(4.6 * n + 1, 4.2), squeeze=False,
                            constrained_layout=True)
    r, mu = ref_sf.grid
    for ax, (name, (sf, pts, verdict)) in zip(axs[0], fits.items(), strict=True):
        im = ax.pcolormesh(1 - r, mu, ref_sf.p_inside.T, cmap="RdBu", vmin=0, vmax=1,
                           shading="auto")
        ax.contour(1 - r, mu, ref_sf.p_inside.T, levels=[0.5], colors="white", linewidths=2.5)
        ax.contour(1 - r, mu, sf.p_inside.T, levels=[0.5], colors="black", linewidths=1.5)
        ax.contourf(1 - r, mu, sf.band.T.astype(float), levels=[0.5, 1.5], colors="none",
                    hatches=["////"])
        if verdict is not None:
            ax.contour(1 - r, mu, verdict.T.astype(float), levels=[0.5], colors="orange",
                       linewidths=1.2, linestyles="--")
        ax.plot(1 - pts[:, 0], pts[:, 1], ".", color="k", ms=2.5)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("impact loss 1 - r")
        ax.set_ylabel("mu")
    fig.colorbar(im, ax=axs[0, -1], label=f"reference P(exact L1(A) <= {tol:g})")
    fig.suptitle("white: the reference's boundary; black: the method's, hatched its 5-95% "
                 "band; orange dashed: the old verdict L1 < 2 floor", fontsize=9)
    fig.savefig(path, dpi=110)


def verdict_class(ds: xr.Dataset, grid: np.ndarray) -> np.ndarray:
    """The old verdict (L1 < 2 floor) interpolated between the points (module docstring)."""
    from scipy.interpolate import griddata

    x = _points(ds)
    u = np.column_stack([a.unit(x[:, k]) for k, a in enumerate(AXES)])
    f = np.log(_flat(ds, "averaging_error_A") / (2 * _flat(ds, "L1_floor_A")))
    ok = np.isfinite(f)
    lin = griddata(u[ok], f[ok], grid, method="linear")
    near = griddata(u[ok], f[ok], grid, method="nearest")
    return np.where(np.isfinite(lin), lin, near) < 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", required=True)
    ap.add_argument("--tolerance", type=float, default=0.04)
    ap.add_argument("--method", action="append", default=[],
                    help="NAME=SWEEP.nc=CPU_SECONDS")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "maps.json"))
    ap.add_argument("--figure", default=None, help="also draw the maps over the reference")
    args = ap.parse_args(argv)
    tol = args.tolerance
    ref = xr.open_dataset(args.reference).load()
    ref_in, ref_band, ref_n, ref_sf = surface_class(ref, tol)
    fits = {}
    n = ref_in.shape[0]
    g = np.linspace(0.0, 1.0, n)
    gu, gv = np.meshgrid(g, g, indexing="ij")
    grid = np.column_stack([gu.ravel(), gv.ravel()])
    out = {"tolerance": tol, "model": MODEL, "grid": f"{n} x {n}",
           "reference": {"file": args.reference, "points": ref_n,
                         "inside_area": float(ref_in.mean()), "band_area": ref_band,
                         "floor": float(np.nanmedian(_flat(ref, "L1_floor_A")))},
           "methods": {}}
    for spec in args.method:
        name, path, cpu = spec.split("=")
        ds = xr.open_dataset(path).load()
        inside, band, pts, sf = surface_class(ds, tol)
        verdict = None
        row = {"file": path, "points": pts, "cpu_seconds": float(cpu),
               "misclassified_area": float(np.mean(inside != ref_in)),
               "band_area": band, "inside_area": float(inside.mean()),
               "floors": [float(np.nanmin(_flat(ds, "L1_floor_A"))),
                          float(np.nanmax(_flat(ds, "L1_floor_A")))]}
        if "mc_path_steps" in ds:
            row["mc_path_steps"] = float(np.nansum(ds["mc_path_steps"].values))
        if "mc_stage" in ds:
            row["extended_points"] = int((ds["mc_stage"].values > 0).sum())
            row["extensions"] = int(np.clip(ds["mc_stage"].values, 0, None).sum())
        adaptive = json.loads(ds.attrs.get("adaptive", "{}"))
        if ds.attrs.get("mode") == "adaptive" and adaptive.get("method", "verdict") == "verdict":
            verdict = verdict_class(ds, grid).reshape(ref_in.shape)
            row["verdict_misclassified_area"] = float(np.mean(verdict != ref_in))
        fits[name] = (sf, _points(ds), verdict)
        out["methods"][name] = row
        print(name, json.dumps(row), file=sys.stderr)
    Path(args.out).write_text(json.dumps(out, indent=1) + "\n")
    if args.figure:
        figure(args.figure, ref_sf, fits, tol)
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
