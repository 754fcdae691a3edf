"""harness/sweeps/surface.py: the error surface, P(inside) and the 5-95% band, on a synthetic map
whose true error surface, boundary and noise are known (issue 29, items 2 and 4).

The synthetic map: unit square (u, v), tolerance T = 0.02, true error

    L(u, v) = T exp(2 (u - b(v))),     b(v) = 0.35 + 0.3 v^2 - 0.15 sin(3 v),

so the true boundary L = T is the curve u = b(v) (from u = 0.35 at v = 0 to 0.63 at v = 1,
bending back near v = 0.3), and L runs from 0.2 T to 3.7 T over the map. The points are a
7 x 7 lattice (the adaptive sweep's initial design at 196 points), each observed as
L_obs = max(L + e, 0), e ~ N(0, s_i^2) with the known heteroscedastic error bar
s_i = noise x T x (0.5 + v_i) passed as error_estimate_err; the max(., 0) is what the debiasing
of tolerance.py does to an estimate below its noise.
"""

from __future__ import annotations

import base64
import json
import math

import numpy as np
import pytest

pytest.importorskip("sklearn", reason="scikit-learn: the sweep and test extras")

from vifpk.harness.sweeps.surface import (  # noqa: E402
    BAND,
    FLOOR_FRACTION,
    Axis,
    SurfaceError,
    axes_for,
    fit_surface,
    log_spaced,
)
from vifpk.harness.sweeps.surfacemaps import (  # noqa: E402
    POINT_VARS,
    add_surfaces,
    dataset_surfaces,
    resolved_error,
    surface_figure,
)

T = 0.02
AXES = (Axis(name="u", lo=0.0, hi=1.0), Axis(name="v", lo=0.0, hi=1.0))
_G = np.linspace(0.0, 1.0, 7)
LATTICE = np.column_stack([a.ravel() for a in np.meshgrid(_G, _G, indexing="ij")])
NOMINAL = BAND[1] - BAND[0]  # a true boundary point is in the band with this probability


def _b(v):
    return 0.35 + 0.3 * v**2 - 0.15 * np.sin(3 * v)


def _log_truth(u, v):
    return math.log(T) + 2.0 * (u - _b(v))


def _observe(noise: float, seed: int, x: np.ndarray = LATTICE):
    rng = np.random.default_rng(seed)
    s = noise * T * (0.5 + x[:, 1])
    return np.maximum(np.exp(_log_truth(x[:, 0], x[:, 1])) + rng.normal(0.0, s), 0.0), s


def _scores(noise: float, seed: int, resolution: int = 61) -> dict[str, float]:
    """One synthetic map: the band's coverage of the true boundary (201 points along it), the
    misclassified area (grid cells where P > 1/2 disagrees with L <= T) and the band's area."""
    obs, s = _observe(noise, seed)
    surf = fit_surface(LATTICE, obs, s, tolerance=T, axes=AXES, resolution=resolution)
    vb = np.linspace(0.0, 1.0, 201)
    p = surf.probability(np.column_stack([_b(vb), vb]))
    gu, gv = np.meshgrid(*surf.grid, indexing="ij")
    truth = _log_truth(gu, gv) <= math.log(T)
    return {"coverage": float(np.mean((p > BAND[0]) & (p < BAND[1]))),
            "misclassified": float(np.mean((surf.p_inside > 0.5) != truth)),
            "band": surf.band_area}


@pytest.mark.slow
def test_surface_recovers_known_boundary_and_shrinks_with_noise():
    """The misclassified area falls as the noise falls (3 seeds a level, means), and with
    little noise the estimated boundary is close to the true one. Noise levels 0.3, 0.1, 0.03
    x T; measured (seeds 0-2, 61 x 61 grid): misclassified 0.025 -> 0.0099 -> 0.0027 of the
    map, band 0.115 -> 0.044 -> 0.016. The bound asserted at the lowest noise, 0.02 of the
    map, is the area of a strip 0.02 wide along the boundary (length about 1): a boundary off
    by 2% of the range."""
    levels = (0.3, 0.1, 0.03)
    runs = [[_scores(n, seed) for seed in range(3)] for n in levels]
    mis = [np.mean([r["misclassified"] for r in level]) for level in runs]
    band = [np.mean([r["band"] for r in level]) for level in runs]
    assert mis[0] > mis[1] > mis[2], mis
    assert band[0] > band[1] > band[2], band
    assert mis[2] < 0.02, mis


@pytest.mark.slow
def test_band_covers_true_boundary_at_nominal_rate():
    """Coverage of the true boundary by the 5-95% band over 25 seeds at the highest and the
    lowest noise level, against the nominal 90% (module docstring: a boundary point is in the
    band iff the pointwise 90% interval of log L covers the truth).

    Tolerance: each seed's coverage is a fraction of the boundary (201 points, strongly
    correlated along it), the seeds are independent, so the mean over seeds has the standard
    error SE = sd(per-seed coverage) / sqrt(25) (measured 0.025-0.05). The assertion is
    |mean - 0.90| < 3 SE + 0.03: 3 SE for the sampling of seeds, and 0.03 for what the
    method knowingly neglects (the hyperparameters' uncertainty, type-II ML, which narrows
    the band; the linearisation of exp(g) at the surface). Measured (2026-11-24, seeds 0-39,
    21 x 21 grid, about 8 s a level): coverage 0.951 (SE 0.020) at noise 0.3 T, 0.935
    (0.023) at 0.1 T, 0.934 (0.022) at 0.03 T: the band is a little wider than nominal, on the
    safe side; the worst seed's band held 39% of the boundary. Since 2026-11-28 the middle
    level and seeds 25-39 are left out to halve the suite's longest test (59 s in CI): the
    three levels behaved alike, and the fast test above covers all three. Measured then (seeds
    0-24): 0.932 (SE 0.031) at 0.3 T, 0.917 (SE 0.032) at 0.03 T."""
    for noise in (0.3, 0.03):
        cov = np.array([_scores(noise, seed, resolution=21)["coverage"] for seed in range(25)])
        se = cov.std(ddof=1) / math.sqrt(cov.size)
        assert abs(cov.mean() - NOMINAL) < 3 * se + 0.03, (noise, cov.mean(), se)


def test_one_dimension_and_log_axis():
    """1-D: L(x) = T exp(3 (x - 0.4)) over x in [1e-3, 1e-1] on a log axis (x enters through
    log10 x mapped to [0, 1]); the boundary is the one crossing at 10^(-3 + 2 x 0.4)."""
    xs = np.logspace(-3, -1, 9)
    assert log_spaced(xs) and not log_spaced(np.linspace(1e-3, 1e-1, 9))
    (ax,) = axes_for(["D"], [xs])
    assert ax.log
    unit = ax.unit(xs)
    L = T * np.exp(3.0 * (unit - 0.4))
    surf = fit_surface(xs[:, None], L, 0.02 * L, tolerance=T, axes=(ax,))
    assert surf.log_error.shape == (400,)
    (crossing,) = surf.boundary
    assert crossing.shape == (1, 1)
    assert math.log10(crossing[0, 0]) == pytest.approx(-3 + 2 * 0.4, abs=0.01)
    assert np.all(np.diff(surf.p_inside) <= 1e-12)  # error grows with x: P(inside) falls


def test_deterministic():
    """The same points give the same surface, bit for bit (fixed restarts' seed)."""
    obs, s = _observe(0.1, 7)
    a = fit_surface(LATTICE, obs, s, tolerance=T, axes=AXES, resolution=21)
    b = fit_surface(LATTICE, obs, s, tolerance=T, axes=AXES, resolution=21)
    assert np.array_equal(a.log_error, b.log_error)
    assert np.array_equal(a.log_error_sd, b.log_error_sd)
    assert a.hyperparameters == b.hyperparameters


def test_per_point_numbers_and_boundary_shape():
    obs, s = _observe(0.1, 3)
    own = np.linspace(0, 1, obs.size)
    surf = fit_surface(LATTICE, obs, s, tolerance=T, axes=AXES, resolution=41,
                       p_within_tolerance=own)
    assert np.array_equal(surf.error_estimate, obs)
    assert np.array_equal(surf.error_estimate_err, s)
    assert np.array_equal(surf.p_within_tolerance, own)  # the points' own, as given
    # the surface at the points: inside where the truth is well inside, outside where well out
    lt = _log_truth(LATTICE[:, 0], LATTICE[:, 1]) - math.log(T)
    assert np.all(surf.surface_p_within_tolerance[lt < -0.5] > 0.95)
    assert np.all(surf.surface_p_within_tolerance[lt > 0.5] < 0.05)
    # one boundary curve from v = 0 to v = 1, within 0.05 of the true one
    (line,) = surf.boundary
    assert line[:, 1].min() == pytest.approx(0.0) and line[:, 1].max() == pytest.approx(1.0)
    assert np.max(np.abs(line[:, 0] - _b(line[:, 1]))) < 0.05
    assert surf.band.shape == surf.p_inside.shape == (41, 41)


def test_all_zero_errors():
    """Every estimate 0 (every point below its noise). With error bars s = 1e-3 each point
    reads "about s / e, give or take a factor e" (module docstring), so the surface sits at
    s / e = 3.7e-4, inside the tolerance with P > 0.999; with no error bars (0 +/- 0) it sits
    at the stated floor FLOOR_FRACTION x T and every point is marked floored."""
    x = LATTICE[::4]
    surf = fit_surface(x, np.zeros(len(x)), np.full(len(x), 1e-3), tolerance=T, axes=AXES,
                       resolution=11)
    assert np.allclose(surf.error, 1e-3 / math.e, rtol=1e-3)
    assert np.all(surf.p_inside > 0.999) and not surf.floored.any()
    assert surf.boundary == ()
    surf = fit_surface(x, np.zeros(len(x)), np.zeros(len(x)), tolerance=T, axes=AXES,
                       resolution=11)
    assert np.all(surf.floored)
    assert np.allclose(surf.error, FLOOR_FRACTION * T, rtol=1e-3)
    assert np.all(surf.p_inside > 0.999)


@pytest.mark.parametrize(("kwargs", "words"), [
    ({"points": [[0.1, 0.2], [0.3, 0.4]], "error_estimate": [0.1, 0.1],
      "error_estimate_err": [0.01, 0.01]}, "2 points with an error estimate; at least 3"),
    ({"error_estimate": [0.1, -0.1, 0.1]}, "must be >= 0"),
    ({"tolerance": 0.0}, "tolerance must be a number > 0"),
    ({"axes": AXES * 2}, "one or two varied parameters, not 4"),
    ({"error_estimate": [0.1, 0.1]}, "they must agree"),
])
def test_bad_input_one_line(kwargs, words):
    args = {"points": [[0.1, 0.2], [0.3, 0.4], [0.5, 0.9]], "error_estimate": [0.1, 0.2, 0.3],
            "error_estimate_err": [0.01, 0.01, 0.01], "tolerance": T, "axes": AXES}
    args.update(kwargs)
    with pytest.raises(SurfaceError) as exc:
        fit_surface(args.pop("points"), args.pop("error_estimate"),
                    args.pop("error_estimate_err"), **args)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_axis_range_checked():
    with pytest.raises(SurfaceError, match="needs lo < hi"):
        Axis(name="x", lo=1.0, hi=1.0)
    with pytest.raises(SurfaceError, match="log axis needs values > 0"):
        Axis(name="x", lo=0.0, hi=1.0, log=True)


# --- sweep.nc and the maps -------------------------------------------------------------------


def _sweep_ds(mode: str = "product", names=("system.r", "system.mu")):
    """A check sweep's Dataset as sweep.dataset writes it (the variables the surface reads),
    from the synthetic truth on the unit square mapped to r in [0.95, 0.99], mu in [0, 0.004];
    model "bad" has only two points with an estimate."""
    xr = pytest.importorskip("xarray")
    lo, hi = np.array([0.95, 0.0]), np.array([0.99, 0.004])
    obs, s = _observe(0.1, 5)
    est = np.stack([obs, np.where(np.arange(obs.size) < 2, obs, np.nan)], axis=-1)
    err = np.stack([s, s], axis=-1)
    floor = np.full(est.shape, 0.01)
    cls = np.where(est < T, "inside", "outside")
    data = {"error_estimate": est, "error_estimate_err": err, "p_within_tolerance": est * 0 + 0.5,
            "tolerance_class": cls, "averaging_error_A_err": err, "L1_floor_A": floor}
    params = lo + LATTICE * (hi - lo)
    attrs = {"varied": json.dumps(list(names)), "tolerance": T, "mode": mode,
             "workflow": "check"}
    if mode == "product":
        shape = (7, 7, 2)
        coords = {names[0]: params[::7, 0], names[1]: params[:7, 1]}
        dims = [names[0], names[1], "model"]
        data = {k: (dims, v.reshape(shape)) for k, v in data.items()}
    else:
        attrs["adaptive"] = json.dumps({"ranges": {names[0]: [0.95, 0.99],
                                                   names[1]: [0.0, 0.004]}})
        coords = {names[0]: ("point", params[:, 0]), names[1]: ("point", params[:, 1])}
        data = {k: (["point", "model"], v) for k, v in data.items()}
    coords["model"] = ["exact", "bad"]
    return xr.Dataset(data, coords=coords, attrs=attrs)


@pytest.mark.parametrize("mode", ["product", "adaptive"])
def test_sweep_dataset_carries_the_surface(mode, tmp_path):
    """dataset_surfaces + add_surfaces: the fine grid, P(inside) and the band per model, the
    surface at the points, the fit as an attribute; netCDF round trip; the map draws."""
    ds = _sweep_ds(mode)
    surfaces, notes = dataset_surfaces(ds, resolution=31)
    assert list(surfaces) == ["exact"]
    assert notes == ["bad model: no error surface: surface: 2 points with an error estimate; "
                     "at least 3 are needed for a surface"]
    out = add_surfaces(ds, surfaces)
    assert out["surface_p_inside"].dims == ("surface.system.r", "surface.system.mu", "model")
    assert out["surface_p_inside"].shape == (31, 31, 2)
    assert np.all(out["surface_band"].sel(model="bad").values == -1)
    assert np.all(np.isnan(out["surface_error"].sel(model="bad").values))
    assert out["surface.system.r"].values[[0, -1]] == pytest.approx([0.95, 0.99])
    for k in POINT_VARS:
        assert out[k].dims == ds["error_estimate"].dims
    # the surface at the points agrees with the truth's side where the truth is clear
    lt = (_log_truth(LATTICE[:, 0], LATTICE[:, 1]) - math.log(T)).reshape(
        out["surface_p_within_tolerance"].sel(model="exact").shape)
    p = out["surface_p_within_tolerance"].sel(model="exact").values
    assert np.all(p[lt < -0.5] > 0.9) and np.all(p[lt > 0.5] < 0.1)
    meta = json.loads(out.attrs["surface"])
    assert set(meta["models"]) == {"exact"} and meta["band"] == list(BAND)
    pytest.importorskip("netCDF4")
    out.to_netcdf(tmp_path / "s.nc", engine="netcdf4")
    png = surface_figure(out)
    assert base64.b64decode(png)[:8] == b"\x89PNG\r\n\x1a\n"


def test_sweep_dataset_surface_one_parameter_and_three():
    xr = pytest.importorskip("xarray")
    x = np.linspace(0.0, 1.0, 9)
    L = T * np.exp(3.0 * (x - 0.4))
    ds = xr.Dataset({k: (["system.mu", "model"], v[:, None]) for k, v in (
        ("error_estimate", L), ("error_estimate_err", 0.05 * L),
        ("p_within_tolerance", 0.5 + 0 * L), ("L1_floor_A", 0.01 + 0 * L),
        ("averaging_error_A_err", 0.05 * L))},
        coords={"system.mu": x, "model": ["exact"]},
        attrs={"varied": json.dumps(["system.mu"]), "tolerance": T, "mode": "product"})
    surfaces, notes = dataset_surfaces(ds)
    out = add_surfaces(ds, surfaces)
    assert out["surface_p_inside"].dims == ("surface.system.mu", "model") and not notes
    assert base64.b64decode(surface_figure(out))[:4] == b"\x89PNG"
    ds.attrs["varied"] = json.dumps(["a", "b", "c"])
    assert dataset_surfaces(ds) == ({}, ["no error surface: 3 varied parameters (it needs one "
                                         "or two)"])


def test_resolved_error_below_the_resolution():
    """An estimate 0 +/- 0 (tolerance.py's interval clamped at 0) enters as 0 +/- r,
    r = sqrt(2 F sigma + sigma^2); an estimate above r keeps its own error."""
    r = math.sqrt(2 * 0.01 * 0.002 + 0.002**2)
    got = resolved_error([0.0, 0.05], [0.0, 0.003], [0.002, 0.002], [0.01, 0.01])
    assert got == pytest.approx([r, 0.003])
