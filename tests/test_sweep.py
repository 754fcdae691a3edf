"""Sweeps (issue 14): validation up front, seeds from parameters, resume, executors bit for bit,
a lost dask worker, failed points recorded."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from vifpk.harness.cli.app import main
from vifpk.harness.sweeps.errors import SweepError
from vifpk.harness.sweeps.runs import run_sweep
from vifpk.harness.sweeps.spec import load_sweep

from tests.conftest import ROOT
from vifpk.core.defaults import CHECK_MODELS as MODELS

DATA = ROOT / "tests" / "data"
CHECK = DATA / "sweep-check.toml"
AVERAGING = DATA / "sweep-averaging-fast.toml"  # every point computed: the cheaper grid


def _write(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    (tmp_path / "tiny.toml").write_text((DATA / "tiny.toml").read_text())
    p = tmp_path / name
    p.write_text(text)
    return p


def _values(path: Path):
    """The data of a sweep.nc without its attributes (provenance differs run to run)."""
    import xarray as xr

    with xr.open_dataset(path, engine="netcdf4") as ds:
        ds.load()
        ds.attrs = {}
        return ds


GOOD = 'scene = "tiny"\nworkflow = "averaging"\n[vary]\n"system.r" = [0.95, 0.97]\n'
BAD = {
    "unknown top key": ('scene = "tiny"\nworkflw = "check"\n[vary]\n"system.r" = [0.95]\n',
                        "workflw"),
    "unknown varied key": ('scene = "tiny"\n[vary]\n"system.rr" = [0.95]\n', "system.rr"),
    "unknown set key": (GOOD + '[set]\n"montecarlo.flor" = 0.01\n', "montecarlo.flor"),
    "empty grid (list)": ('scene = "tiny"\n[vary]\n"system.r" = []\n', "empty grid"),
    "empty grid (range)": ('scene = "tiny"\n[vary]\n"system.mu" = {start = 0, stop = 1, '
                           'num = 0}\n', "empty grid"),
    "no [vary]": ('scene = "tiny"\n', "[vary]"),
    "out of range at one point": ('scene = "tiny"\n[vary]\n"system.r" = [0.95, 1.2]\n'
                                  '"system.mu" = [0.0, 0.001]\n', "system.r = 1.2"),
    "out of range in [set]": (GOOD + '[set]\n"noise.D" = -1.0\n', "noise.D"),
    "unknown workflow": ('scene = "tiny"\nworkflow = "chek"\n[vary]\n"system.r" = [0.95]\n',
                         "workflow"),
    "unknown mode": ('scene = "tiny"\nmode = "outer"\n[vary]\n"system.r" = [0.95]\n', "mode"),
    "zip of unequal lengths": ('scene = "tiny"\nmode = "zip"\n[vary]\n"system.r" = [0.95]\n'
                               '"system.mu" = [0.0, 0.001]\n', "zip"),
    "seed set per point": (GOOD + '[set]\n"montecarlo.seed" = 3\n', "montecarlo.seed"),
    "wall-clock budget": (GOOD + '[set]\n"montecarlo.budget" = 10.0\n', "montecarlo.budget"),
    "unknown scene": ('scene = "nope"\n[vary]\n"system.r" = [0.95]\n', "nope"),
    "bifurcation without find": ('scene = "tiny"\nworkflow = "bifurcation"\n[vary]\n'
                                 '"system.r" = [0.95]\n', "find"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_sweep_file_exit_2_one_line_nothing_written(case, tmp_path, capsys):
    text, word = BAD[case]
    path = _write(tmp_path, text)
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and word in err, err
    assert not out.exists()


@pytest.mark.parametrize("executor,word", [("threads:2", "unknown executor"),
                                           ("processes:0", "N must be"),
                                           ("dask:100000", "cores of this machine"),
                                           ("tcp://127.0.0.1:1", "no dask scheduler"),
                                           ("tcp://::1:8786", "PORT in 1-65535"),
                                           ("tcp://localhost:99999", "PORT in 1-65535"),
                                           ("tcp://host/p:8786", "PORT in 1-65535")])
def test_bad_executor_exit_2_one_line_nothing_written(executor, word, tmp_path, capsys):
    """tcp://127.0.0.1:1: nothing listens on port 1 (the connection is refused)."""
    path = _write(tmp_path, GOOD)
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--executor", executor]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and word in err, err
    assert not out.exists()


def test_dask_without_the_cluster_extra_names_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import fails as if not installed
    path = _write(tmp_path, GOOD)
    assert main(["sweep", str(path), "--out", str(tmp_path / "o"), "--executor", "dask:2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "vifpk[cluster]" in err, err


def test_seeds_and_keys_follow_parameters_not_positions(tmp_path):
    """The same parameters give the same key and seed whatever the grid around them; another
    sweep seed gives other seeds."""
    a = load_sweep(_write(tmp_path, GOOD, "a.toml"))
    b = load_sweep(_write(tmp_path, GOOD.replace("[0.95, 0.97]", "[0.97, 0.96, 0.95]")
                          + '"system.mu" = [0.001]\n', "b.toml"))
    c = load_sweep(_write(tmp_path, "seed = 5\n" + GOOD, "c.toml"))
    pa = {p.params: (p.key, p.seed) for p in a.points}
    pb = {p.params[:1]: p.seed for p in b.points}
    # the scheme docs/maps.md publishes (and sweep.nc's seed_scheme attribute), written out
    # here from its words, not through the package's point_seed / point_key
    text = f'[["system.r", "{(0.95).hex()}"]]'
    digest = hashlib.sha256(text.encode()).digest()
    words = [int.from_bytes(digest[i:i + 4], "little") for i in range(0, 32, 4)]
    seed = int(np.random.SeedSequence([a.seed, *words]).generate_state(1, np.uint64)[0]) >> 2
    assert pa[(("system.r", 0.95),)] == (hashlib.sha256(text.encode()).hexdigest()[:16], seed)
    assert pb[(("system.r", 0.95),)] != pa[(("system.r", 0.95),)][1]  # mu is a parameter too
    assert {p.seed for p in c.points}.isdisjoint({p.seed for p in a.points})
    assert [p.scene.montecarlo.seed for p in a.points] == [p.seed for p in a.points]
    again = load_sweep(_write(tmp_path, GOOD.replace("[0.95, 0.97]", "[0.97, 0.95]"), "d.toml"))
    assert {p.params: (p.key, p.seed) for p in again.points} == pa


@pytest.fixture(scope="module")
def serial_check(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    res = run_sweep(load_sweep(CHECK), out, executor="serial", quiet=True, report=False)
    assert len(res.computed) == 4 and not res.failed
    return out


# the tests of serial_check on one xdist worker (CI: --dist loadgroup): the sweep is made once
@pytest.mark.slow  # eight real check points (Monte Carlo), serial and on a LocalCluster
@pytest.mark.xdist_group("check-sweep")
def test_local_cluster_equals_serial_bit_for_bit(serial_check, tmp_path):
    """A real LocalCluster on loopback (2 worker processes, 1 numba thread each) against the
    serial run: every variable identical, NaN for NaN (the check workflow: Monte Carlo with
    seeds from the parameters)."""
    res = run_sweep(load_sweep(CHECK), tmp_path, executor="dask:2", quiet=True, report=False)
    assert len(res.computed) == 4
    a, b = _values(serial_check / "sweep.nc"), _values(tmp_path / "sweep.nc")
    assert {"averaging_error_A", "averaging_error_A_err", "L1_floor_A", "mean_A",
            "mean_A_simulation", "converged", "warn_narrow_band", "warn_sticking",
            "warn_strong_damping", "warn_strong_noise", "warn_not_converged"} <= set(a)
    assert a.sizes == {"system.r": 2, "system.mu": 2, "model": len(MODELS)}
    assert (a["status"] == "ok").all()
    a.identical(b) or pytest.fail(f"sweep.nc differ:\n{a}\n{b}")
    umask = os.umask(0)
    os.umask(umask)
    for nc in (serial_check / "sweep.nc", tmp_path / "sweep.nc"):  # as every other output
        assert nc.stat().st_mode & 0o777 == 0o666 & ~umask, oct(nc.stat().st_mode)


@pytest.fixture
def canned_check_sweep(canned_check, tmp_path):
    """The 2 x 2 check sweep run serially on the canned tiny check (tests/conftest.py): what
    the sweep does with each point's result, without computing one."""
    res = run_sweep(load_sweep(CHECK), tmp_path, executor="serial", quiet=True, report=False)
    assert len(res.computed) == 4 and not res.failed
    return tmp_path


def test_check_sweep_writes_every_variable_of_every_point(canned_check_sweep):
    ds = _values(canned_check_sweep / "sweep.nc")
    assert {"averaging_error_A", "averaging_error_A_err", "L1_floor_A", "mean_A",
            "mean_A_simulation", "converged", "warn_narrow_band", "warn_sticking",
            "warn_strong_damping", "warn_strong_noise", "warn_not_converged",
            "warn_correlated_noise", "recommended_model"} <= set(ds)
    assert set(ds["recommended_model"].values.ravel().tolist()) <= {"exact", "corrected",
                                                                       "none"}
    assert ds.sizes == {"system.r": 2, "system.mu": 2, "model": len(MODELS)}
    assert (ds["status"] == "ok").all()


@pytest.mark.parametrize("source", ["canned", pytest.param("computed", marks=pytest.mark.slow)])
@pytest.mark.xdist_group("check-sweep")
def test_sde_check_only_at_sampled_points(source, request):
    """The averaged SDEs' Monte Carlo runs at the first point and where the key is divisible by
    SDE_CHECK_EVERY (chosen by the parameters alone); sampling_ok is -1 elsewhere. On the
    canned check (fast tier) and on the real serial sweep (slow tier)."""
    from vifpk.harness.sweeps.points import SDE_CHECK_EVERY

    folder = request.getfixturevalue("canned_check_sweep" if source == "canned"
                                     else "serial_check")
    sweep = load_sweep(CHECK)
    ds = _values(folder / "sweep.nc")
    assert sweep.points[0].sde
    for pt in sweep.points:
        # the rule docs/maps.md states, against what the written sweep.nc holds
        sampled = pt is sweep.points[0] or int(pt.key, 16) % SDE_CHECK_EVERY == 0
        ok = ds["sampling_ok"].sel(dict(pt.params)).values
        assert (ok >= 0).all() if sampled else (ok == -1).all(), (pt.params, ok)


@pytest.mark.slow
def test_interrupted_sweep_resumes_with_only_the_rest(tmp_path):
    """Ctrl-C (SIGINT) after two points: exit 130, no sweep.nc; the second run (on a process
    pool) computes only the points without a record and leaves the kept records untouched."""
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_NUM_THREADS": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "vifpk", "sweep", str(AVERAGING),
                             "--out", str(out), "--quiet"], env=env, cwd=tmp_path,
                            stderr=subprocess.PIPE, text=True,
                            # a test run started in the background inherits SIGINT ignored
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    t0 = time.monotonic()
    while len(list((out / "points").glob("[!.]*.json"))) < 2 and time.monotonic() - t0 < 120:
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "run the same command again" in err
    assert not (out / "sweep.nc").exists()
    kept = {p.stem: p.stat().st_mtime_ns for p in (out / "points").glob("[!.]*.json")}
    sweep = load_sweep(AVERAGING)
    assert 2 <= len(kept) < len(sweep.points), "the sweep ended before it was interrupted"
    res = run_sweep(sweep, out, executor="processes:2", quiet=True, report=False)
    assert res.skipped == len(kept)
    assert sorted(res.computed) == sorted({p.key for p in sweep.points} - set(kept))
    assert {k: (out / "points" / f"{k}.json").stat().st_mtime_ns for k in kept} == kept
    assert (_values(out / "sweep.nc")["status"] == "ok").all()
    again = run_sweep(sweep, out, quiet=True, report=False)
    assert again.computed == () and again.skipped == len(sweep.points)


@pytest.mark.slow  # a real dask LocalCluster: two worker processes import the whole stack
def test_killed_dask_worker_loses_and_duplicates_no_point(tmp_path):
    """SIGKILL one of two workers while it runs a point: dask reschedules it; every point is
    computed and recorded exactly once."""
    from distributed import Client, LocalCluster

    sweep = load_sweep(AVERAGING)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        result = {}
        th = threading.Thread(target=lambda: result.update(run=run_sweep(
            sweep, tmp_path, executor=cluster.scheduler_address, quiet=True, report=False)))
        th.start()
        killed = None
        t0 = time.monotonic()
        while killed is None and time.monotonic() - t0 < 120:
            busy = [w for w, keys in client.processing().items()
                    if any(str(k).startswith("vifpk-") for k in keys)]
            if busy and list((tmp_path / "points").glob("[!.]*.json")):
                pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
                os.kill(pid, signal.SIGKILL)
                killed = busy[0]
            time.sleep(0.05)
        th.join(timeout=300)
    assert killed is not None, "no worker was busy with a point"
    run = result["run"]
    keys = [p.key for p in sweep.points]
    assert sorted(run.computed) == sorted(keys)  # each exactly once
    assert sorted(p.stem for p in (tmp_path / "points").glob("[!.]*.json")) == sorted(keys)
    assert (_values(tmp_path / "sweep.nc")["status"] == "ok").all()


def test_failed_point_is_recorded_and_the_sweep_goes_on(tmp_path, capsys):
    """f = 0 has no stationary density: that point fails with its message, the other is
    computed, sweep.nc flags it, and the exit code is 3 (never 0 with a missing value)."""
    path = _write(tmp_path, 'scene = "tiny"\nworkflow = "averaging"\n[vary]\n'
                            '"system.f" = [0.0, 1.0]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--quiet"]) == 3
    ds = _values(out / "sweep.nc")
    assert ds["failed"].values.tolist() == [1, 0]
    assert "f = 0" in str(ds["message"].values[0])
    assert ds["mean_A"].isnull().values[0].all() and ds["mean_A"].notnull().values[1].all()
    assert "1 of 2 points failed" in capsys.readouterr().err
    again = run_sweep(load_sweep(path), out, quiet=True, report=False)
    assert again.computed == () and len(again.failed) == 1  # a numerical failure is a result
    page = (out / "report.html").read_text()
    assert "data:image/png;base64," in page and "src='http" not in page


def test_the_grid_map_boundary_is_the_cell_edges_between_verdicts():
    """An isolated cell within the noise is enclosed by exactly its four edges (the maps drew
    an interpolated contour that broke into dashes on coarse grids; issue 20 G); an unknown
    (failed) neighbour draws no edge."""
    import numpy as np
    from vifpk.harness.sweeps.maps import _edges, _verdict_boundary

    from vifpk.core.io import figures

    plt = figures()

    inside = np.zeros((3, 3), bool)
    inside[1, 1] = True
    xe, ye = _edges(np.array([1.0, 2.0, 3.0])), _edges(np.array([10.0, 20.0, 30.0]))
    fig, ax = plt.subplots()
    _verdict_boundary(ax, inside, np.ones((3, 3), bool), xe, ye)
    (lines,) = ax.collections
    segs = {tuple(map(tuple, np.round(s, 9))) for s in lines.get_segments()}
    assert segs == {((1.5, 15.0), (1.5, 25.0)), ((2.5, 15.0), (2.5, 25.0)),
                    ((1.5, 15.0), (2.5, 15.0)), ((1.5, 25.0), (2.5, 25.0))}
    known = np.ones((3, 3), bool)
    known[1, 2] = False
    ax.clear()
    _verdict_boundary(ax, inside, known, xe, ye)
    assert len(ax.collections[0].get_segments()) == 3
    plt.close(fig)



@pytest.mark.slow
def test_a_check_sweep_carries_the_tolerance_verdict(canned_check, tmp_path):
    """`tolerance` in a check sweep (issue 29): per point and model the error with the noise
    removed, its error, P(error <= tolerance) and the class, and the tolerance as an
    attribute; refused with one line outside the check workflow or out of range."""
    import xarray as xr
    from vifpk.harness.sweeps.errors import SweepError

    text = CHECK.read_text().replace('seed = 11', 'seed = 11\ntolerance = 0.05')
    f = _write(tmp_path, text)
    sw = load_sweep(f)
    assert sw.tolerance == 0.05 and sw.surface
    pytest.importorskip("sklearn")
    run_sweep(sw, tmp_path / "out", executor="serial", quiet=True, report=True)
    with xr.open_dataset(tmp_path / "out" / "sweep.nc", engine="netcdf4") as ds:
        ds.load()
    assert ds.attrs["tolerance"] == 0.05
    # the file asks a tolerance: the error surface is fitted and drawn (issue 29 item 2)
    p_in = ds["surface_p_inside"].values
    assert np.all((p_in[np.isfinite(p_in)] >= 0) & (p_in[np.isfinite(p_in)] <= 1))
    assert "surface_p_within_tolerance" in ds and "surface" in ds.attrs
    assert "error surface at tolerance 0.05" in (tmp_path / "out" / "report.html").read_text()
    for k in ("error_estimate", "error_estimate_err", "p_within_tolerance", "tolerance_class"):
        assert k in ds, k
    assert set(ds["tolerance_class"].values.ravel()) <= {"inside", "outside", "undecided"}
    for bad in ("tolerance = -1", 'tolerance = "x"',
                'tolerance = 0.1\nworkflow = "averaging"'):
        f = _write(tmp_path, text.replace("tolerance = 0.05", bad).replace(
            'workflow = "check"\n', "" if "averaging" in bad else 'workflow = "check"\n'))
        with pytest.raises(SweepError, match="tolerance"):
            load_sweep(f)


def test_a_check_sweep_takes_the_whole_tolerance_question(canned_check, tmp_path):
    """Review of issue 29: sweeps took the tolerance's value only; a table gives the metric,
    the observable and the confidence too, checked like --tolerance-*, written as sweep.nc
    attributes; a changed question changes the points' fingerprints (no stale verdicts on a
    resume), the default one keeps them."""
    text = CHECK.read_text()
    base = load_sweep(_write(tmp_path, text, "base.toml"))
    q = text.replace("seed = 11", 'seed = 11\ntolerance = {value = 0.05, metric = "ks", '
                     'confidence = 0.9}')
    sw = load_sweep(_write(tmp_path, q, "q.toml"))
    assert sw.tolerance == 0.05 and sw.tolerance_question == ("ks", "A", 0.9)
    assert all(a.fingerprint != b.fingerprint for a, b in zip(base.points, sw.points,
                                                              strict=True))
    same = load_sweep(_write(tmp_path, text.replace("seed = 11", "seed = 11\ntolerance = 0.02"),
                             "same.toml"))
    assert [p.fingerprint for p in same.points] == [p.fingerprint for p in base.points]
    for bad, needle in (('tolerance = {value = 0.05, metric = "L7"}', "--tolerance-metric"),
                        ("tolerance = {value = 0.05, confidence = 1.5}", "--confidence"),
                        ("tolerance = {valu = 0.05}", "tolerance.valu: unknown key")):
        with pytest.raises(SweepError, match=needle):
            load_sweep(_write(tmp_path, text.replace("seed = 11", f"seed = 11\n{bad}"),
                              "bad.toml"))


def test_a_model_without_values_is_labelled_not_left_blank(canned_check_sweep, monkeypatch):
    """Issue 28 (day-one path): where a model has no value at any point (the paper model
    outside its family) its panel says so instead of staying blank."""
    import xarray as xr
    from vifpk.harness.sweeps import maps

    with xr.open_dataset(canned_check_sweep / "sweep.nc", engine="netcdf4") as ds:
        ds.load()
    first = str(ds["model"].values[0])
    ds["averaging_error_A"].loc[{"model": first}] = np.nan
    labelled = []
    monkeypatch.setattr(maps, "_no_values", lambda ax: labelled.append(ax.get_title()))
    figs = maps.figures(ds)
    assert figs and len(labelled) == 1, labelled


def test_the_sweep_report_table_gives_each_models_error_and_verdict(canned_check, tmp_path):
    """Issue 28 (day-one path): the sweep report's table had the status only; a check sweep's
    gives per point and model L1(A) ± its error bar [floor] and the verdict."""
    import html

    run_sweep(load_sweep(CHECK), tmp_path, executor="serial", quiet=True, report=True)
    text = html.unescape((tmp_path / "report.html").read_text())
    assert "exact: L1(A) ± err [floor], verdict" in text
    table = text[text.index("<h2>Points</h2>"):text.index("<h2>Sweep file</h2>")]
    assert table.count(" ± ") >= 4 and "[" in table


@pytest.mark.slow
def test_a_sweep_over_the_hour_by_its_measured_rate_stops_with_its_records(
        tmp_path, monkeypatch, capsys):
    """Issue 28: `points = 2000` was estimated under the hour and ran 10 minutes for 279 points.
    The estimate (a lower bound) is now checked against the run's own rate: here the hour is
    made 1e-3 s (and the estimate 0, so the sweep starts): after 3 points (max(3, workers))
    the projection is over it, so the command stops, exit 2, one line naming the measured
    rate and --yes; the 3 records are kept, no sweep.nc, and --yes computes only the rest."""
    from vifpk.harness.cli.app import main
    from vifpk.harness.request import cost
    from vifpk.harness.sweeps import store

    monkeypatch.setattr(store, "sweep_seconds", lambda *a, **k: 0.0)
    monkeypatch.setattr(cost, "HOUR", 1e-3)
    out = tmp_path / "out"
    assert main(["sweep", str(AVERAGING), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "a point" in err[0] and "--yes" in err[0], err
    kept = sorted(p.stem for p in (out / "points").glob("[!.]*.json"))
    assert len(kept) == 3 and not (out / "sweep.nc").exists()
    assert main(["sweep", str(AVERAGING), "--out", str(out), "--quiet", "--yes"]) == 0
    assert "3 computed, 3 done before" in capsys.readouterr().out


def test_scattered_map_markers_are_drawn_whole_at_the_range_s_edge(canned_check_sweep,
                                                                   monkeypatch):
    """Issue 28: the adaptive map's points on the range's edge were half-clipped by the axes.
    The canned 2 x 2 check sweep's points (all four on the corners of their range) laid out as
    an adaptive sweep's (a ``point`` dimension): every marker of the scattered map is drawn
    unclipped (its figure captured before it becomes a PNG)."""
    import matplotlib.lines
    import vifpk.harness.sweeps.maps as maps
    import xarray as xr

    with xr.open_dataset(canned_check_sweep / "sweep.nc", engine="netcdf4") as ds:
        ds.load()
    flat = ds.stack(point=("system.r", "system.mu")).reset_index("point")
    flat.attrs["mode"] = "adaptive"
    figs = []
    real = maps._png

    def capture(fig):
        figs.append(fig)
        return real(fig)

    monkeypatch.setattr(maps, "_png", capture)
    assert any(caption.startswith("Adaptive sweep") for caption, _ in maps.figures(flat))
    markers = [a for f in figs for ax in f.axes for a in ax.get_children()
               if isinstance(a, matplotlib.lines.Line2D)
               and a.get_marker() not in (None, "None", "") and len(a.get_xdata())]
    assert markers, "no marker drawn"
    assert not [m for m in markers if m.get_clip_on()]
