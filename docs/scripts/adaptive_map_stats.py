"""The numbers docs/maps.md quotes for an adaptive check sweep over (system.r, system.mu):
points within the Monte Carlo noise per model and per band of impact loss 1 - r, and how finely
the target model's validity boundary is resolved (the Delaunay triangles whose corners
disagree on the verdict, their longest edge against the diagonal of one cell of an N x N grid
over the same ranges, in units of the ranges).

    python docs/scripts/adaptive_map_stats.py docs/data/maps-r-mu-adaptive.nc [--grid 40]

Within the noise: averaging_error_A < 2 x L1_floor_A (the sweep's own rule, its attribute
``within_noise``); the target model is the sweep file's [adaptive] model.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np
import xarray as xr
from scipy.spatial import Delaunay

BANDS = (0.0, 0.0125, 0.015, 0.02, 0.03, 1.0)  # bands of 1 - r


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep_nc")
    ap.add_argument("--grid", type=int, default=40)
    a = ap.parse_args()
    ds = xr.open_dataset(a.sweep_nc).load()
    target = json.loads(ds.attrs["adaptive"])["model"]
    ok = ds["status"].values == "ok"
    within = (ds["averaging_error_A"] < 2 * ds["L1_floor_A"]).values & ok[:, None]
    models = [str(m) for m in ds["model"].values]
    n = int(ds.sizes["point"])
    print(f"{n} points ({int(ok.sum())} ok), batches {int(ds['batch'].max()) + 1}")
    for i, m in enumerate(models):
        print(f"  {m}: within the noise at {int(within[:, i].sum())} of {n}")
    r, mu = ds["system.r"].values, ds["system.mu"].values
    loss = 1.0 - r
    t = models.index(target)
    for lo, hi in zip(BANDS[:-1], BANDS[1:], strict=True):
        sel = (loss >= lo - 1e-12) & (loss < hi - 1e-12)
        print(f"  1 - r in [{lo:g}, {hi:g}): {target} within at {int(within[sel, t].sum())}"
              f" of {int(sel.sum())}")
    u = np.column_stack([(r - r.min()) / np.ptp(r), (mu - mu.min()) / np.ptp(mu)])
    tri = Delaunay(u).simplices
    v = within[:, t]
    mixed = [s for s in tri if v[s].any() and not v[s].all()]
    longest = np.array([max(np.hypot(*(u[s[i]] - u[s[j]])) for i, j in ((0, 1), (1, 2), (0, 2)))
                        for s in mixed])
    diag = math.sqrt(2) / (a.grid - 1)
    print(f"  boundary triangles: {len(mixed)}; longest edge below the {a.grid} x {a.grid} "
          f"cell diagonal ({diag:.3f}) in {100 * np.mean(longest <= diag):.0f}%; "
          f"median {np.median(longest):.3f}, longest {longest.max():.3f}")
    err = ds["averaging_error_A"].values
    for i, m in enumerate(models):
        print(f"  {m}: L1(A) {np.nanmin(err[ok, i]):.3f}-{np.nanmax(err[ok, i]):.3f}")
    fl = ds["L1_floor_A"].values[ok, t]
    print(f"  noise floors of L1(A): {fl.min():.4f}-{fl.max():.4f}")


if __name__ == "__main__":
    main()
