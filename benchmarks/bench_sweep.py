"""What a sweep point costs, and what the executors add: points per minute with ``serial``,
``processes:2`` and ``dask:2`` on one small check sweep of the paper's base scene, the dask
overhead per point, and the extrapolated cost of a 40 x 40 map at floor 0.01.

    python benchmarks/bench_sweep.py [--floor F] [--quick]   # writes benchmarks/results/sweep.json

1. The same sweep (paper-base, workflow "check", 3 x 2 points in (r, mu), target floor F,
   dt "auto") on each executor, from a cold start of the executor (pool or cluster start-up
   included, numba's on-disk cache warm), into a fresh directory: wall seconds, points per
   minute, and the overhead per point = (wall x workers - sum of the points' own seconds) /
   points (start-up, scheduling, serialisation and the idle tail). The three sweep.nc must be
   identical (checked).
2. dask's own overhead per point: 200 no-op tasks through the same submit / as_completed path
   on a LocalCluster of 2 workers (round trip per task), and the cluster's start-up time.
3. The cost of one point at floor 0.01 (two points of scenes/sweeps/r-mu.toml, serially), and
   the 40 x 40 map extrapolated from it: 1600 x seconds per point / workers.
4. The point against the bare Monte Carlo of the same point at floor 0.01, in one run
   (point_against_bare; issue 22: at most 1.5x). ``--point-only`` runs just this part.

The machine is shared (the load average is recorded): the numbers are upper bounds.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ["PYTHONPATH"] = os.pathsep.join(  # worker processes import this checkout
    [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])

from vifpk.harness.sweeps.executors import Runner, parse_executor  # noqa: E402
from vifpk.harness.sweeps.runs import run_sweep  # noqa: E402
from vifpk.harness.sweeps.spec import load_sweep  # noqa: E402

SWEEP = """scene = "paper-base"
workflow = "check"
seed = 1
[vary]
"system.r" = [0.95, 0.97, 0.99]
"system.mu" = [0.0, 0.002]
[set]
"montecarlo.floor" = {floor}
"montecarlo.dt" = "auto"
"""


def _noop(x: int) -> int:
    return x


def executor_rows(floor: float, work: Path) -> dict:
    path = work / "bench.toml"
    path.write_text(SWEEP.format(floor=floor))
    sweep = load_sweep(path)
    rows = {}
    data = {}
    for ex in ("serial", "processes:2", "dask:2"):
        out = work / ex.replace(":", "-")
        shutil.rmtree(out, ignore_errors=True)
        t0 = time.perf_counter()
        res = run_sweep(sweep, out, executor=ex, quiet=False, report=False)
        wall = time.perf_counter() - t0
        recs = [json.loads((out / "points" / f"{k}.json").read_text()) for k in res.computed]
        own = sum(r["seconds"] for r in recs)
        workers = 1 if ex == "serial" else 2
        n = len(res.computed)
        rows[ex] = {"points": n, "wall_seconds": wall, "points_per_minute": 60 * n / wall,
                    "point_seconds_mean": own / n,
                    "overhead_per_point_seconds": (wall * workers - own) / n}
        import xarray as xr

        with xr.open_dataset(out / "sweep.nc") as ds:
            ds.load()
            ds.attrs = {}
            data[ex] = ds
        print(ex, rows[ex], file=sys.stderr, flush=True)
    rows["identical_sweep_nc"] = all(data["serial"].identical(d) for d in data.values())
    ref = data["serial"]
    rows["differing_variables"] = {ex: sorted(k for k in ref.data_vars
                                              if not ref[k].identical(d[k]))
                                   for ex, d in data.items() if ex != "serial"}
    return rows


def dask_overhead(tasks: int = 200) -> dict:
    from distributed import as_completed

    t0 = time.perf_counter()
    runner = Runner(parse_executor("dask:2"))
    start = time.perf_counter() - t0
    try:
        client = runner.client
        list(as_completed([client.submit(_noop, i, pure=False) for i in range(10)]))  # warm
        t1 = time.perf_counter()
        futs = [client.submit(_noop, i, pure=False) for i in range(tasks)]
        for f in as_completed(futs):
            f.result()
        per = (time.perf_counter() - t1) / tasks
    finally:
        runner.close()
    return {"cluster_start_seconds": start, "round_trip_per_task_seconds": per,
            "tasks": tasks}


def floor_point_cost(work: Path, points: int) -> dict:
    sweep = load_sweep(ROOT / "scenes" / "sweeps" / "r-mu.toml")
    pick = [sweep.points[i] for i in (6, 18)][:points]  # interior points of the 5 x 5 grid
    from dataclasses import replace

    sub = replace(sweep, points=tuple(pick))
    out = work / "floor001"
    t0 = time.perf_counter()
    run_sweep(sub, out, executor="serial", quiet=False, report=False)
    wall = time.perf_counter() - t0
    recs = [json.loads((out / "points" / f"{p.key}.json").read_text()) for p in pick]
    per = sum(r["seconds"] for r in recs) / len(recs)
    return {"points": [dict(p.params) for p in pick], "wall_seconds": wall,
            "seconds_per_point": per,
            "map_40x40_hours": {f"{w} workers": 1600 * per / w / 3600
                                for w in (1, 2, 8, 32, 128)}}


def point_against_bare(repeats: int = 3) -> dict:
    """Issue 22.1: a check sweep point at floor 0.01 against the bare Monte Carlo of the same
    point (``vifpk solve --solver montecarlo --floor 0.01 --dt auto``: the scene's default
    observables, its own pilot), both warm in this process (a sweep's worker keeps numba's
    kernels and the imports from point to point), alternated ``repeats`` times so that a
    change of the machine's load hits both; medians. Two interior points of
    scenes/sweeps/r-mu.toml at floor 0.01; the point without the sampled averaged-SDE check
    (the case of all but about 1 in 16 points, harness.sweeps.points.SDE_CHECK_EVERY), and the same
    point with it (``sde_point``), so the mean cost per point of a sweep is
    plain + (sde - plain) / 16."""
    import statistics
    from dataclasses import replace

    from vifpk.harness.door.solvers import run_solver
    from vifpk.harness.sweeps.points import SDE_CHECK_EVERY, run_point
    from vifpk.harness.sweeps.store import _job

    sweep = load_sweep(ROOT / "scenes" / "sweeps" / "r-mu.toml")
    rows = []
    for i in (6, 18):
        pt = sweep.points[i]
        pt = replace(pt, scene=pt.scene.with_values({"montecarlo.floor": 0.01}))
        bare_scene = pt.scene.with_values({"montecarlo.budget": 600.0})  # solve's default
        plain, with_sde = _job(sweep, replace(pt, sde=False)), _job(sweep, replace(pt, sde=True))
        run_point(with_sde)  # warm: kernels of every specialisation, imports
        run_solver(bare_scene, "montecarlo", progress=False)
        t_point, t_sde, t_bare = [], [], []
        load = os.getloadavg()
        for _ in range(repeats):
            t0 = time.perf_counter()
            run_solver(bare_scene, "montecarlo", progress=False)
            t_bare.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            rec = run_point(plain)
            t_point.append(time.perf_counter() - t0)
            assert rec["status"] == "ok", rec
            t0 = time.perf_counter()
            run_point(with_sde)
            t_sde.append(time.perf_counter() - t0)
        point, sde, bare = (statistics.median(t) for t in (t_point, t_sde, t_bare))
        rows.append({"params": dict(pt.params), "bare_montecarlo_seconds": bare,
                     "point_seconds": point, "sde_point_seconds": sde,
                     "ratio": point / bare,
                     "ratio_mean_per_point": (point + (sde - point) / SDE_CHECK_EVERY) / bare,
                     "load_average": [load, os.getloadavg()],
                     "all_seconds": {"bare": t_bare, "point": t_point, "sde_point": t_sde}})
        print("point vs bare", rows[-1], file=sys.stderr, flush=True)
    return {"floor": 0.01, "dt": "auto", "points": rows,
            "ratio_max": max(r["ratio"] for r in rows),
            "ratio_mean_per_point_max": max(r["ratio_mean_per_point"] for r in rows)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--floor", type=float, default=0.03,
                    help="target floor of the executor comparison (default 0.03)")
    ap.add_argument("--quick", action="store_true", help="skip the floor-0.01 point cost")
    ap.add_argument("--point-only", action="store_true",
                    help="only the point against the bare Monte Carlo (merged into the file)")
    args = ap.parse_args()
    out = ROOT / "benchmarks" / "results" / "sweep.json"
    if args.point_only:
        res = json.loads(out.read_text()) if out.is_file() else {}
        res["point_vs_bare"] = point_against_bare()
        out.write_text(json.dumps(res, indent=1) + "\n")
        print(json.dumps(res["point_vs_bare"], indent=1))
        return
    work = Path(tempfile.mkdtemp(prefix="vifpk-bench-sweep-"))
    load0 = os.getloadavg()
    res = {"machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                       "load_average_start": load0,
                       "note": "the load average is recorded: above the core count, other "
                               "jobs shared the cores and the times are upper bounds"},
           "floor": args.floor,
           "executors": executor_rows(args.floor, work),
           "dask": dask_overhead()}
    if not args.quick:
        res["floor_0.01"] = floor_point_cost(work, 2)
        res["point_vs_bare"] = point_against_bare()
    res["machine"]["load_average_end"] = os.getloadavg()
    out.write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps(res, indent=1))
    shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
