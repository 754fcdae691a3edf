"""sweep.nc: the points' records as one labelled dataset (xarray), its attributes the
sweep's provenance; and the sweep's outputs written as units (sweep.nc, maps, report.html).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from vifpk.harness.sweeps.points import SDE_CHECK_EVERY, WARNING_FLAGS, Point, Sweep
from vifpk.harness.sweeps.store import (
    _tolerance,
    load_record,
    record_name,
    stage_fingerprint,
)
from vifpk.harness.sweeps.timesweep import SCALARS as TIME_SCALARS


# --------------------------------------------------------------------------------------------
def dataset(sweep: Sweep, records: Mapping[str, dict[str, Any]], *,
            provenance: Mapping[str, Any] | None = None) -> Any:
    """The labelled result (xarray.Dataset) from the points' records."""
    import numpy as np
    import xarray as xr

    if sweep.mode == "product":
        dims = list(sweep.names)
        shape = tuple(len(v) for _, v in sweep.vary)
        coords: dict[str, Any] = {k: (k, np.array(v)) for k, v in sweep.vary}

        def index(pt: Point) -> tuple[int, ...]:
            return tuple(vals.index(v) for (_, vals), (_, v) in zip(sweep.vary, pt.params,
                                                                    strict=True))
    else:  # zip and adaptive: the parameters as coordinates along a point dimension
        dims = ["point"]
        shape = (len(sweep.points),)
        coords = {k: ("point", np.array([dict(pt.params)[k] for pt in sweep.points]))
                  for k in sweep.names}
        order = {pt.key: i for i, pt in enumerate(sweep.points)}

        def index(pt: Point) -> tuple[int, ...]:
            return (order[pt.key],)

    recs = [(pt, records.get(pt.key)) for pt in sweep.points]
    models: list[str] = []
    for _, r in recs:
        for m in (r or {}).get("result", {}).get("models", {}):
            if m not in models:
                models.append(m)
    data: dict[str, Any] = {}

    def put(name: str, value: Any, pt: Point, model: str | None = None,
            dtype: Any = float, fill: Any = np.nan) -> None:
        if name not in data:
            s = shape + ((len(models),) if model is not None else ())
            data[name] = (dims + (["model"] if model is not None else []),
                          np.full(s, fill, dtype=dtype))
        idx = index(pt) + ((models.index(model),) if model is not None else ())
        data[name][1][idx] = fill if value is None else value

    status = np.full(shape, "missing", dtype=object)
    message = np.full(shape, "", dtype=object)
    keys = np.full(shape, "", dtype=object)
    seeds = np.zeros(shape, dtype=np.int64)
    for pt, r in recs:
        i = index(pt)
        keys[i], seeds[i] = pt.key, pt.seed
        if r is None:
            continue
        status[i], message[i] = r["status"], r.get("message", "")
        res = r.get("result")
        if res is None:
            continue
        for m, vals in res.get("models", {}).items():
            for k, v in vals.items():
                if isinstance(v, bool):
                    put(k, int(v), pt, m, dtype=np.int8, fill=-1)
                elif isinstance(v, str):
                    put(k, v, pt, m, dtype=object, fill="")
                else:
                    put(k, v, pt, m)
        for k in ("mean_A_simulation", "mean_A_simulation_err", "L1_paper_exact_A",
                  *TIME_SCALARS):
            if k in res:
                put(k, res[k], pt)
        if "recommended_model" in res:  # check's recommendation (issue 23): a string per point
            put("recommended_model", res["recommended_model"], pt, dtype=object, fill="")
        if "extensions" in res:
            put("extensions", res["extensions"], pt, dtype=np.int16, fill=-1)
        if "converged" in res:
            put("converged", int(res["converged"]), pt, dtype=np.int8, fill=-1)
        for k in ("mc_path_steps", "mc_sampled_steps"):
            if k in res:
                put(k, res[k], pt)
        if "stage" in r:  # band sweeps: how often the point's Monte Carlo was extended
            put("mc_stage", r["stage"], pt, dtype=np.int16, fill=-1)
        for k, v in res.get("flags", {}).items():
            put(k, int(v), pt, dtype=np.int8, fill=-1)
    if sweep.workflow == "bifurcation":
        width = max([len((r or {}).get("result", {}).get("mc_check", [])) for _, r in recs]
                    + [0])
        vals = np.full(shape + (width,), np.nan)
        crater = np.full(shape + (width,), -1, dtype=np.int8)
        agrees = np.full(shape + (width, len(models)), -1, dtype=np.int8)
        for pt, r in recs:
            for j, c in enumerate((r or {}).get("result", {}).get("mc_check", [])):
                vals[index(pt) + (j,)] = c["value"]
                crater[index(pt) + (j,)] = int(c["crater"])
                for mi, m in enumerate(models):
                    agrees[index(pt) + (j, mi)] = int(c["agrees"].get(m, False))
        data["mc_check_value"] = (dims + ["check"], vals)
        data["mc_check_crater"] = (dims + ["check"], crater)
        data["mc_check_agrees"] = (dims + ["check", "model"], agrees)
    for k, (d, arr) in list(data.items()):
        if arr.dtype == object:
            data[k] = (d, arr.astype(str))
    data["failed"] = (dims, (status == "failed").astype(np.int8))
    data["status"] = (dims, status.astype(str))
    data["message"] = (dims, message.astype(str))
    data["key"] = (dims, keys.astype(str))
    data["seed"] = (dims, seeds)
    if sweep.mode == "adaptive":
        data["batch"] = (dims, np.array([pt.batch for pt in sweep.points], dtype=np.int16))
    if models:
        coords["model"] = ("model", np.array(models))
    ds = xr.Dataset(data, coords=coords)
    for k in WARNING_FLAGS:
        if k in ds:
            ds[k].attrs["flag_values"] = "1: the warning applies, 0: it does not, -1: no value"
    if "sampling_ok" in ds:
        ds["sampling_ok"].attrs["flag_values"] = (
            "1: the averaged SDE's Monte Carlo matches its closed form, 0: it does not, -1: not "
            f"run at this point (it runs at the first point and where int(key, 16) % "
            f"{SDE_CHECK_EVERY} == 0)")
    ds.attrs.update({
        "title": f"vifpk sweep {sweep.name}",
        "workflow": sweep.workflow, "mode": sweep.mode, "seed": sweep.seed,
        "varied": json.dumps(list(sweep.names)),
        "sweep_file": sweep.text, "sweep_path": sweep.path,
        "base_scene": json.dumps(sweep.base.to_dict()),
        "seed_scheme": "montecarlo.seed of a point = SeedSequence([seed, *le32 words of "
                       "sha256(canonical params)]).generate_state(1, uint64)[0] >> 2",
    })
    if sweep.workflow == "bifurcation":
        ds.attrs["bifurcation"] = json.dumps(dict(sweep.bifurcation))
    if sweep.workflow in ("passage", "transient"):
        ds.attrs[sweep.workflow] = json.dumps(dict(sweep.bifurcation))
    if sweep.mode == "adaptive":
        ds.attrs["adaptive"] = json.dumps({**sweep.adaptive, "ranges": {
            k: list(v) for k, v in sweep.vary}})
        ds["batch"].attrs["meaning"] = ("0: the initial lattice; n: the n-th refinement batch "
                                        "(harness/sweeps/adaptive.py)")
    if sweep.workflow == "check":
        ds.attrs["within_noise"] = ("a model is within the Monte Carlo noise where "
                                    "averaging_error_A < 2 L1_floor_A (the check's verdict)")
        tol = _tolerance(sweep)
        ds.attrs["tolerance"] = tol.value
        ds.attrs["tolerance_metric"] = tol.metric
        ds.attrs["tolerance_observable"] = tol.observable
        ds.attrs["tolerance_confidence"] = tol.confidence
        ds.attrs["tolerance_meaning"] = (
            f"the question: {tol.words()}; error_estimate: {tol.metric} of "
            f"p({tol.observable}) with the Monte Carlo noise removed, sqrt(max(d^2 - floor^2, "
            "0)); p_within_tolerance: P(error <= tolerance); tolerance_class: inside / outside "
            "/ undecided at that confidence (harness/workflows/tolerance.py)")
    if provenance is not None:
        ds.attrs["provenance"] = json.dumps(dict(provenance))
        ds.attrs["versions"] = json.dumps(provenance.get("versions", {}))
        ds.attrs["vifpk_version"] = str(provenance.get("vifpk", ""))
    return ds


def write_netcdf(ds: Any, path: Path) -> Path:
    """Write a Dataset atomically (temporary file beside it, then rename). The temporary file
    is created with mode 0666 minus the umask, as every other output (netCDF keeps the mode of
    the file it overwrites; ``tempfile`` would give 0600)."""
    from vifpk.core.io import atomic_path

    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4")
    return path


def write_results(sweep: Sweep, out: Path, *, executor: str = "", report: bool = True,
                  provenance: Mapping[str, Any] | None = None,
                  stages: Mapping[str, int] | None = None) -> dict[str, Path]:
    """DIR/sweep.nc (and DIR/report.html) from the records on disk; ``stages``: the record
    of each point's ``stages[key]``-th extension (band sweeps), else its first."""
    from vifpk.core import provenance as prov

    records = {}
    for pt in sweep.points:
        stage = (stages or {}).get(pt.key, 0)
        rec = load_record(out / "points" / record_name(pt.key, stage))
        if rec and rec.get("fingerprint") == stage_fingerprint(pt.fingerprint, stage):
            records[pt.key] = rec
    if provenance is None:
        provenance = prov.collect(scene_path=sweep.path)
    ds = dataset(sweep, records, provenance={**provenance, "executor": executor})
    if sweep.surface and sweep.workflow == "check":  # the file asks a tolerance: its surface
        from vifpk.harness.sweeps.surfacemaps import with_surfaces

        ds = with_surfaces(ds)
    files = {"sweep.nc": write_netcdf(ds, out / "sweep.nc")}
    if report:
        from vifpk.harness.sweeps.maps import write_maps

        files["report.html"] = write_maps(sweep, ds, out)
    return files
