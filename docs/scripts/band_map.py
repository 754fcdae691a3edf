"""Draw the shipped band-sweep map (docs/data/maps-r-mu-band.nc, issue 29) as
docs/img/maps-r-mu-band.png: the three models' error surfaces, boundaries and bands, as
report.html draws them (harness/sweeps/surfacemaps.py). No new Monte Carlo.

    python docs/scripts/band_map.py
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import xarray as xr
from vifpk.harness.sweeps.surfacemaps import surface_figure

ROOT = Path(__file__).resolve().parents[2]


def main() -> int:
    ds = xr.open_dataset(ROOT / "docs" / "data" / "maps-r-mu-band.nc").load()
    meta = json.loads(ds.attrs["surface"])
    for m, info in meta.get("models", {}).items():
        print(m, {k: info[k] for k in info if k.endswith("area")})
    dest = ROOT / "docs" / "img" / "maps-r-mu-band.png"
    dest.write_bytes(base64.b64decode(surface_figure(ds)))
    print(dest)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
