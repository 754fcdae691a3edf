"""Redraw a shipped verdict map as a tolerance map (issue 29 item 2): each point's tolerance
verdict at T from its stored L1, error bar and noise floor (harness/workflows/tolerance.py),
then every model's error surface, boundary and 5-95% band (harness/sweeps/surfacemaps.py). No
new Monte Carlo.

    python docs/scripts/surface_map.py    # docs/data/maps-r-mu-adaptive.nc at T = 0.02 ->
                                          # docs/img/maps-r-mu-adaptive-surface.png
    python docs/scripts/surface_map.py NAME T   # docs/data/maps-NAME.nc at T ->
                                                # docs/img/maps-NAME-surface.png
Prints the inside and band areas per model.
"""

from __future__ import annotations

import base64
import json
import sys
from pathlib import Path

import numpy as np
import xarray as xr
from vifpk.harness.request.tolerance import Tolerance
from vifpk.harness.sweeps.surfacemaps import surface_figure, with_surfaces
from vifpk.harness.workflows.tolerance import tolerance_verdict

ROOT = Path(__file__).resolve().parents[2]

def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    name = argv[0] if argv else "r-mu-adaptive"
    TOL = float(argv[1]) if len(argv) > 1 else 0.02  # noqa: N806 - the module's default's name
    ds = xr.open_dataset(ROOT / "docs" / "data" / f"maps-{name}.nc").load()
    tol = Tolerance(value=TOL)
    names = ("error_estimate", "error_estimate_err", "p_within_tolerance")
    out = {k: np.full(ds["averaging_error_A"].shape, np.nan) for k in names}
    cls = np.full(ds["averaging_error_A"].shape, "", dtype=object)
    L1, err, floor = (ds[k].values for k in ("averaging_error_A", "averaging_error_A_err",
                                             "L1_floor_A"))
    for idx in np.ndindex(L1.shape):
        if np.isfinite(L1[idx]) and np.isfinite(floor[idx]):
            v = tolerance_verdict({"L1": L1[idx], "L1_err": err[idx], "L1_floor": floor[idx]},
                                  tol)
            for k in names:
                out[k][idx] = v[k]
            cls[idx] = v["class"]
    dims = ds["averaging_error_A"].dims
    ds = ds.assign({**{k: (dims, v) for k, v in out.items()}, "tolerance_class": (dims, cls)})
    ds.attrs.update(tolerance=TOL, tolerance_metric="L1", tolerance_observable="A")
    ds = with_surfaces(ds)
    meta = json.loads(ds.attrs.get("surface", "{}"))
    for m in ds["model"].values:
        band = ds["surface_band"].sel(model=m).values
        p = ds["surface_p_inside"].sel(model=m).values
        ok = np.isfinite(p)
        print(f"{m}: inside {np.mean(p[ok] >= 0.5):.3f} of the map, band "
              f"{np.mean(band[ok] == 1):.3f}", meta.get("models", {}).get(str(m), ""))
    print(ds.attrs.get("surface_notes", ""))
    png = surface_figure(ds)
    dest = ROOT / "docs" / "img" / f"maps-{name}-surface.png"
    dest.write_bytes(base64.b64decode(png))
    print(dest)
    return 0


if __name__ == "__main__":
    sys.exit(main())
