"""The averaged amplitude SDE dA = m(A) dt + sigma(A) dB in the time domain (issue 30): first
passage through a threshold Ac and the law of A at given times, from a start amplitude.

The step is averaged_sde's (``sde_step``: Z = A^2, the BESQ(2) part exact, weak order 1) on
its tables (``sde_tables``), so this Monte Carlo and the stationary one share one scheme.

**The crossing inside the step.** A step that ends at A_{n+1} >= Ac crosses at the linear
interpolation t_n + h (Ac - A_n) / (A_{n+1} - A_n). A step that ends below Ac may still have
crossed in between: for a diffusion, given both ends, the probability is the Brownian
bridge's, p = exp(-2 (Ac - A_n)(Ac - A_{n+1}) / (sigma(A_n)^2 h)); a uniform (drawn only when
p > 1e-14) decides, and such a crossing is placed at t_n + h (Ac - A_n) / (2 Ac - A_n -
A_{n+1}). Without the bridge, monitoring at the grid times alone misses excursions and biases
the first-passage time up by O(h^(1/2)) (about 0.58 sigma sqrt(h) in the threshold, Broadie,
Glasserman & Kou 1997); with the bridge, the Rayleigh MFPT at one step agrees with its
closed form within 4 standard errors (tests/test_time_sde.py), and the white-noise MFPT of the
original system at dt = 0.1 with that at dt = 0.00625 (tests/test_passage_mc.py); the order of
the remaining bias has not been fitted.

**Seeds.** Path p of block b draws from its own xoshiro stream (rng.block_seeds(seed,
blocks, paths per block), as the original system's paths do), so a path's numbers do not
depend on the other paths, the horizon (a shorter one censors the same paths, leaving the
other times unchanged), the cut into calls (of whole paths; Ctrl-C between them) nor the
thread count.

**Lanes.** The kernels (sde_lanes.py) step LANES paths of a thread together in struct-of-arrays
lanes (the step vectorised, as averaged_sde.run_sde_blocks's), each lane's numbers those of
``sde_step`` on its path's own words, so the results are bit for bit those of the kernels
that stepped one path at a time (issue 44; benchmarks/mc_identity.py).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from numbers import Real
from typing import Any

import numba
import numpy as np
from vifpk.montecarlo.failures import SimulationDiverged
from vifpk.montecarlo.progress import progress_bar
from vifpk.montecarlo.rng import block_seeds
from vifpk.montecarlo.stepper import CHUNK_SECONDS

from vifpk.core.result import BadInput, Result, Status

from .averaged_sde import ORDER, STEPS_PER_TAU, relaxation_time, sde_tables
from .lanes import LANES
from .passage import layout
from .sde_lanes import run_sde_passage, run_sde_snapshots
from .transient import snapshot_densities

TABLE_POINTS = 4001
TABLE_MARGIN = 1.25  # the tables reach TABLE_MARGIN x the threshold (or the top edge)


def auto_dt(drift: Callable[[np.ndarray], np.ndarray],
            diffusion: Callable[[np.ndarray], np.ndarray], top: float, fallback: float
            ) -> tuple[float, float]:
    """(dt, tau): the averaged SDE's own step rule, tau / STEPS_PER_TAU with tau its
    relaxation time on [0, top] (averaged_sde.relaxation_time); ``fallback`` when tau is not
    finite. The scheme's bias in the MFPT is then about u_c dt / (2 tau) relative
    (tests/test_time_sde.py), u_c the threshold's depth in units of the noise."""
    tau = relaxation_time(drift, diffusion, top)
    if not math.isfinite(tau):
        return float(fallback), tau
    return tau / STEPS_PER_TAU, tau


def _starts(start: float | np.ndarray, paths: int, threshold: float) -> np.ndarray:
    a = np.asarray(start, dtype=float)
    if a.ndim == 0:
        a = np.full(paths, float(a))
    if a.shape != (paths,):
        raise BadInput(f"start must be an amplitude or an array of {paths} start amplitudes "
                       f"(got shape {a.shape})")
    if not (np.all(np.isfinite(a)) and np.all(a >= 0) and np.all(a < threshold)):
        raise BadInput(f"start amplitudes must lie in [0, {threshold:g}) (the threshold)")
    return a


def _check(paths: int, blocks: int, dt: float, **positive: float) -> None:
    if not (isinstance(blocks, int) and blocks >= 2 and isinstance(paths, int)
            and paths >= blocks):
        raise BadInput(f"need whole numbers paths >= blocks >= 2 (got paths={paths!r}, "
                       f"blocks={blocks!r})")
    for name, val in {"dt": dt, **positive}.items():
        if not (isinstance(val, Real) and math.isfinite(val) and val > 0):
            raise BadInput(f"{name} must be a finite number > 0 (got {val!r})")


def _drive(kernel: Callable[..., None], count: np.ndarray, steps_per_path: float,
           progress: bool, label: str) -> float:
    """Run ``kernel(done, k)`` over every block's paths in calls of about CHUNK_SECONDS (whole
    paths; Ctrl-C between calls), with a tqdm bar in paths (progress.progress_bar: quiet for
    runs under 3 s); returns the seconds spent. A call takes at least enough paths to fill
    every thread's LANES lanes (the kernels pool a thread's paths into its lanes,
    sde_lanes.py); any cut gives the same numbers."""
    done = np.zeros_like(count)
    rate = 5e6 * numba.get_num_threads()
    k_min = -(-LANES * min(numba.get_num_threads(), count.size) // count.size)
    bar = progress_bar(progress, total=int(count.sum()), desc=label, unit=" paths")
    t0 = time.perf_counter()
    try:
        while np.any(done < count):
            k = int(max(k_min, CHUNK_SECONDS * rate / max(steps_per_path * count.size, 1.0)))
            t = time.perf_counter()
            kernel(done, k)
            spent = time.perf_counter() - t
            if spent > 0:
                rate = k * steps_per_path * count.size / spent
            new = np.minimum(done + k, count)
            if bar is not None:
                bar.update(int((new - done).sum()))
            done = new
    finally:
        if bar is not None:
            bar.close()
    return time.perf_counter() - t0


def sde_first_passage(drift: Callable[[np.ndarray], np.ndarray],
                      diffusion: Callable[[np.ndarray], np.ndarray], *, threshold: float,
                      start: float | np.ndarray, paths: int, blocks: int, dt: float,
                      horizon: float, seed: int, table_points: int = TABLE_POINTS,
                      progress: bool = True) -> Result:
    """First passage of the averaged SDE through A = threshold from ``start`` (one amplitude,
    or one per path), censored at ``horizon``: data["fpt"] = {"time", "censored"} as
    montecarlo.first_passage, data["start"] = {"A"}. Paths are ordered block by block."""
    _check(paths, blocks, dt, horizon=horizon)
    if not (isinstance(threshold, Real) and math.isfinite(threshold) and threshold > 0):
        raise BadInput(f"threshold must be a finite amplitude > 0 (got {threshold!r})")
    a0 = _starts(start, paths, threshold)
    grid, a_tab, b_tab = sde_tables(drift, diffusion, TABLE_MARGIN * threshold, table_points)
    count = layout(paths, blocks)
    offset = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    states = block_seeds(seed, blocks, int(count.max()))
    n_max = int(math.ceil(horizon / dt * (1 - 1e-12)))
    fpt = np.zeros(paths)
    cens = np.zeros(paths, dtype=np.bool_)
    bad = np.zeros(paths, dtype=np.int64)
    inv_d = 1.0 / (grid[1] - grid[0])

    def kernel(done: np.ndarray, k: int, st: np.ndarray = states) -> None:
        run_sde_passage(st, a0, offset, count, done, k, n_max, float(horizon), float(dt),
                        float(threshold), a_tab, b_tab, inv_d, fpt, cens, bad)

    t0 = time.perf_counter()
    kernel(np.zeros_like(count), 0, states.copy())  # compile (or load the cache)
    compile_s = time.perf_counter() - t0
    run_s = _drive(kernel, count, min(n_max, 1e5), progress, "averaged SDE: first passage")
    if bad.any():
        raise SimulationDiverged(f"the averaged SDE blew up (non-finite amplitude) at dt = {dt:g}; "
                           "try a smaller dt")
    steps = float(np.sum(np.minimum(np.ceil(fpt / dt - 1e-9), n_max)))  # path-steps taken
    info: dict[str, Any] = {
        "solver": "averaged-sde", "method": "first_passage", "threshold": float(threshold),
        "start": float(a0[0]) if np.ndim(start) == 0 else "array",
        "paths": int(paths), "blocks": int(blocks), "horizon": float(horizon), "dt": float(dt),
        "seed": {"root": int(seed), "scheme": "path p of block b: words 4p..4p+3 of "
                 "numpy.random.SeedSequence(root, spawn_key=(b,)).generate_state"},
        "censored": int(cens.sum()),
        "crossing": {"method": "linear interpolation of A when a step ends at or above Ac; "
                               "Brownian-bridge crossing probability exp(-2 (Ac - A_n)"
                               "(Ac - A_n+1) / (sigma^2 dt)) when it ends below",
                     "order": ORDER},
        "order": {"weak": ORDER, "note": "exact BESQ(2) part + explicit remainder, Z = A^2"},
        "table": {"points": int(table_points), "top": float(grid[-1])},
        "seconds": {"compile": compile_s, "run": run_s, "total": compile_s + run_s},
        "steps": steps, "steps_per_second": steps / run_s if run_s > 0 else math.nan,
        "status": (Status.CENSORED.record(f"{int(cens.sum())} of {cens.size} paths")
                   if cens.any() else Status.SIMULATED.record()),
    }
    return Result(data={"fpt": {"time": fpt, "censored": cens}, "start": {"A": a0}},
                  info=info)


def sde_snapshots(drift: Callable[[np.ndarray], np.ndarray],
                  diffusion: Callable[[np.ndarray], np.ndarray], *, start: float | np.ndarray,
                  times: Sequence[float], edges_A: np.ndarray, paths: int, blocks: int,
                  dt: float, seed: int, table_points: int = TABLE_POINTS,
                  progress: bool = True) -> Result:
    """The law of A at ``times`` from ``start`` (one amplitude, or one per path):
    data["snapshots"] = {"t": float[n], "A": {"edges", "x", "p": float[n, bins],
    "err": float[n, bins]}} (densities per unit length over all paths, block standard
    errors). Each time is taken at the nearest whole step (info["times_requested"])."""
    edges = np.asarray(edges_A, dtype=float)
    t_req = np.asarray(times, dtype=float)
    _check(paths, blocks, dt)
    if not (t_req.ndim == 1 and t_req.size and np.all(np.isfinite(t_req)) and np.all(t_req >= 0)
            and np.all(np.diff(t_req) > 0)):
        raise BadInput("times must be finite, >= 0 and increasing")
    if not (edges.ndim == 1 and edges.size >= 2 and np.all(np.diff(edges) > 0)
            and np.allclose(np.diff(edges), edges[1] - edges[0])):
        raise BadInput("edges_A must be increasing and evenly spaced")
    a0 = _starts(start, paths, math.inf)
    top = TABLE_MARGIN * max(edges[-1], float(a0.max()))
    grid, a_tab, b_tab = sde_tables(drift, diffusion, top, table_points)
    marks = np.round(t_req / dt).astype(np.int64)
    count = layout(paths, blocks)
    offset = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    states = block_seeds(seed, blocks, int(count.max()))
    hist = np.zeros((blocks, marks.size, edges.size - 1))
    bad = np.zeros(paths, dtype=np.int64)
    inv_d = 1.0 / (grid[1] - grid[0])

    def kernel(done: np.ndarray, k: int, st: np.ndarray = states,
               hh: np.ndarray = hist) -> None:
        run_sde_snapshots(st, a0, offset, count, done, k, marks, float(dt), a_tab, b_tab,
                          inv_d, edges[0], 1.0 / (edges[1] - edges[0]), hh, bad)

    t0 = time.perf_counter()
    kernel(np.zeros_like(count), 0, states.copy(), hist.copy())
    compile_s = time.perf_counter() - t0
    run_s = _drive(kernel, count, float(max(marks[-1], 1)), progress,
                   "averaged SDE: transient")
    if bad.any():
        raise SimulationDiverged(f"the averaged SDE blew up (non-finite amplitude) at dt = {dt:g}; "
                           "try a smaller dt")
    snap = snapshot_densities(hist, count.astype(float), edges)
    t = marks * float(dt)
    info = {"solver": "averaged-sde", "method": "snapshots", "paths": int(paths),
            "blocks": int(blocks), "dt": float(dt), "times_requested": t_req.tolist(),
            "seed": {"root": int(seed), "scheme": "path p of block b: words 4p..4p+3 of "
                     "numpy.random.SeedSequence(root, spawn_key=(b,)).generate_state"},
            "L1_floor": {"A": snap.pop("L1_floor").tolist()},
            "mass_inside": {"A": snap.pop("mass").tolist()},
            "order": {"weak": ORDER},
            "seconds": {"compile": compile_s, "run": run_s, "total": compile_s + run_s},
            "status": Status.SNAPSHOTS.record()}
    return Result(data={"snapshots": {"t": t, "A": snap}}, info=info)
