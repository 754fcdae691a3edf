"""harness/sweeps/bandrun.py: band sweeps (issue 29, item 3) -- the sweep file's contract (fast)
and (slow) a small real band sweep whose extension continues a point's Monte Carlo from its
checkpoint, keeps one state file a point, and resumes without computing anything again."""

from __future__ import annotations

import json

import numpy as np
import pytest
from vifpk.harness.sweeps.errors import SweepError
from vifpk.harness.sweeps.spec import load_sweep

from tests.conftest import ROOT

DATA = ROOT / "tests" / "data"
BAND_SWEEP = DATA / "sweep-band.toml"
BAND_RUN = DATA / "sweep-band-run.toml"  # the same sweep with cheaper points, for the slow test


def _write(tmp_path, extra: str, tolerance: bool = True):
    text = BAND_SWEEP.read_text().replace('scene = "tiny.toml"', f'scene = "{DATA / "tiny.toml"}"')
    if not tolerance:
        text = text.replace("tolerance = 0.03\n", "")
    text = text.replace("[adaptive]\n", "[adaptive]\n" + extra)
    p = tmp_path / "s.toml"
    p.write_text(text)
    return p


def test_band_is_the_default_with_a_tolerance(tmp_path):
    assert load_sweep(BAND_SWEEP).adaptive["method"] == "band"
    assert load_sweep(DATA / "sweep-adaptive.toml").adaptive["method"] == "verdict"
    assert load_sweep(_write(tmp_path, 'method = "verdict"\n')).adaptive["method"] == "verdict"


@pytest.mark.parametrize("extra, tolerance, words", [
    ('method = "band"\n', False, "give tolerance = VALUE"),
    ('method = "straddle"\n', True, "allowed: verdict, band"),
])
def test_bad_method_one_line(tmp_path, extra, tolerance, words):
    with pytest.raises(SweepError, match=words) as exc:
        load_sweep(_write(tmp_path, extra, tolerance))
    assert "\n" not in str(exc.value)


@pytest.mark.slow
def test_band_sweep_extends_from_the_checkpoint_and_resumes(tmp_path, monkeypatch):
    """Batch 1 is forced to extend the lattice's first point (the choice is band.py's, tested
    in tests/test_band.py): its extension record continues the same Monte Carlo (path-steps
    add up, the floor falls below the target), one state file is kept a point, sweep.nc holds
    the extension's numbers with mc_stage 1, a second run computes nothing and writes the
    same sweep.nc, and the same sweep on processes:2 gives the same points and numbers."""
    import xarray as xr
    from vifpk.harness.sweeps import band
    from vifpk.harness.sweeps.runs import run_sweep

    real = band.choose
    calls = []

    forced_key = []

    def forced(sf, cands, size, **kw):
        calls.append(len(cands))
        ext = [c for c in cands if c.key is not None]
        if len(calls) == 1:
            forced_key.append(ext[0].key)
            return [band.Choice(unit=ext[0].unit, key=ext[0].key, gain=0.0, cost=ext[0].cost)]
        return real(sf, cands, size, **kw)

    monkeypatch.setattr(band, "choose", forced)
    sweep = load_sweep(BAND_RUN)
    assert sweep.adaptive["method"] == "band"
    out = tmp_path / "out"
    first = run_sweep(sweep, out, quiet=True, report=False)
    pts = out / "points"
    # the forced extension; the real choices after it may extend others (issue 39, B43: the
    # rest of the budget goes to what it affords, cheap extensions, not to one new point
    # whatever its cost)
    key = forced_key[0]
    ext = [pts / f"{key}.ext1.json"]
    assert ext[0].exists()
    r0 = json.loads((pts / f"{key}.json").read_text())["result"]
    r1 = json.loads(ext[0].read_text())["result"]
    assert r1["mc_path_steps"] == r0["mc_path_steps"] + r1["mc_path_steps_run"]
    target = r0["models"]["exact"]["L1_floor_A"] * np.sqrt(band.EXTEND_VARIANCE)
    assert r1["models"]["exact"]["L1_floor_A"] <= target
    assert not (pts / f"{key}.state0.npz").exists() and (pts / f"{key}.state1.npz").exists()
    stage0 = [p for p in pts.glob("*.json") if ".ext" not in p.name]
    assert len(list(pts.glob("*.npz"))) == len(stage0)  # one state file a point
    ds = xr.open_dataset(out / "sweep.nc")
    i = list(ds.key.values).index(key)
    assert int(ds.mc_stage[i]) == 1
    assert float(ds.L1_floor_A.sel(model="exact")[i]) == r1["models"]["exact"]["L1_floor_A"]
    before = ds.load()
    ds.close()
    calls.clear()  # the replay makes the same (forced) first choice
    again = run_sweep(sweep, out, quiet=True, report=False)
    assert again.computed == () and again.total == first.total
    with xr.open_dataset(out / "sweep.nc") as ds2:
        for v in ("error_estimate", "L1_floor_A", "mc_path_steps", "surface_p_inside"):
            np.testing.assert_array_equal(ds2[v].values, before[v].values)
    calls.clear()
    run_sweep(sweep, tmp_path / "pool", executor="processes:2", quiet=True, report=False)
    with xr.open_dataset(tmp_path / "pool" / "sweep.nc") as ds3:
        assert list(ds3.key.values) == list(before.key.values)
        for v in ("error_estimate", "error_estimate_err", "L1_floor_A", "mc_stage"):
            np.testing.assert_array_equal(ds3[v].values, before[v].values)


def test_a_failed_extension_keeps_the_points_last_good_stage():
    """An extension whose Monte Carlo fails (a numerical failure is a record, replayed alike on
    a resume) leaves the point's numbers and stage as they were, and the point is not offered
    for extension again (else a replay would choose it for ever)."""
    from vifpk.harness.sweeps.bandrun import _State

    st = _State(None, "exact")
    good = {"key": "k", "stage": 1, "status": "ok", "result": {"mc_path_steps_run": 5.0}}
    st.take(good)
    st.take({"key": "k", "stage": 2, "status": "failed", "failure": "numerical",
             "message": "blew up", "result": None})
    assert st.stage["k"] == 1 and st.recs["k"] is good
    assert "k" in st.failed_extension and st.spent == 5.0
