"""Transient laws of the ORIGINAL system (issue 30): histograms of A, x1 = x and x2 = x' at
given times from an ensemble started at amplitude A0.

The start is first_passage's (geometry.orbit_start: energy U(A0), a phase uniform in time
along that conservative orbit, folded onto x >= 0 with the barrier, xi from its stationary
law), drawn from each path's own generator (rng.block_seeds). The paths are then
advanced by the kernel of the stationary run (lanes.run_paths, nothing sampled), from one
snapshot time to the next, in calls of about CHUNK_SECONDS (stepper.Stepper: the progress
bar, Ctrl-C between calls, a non-finite state raises SimulationDiverged in one line). Each
time must be a whole number of steps, t_j = k_j dt (BadInput otherwise: a snapshot is never moved).

Densities are per unit length over all paths of a block (a sample outside the edges is not
counted, so the mass inside the edges is reported), averaged over blocks, with the standard
error of the block means. The second moments E[x^2], E[x x'], E[x'^2] at each time
(``moments``, every path, no edges) come with their block means, so that a smooth function of
them (e.g. the log-slope of E[x^2] between two times) gets its standard error from the
blocks (tests/test_parametric_growth.py). A sample at v = 0 exactly (the mass at rest) is the
atom of x2 at 0: counted in "atom_weight", not in the x2 bins, as in the stationary run.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from numbers import Real
from typing import Any

import numba
import numpy as np
from vifpk.montecarlo.failures import likely_cause
from vifpk.montecarlo.passage_kernels import starts_loop
from vifpk.montecarlo.progress import progress_bar
from vifpk.montecarlo.rng import block_seeds
from vifpk.montecarlo.runplan import effects
from vifpk.montecarlo.stepper import DUMMY_EDGES, Stepper, arrays

from vifpk.core.result import BadInput, Result, Status

from .geometry import amplitudes
from .passage import PassageSettings, check_settings, layout
from .pieces import record
from .plan import bounds, fold, physics

EDGE_KEYS = {"A": "edges_A", "x1": "edges_x", "x2": "edges_v"}


def _edges(edges: dict[str, Any]) -> dict[str, np.ndarray]:
    out = {}
    for name, key in EDGE_KEYS.items():
        if key not in edges:
            raise BadInput(f"edges must give {sorted(EDGE_KEYS.values())} (missing {key})")
        e = np.asarray(edges[key], dtype=float)
        if not (e.ndim == 1 and e.size >= 2 and np.all(np.isfinite(e))
                and np.all(np.diff(e) > 0)):
            raise BadInput(f"{key} must be finite increasing bin edges (at least 2)")
        out[name] = e
    return out


def snapshots(system: Any, noise: Any, settings: PassageSettings, *, start: float,
              times: Sequence[float], edges: dict[str, Any], parametric: Any = None) -> Result:
    """data["snapshots"] = {"t": float[n], "A" | "x1" | "x2": {"edges", "x" (centres),
    "p": float[n, bins], "err": float[n, bins]}, "moments": {"x1x1" | "x1x2" | "x2x2":
    {"value": float[n], "err": float[n], "blocks": float[blocks, n]}}} (x2 also
    "atom_weight", "atom_err": float[n]); settings.horizon is not used (the last time is the
    end)."""
    st = settings
    check_settings(st)
    if not (isinstance(start, Real) and math.isfinite(start) and start >= 0):
        raise BadInput(f"start must be an amplitude >= 0 (got {start!r})")
    t_req = np.asarray(times, dtype=float)
    if not (t_req.ndim == 1 and t_req.size and np.all(np.isfinite(t_req))
            and np.all(t_req >= 0) and np.all(np.diff(t_req) > 0)):
        raise BadInput("times must be finite, >= 0 and increasing")
    ed = _edges(edges)
    phys = physics(system, noise, parametric)
    h = float(st.dt)
    marks = np.round(t_req / h).astype(np.int64)
    if np.any(np.abs(marks * h - t_req) > 1e-9 * t_req) \
            or np.any(np.diff(marks) < 1):
        raise BadInput(f"times must be whole numbers of steps of dt = {h:g} (snapshots are "
                       f"taken at whole steps), got {list(t_req)}")
    count = layout(st.paths, st.blocks)
    per = int(count.max())
    mask = np.arange(per)[None, :] < count[:, None]
    threads = st.threads or numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(threads)
    t0 = time.perf_counter()
    rng = block_seeds(st.seed, st.blocks, per)
    state = np.empty((st.blocks, per, 3))
    flat_rng = rng.reshape(-1, 4)  # a view: the starts advance each path's own stream
    starts_loop(flat_rng, state.reshape(-1, 3), float(start), phys["w0sq"], phys["alpha"],
                phys["khi"], (fold(phys), *bounds(phys)), record(phys, h))
    arr = arrays(rng, state, DUMMY_EDGES, ())
    never = np.iinfo(np.int64).max // 2  # a burn-in never reached: nothing is sampled
    bar = progress_bar(st.progress, total=float(st.blocks * per * max(marks[-1], 1)),
                       desc="monte carlo: transient")
    step = Stepper(phys, h, threads, bar, likely_cause(system, parametric, h))
    hists = {k: np.zeros((st.blocks, marks.size, e.size - 1)) for k, e in ed.items()}
    atom = np.zeros((st.blocks, marks.size))
    mom = np.zeros((3, st.blocks, marks.size))
    n = 0
    try:
        for j, mark in enumerate(marks):
            if mark > n:
                step.run(arr, int(mark - n), n, never, 1)
                n = int(mark)
            _record(arr.state, mask, phys, ed, hists, atom, j)
            _second(arr.state, mask, mom, j)
    finally:
        if bar is not None:
            bar.close()
    run_s = time.perf_counter() - t0
    cnt = count.astype(float)
    snap: dict[str, Any] = {"t": marks * h}
    floors, mass = {}, {}
    for name, e in ed.items():
        d = snapshot_densities(hists[name], cnt, e)
        floors[name], mass[name] = d.pop("L1_floor").tolist(), d.pop("mass").tolist()
        snap[name] = d
    w = atom / cnt[:, None]
    snap["x2"]["atom_weight"] = w.mean(axis=0)
    snap["x2"]["atom_err"] = w.std(axis=0, ddof=1) / math.sqrt(st.blocks)
    snap["moments"] = {}
    for name, sums in zip(("x1x1", "x1x2", "x2x2"), mom, strict=True):
        blk = sums / cnt[:, None]
        snap["moments"][name] = {"value": blk.mean(axis=0),
                                 "err": blk.std(axis=0, ddof=1) / math.sqrt(st.blocks),
                                 "blocks": blk}
    steps = float(st.blocks * per * marks[-1])
    info = {"solver": "montecarlo", "method": "snapshots", "start": float(start),
            "start_law": "energy U(A0), phase uniform in time along the conservative orbit "
                         "(folded onto x >= 0 with the barrier), noise state from its "
                         "stationary law",
            "paths": int(st.paths), "blocks": int(st.blocks), "dt": h,
            "times_requested": t_req.tolist(), "threads": threads,
            "seed": {"root": int(st.seed), "scheme": "path p of block b: words 4p..4p+3 of "
                     "numpy.random.SeedSequence(root, spawn_key=(b,)).generate_state"},
            "effects": effects(system, noise), "L1_floor": floors, "mass_inside": mass,
            "steps": steps,
            "steps_per_second": steps / step.busy if step.busy > 0 else math.nan,
            "seconds": {"total": run_s, "kernel": step.busy},
            "status": Status.SNAPSHOTS.record()}
    return Result(data={"snapshots": snap}, info=info)


def _record(state: np.ndarray, mask: np.ndarray, phys: dict[str, Any],
            ed: dict[str, np.ndarray], hists: dict[str, np.ndarray], atom: np.ndarray,
            j: int) -> None:
    """Histogram the paths' current state into time slot j, block by block."""
    x, v = state[..., 0], state[..., 1]
    A = np.empty(x.size)
    amplitudes(x.ravel(), v.ravel(), phys["w0sq"], phys["alpha"], phys["khi"], A)
    A = A.reshape(x.shape)
    for b in range(state.shape[0]):
        m = mask[b]
        vb = v[b][m]
        rest = vb == 0.0
        atom[b, j] = rest.sum()
        hists["A"][b, j] = np.histogram(A[b][m], ed["A"])[0]
        hists["x1"][b, j] = np.histogram(x[b][m], ed["x1"])[0]
        hists["x2"][b, j] = np.histogram(vb[~rest], ed["x2"])[0]


def _second(state: np.ndarray, mask: np.ndarray, mom: np.ndarray, j: int) -> None:
    """Per-block sums of x^2, x x', x'^2 over the paths into time slot j."""
    x, v = np.where(mask, state[..., 0], 0.0), np.where(mask, state[..., 1], 0.0)
    mom[0, :, j], mom[1, :, j], mom[2, :, j] = (x * x).sum(1), (x * v).sum(1), (v * v).sum(1)


def snapshot_densities(hist: np.ndarray, count: np.ndarray, edges: np.ndarray) -> dict[str, Any]:
    """hist[b, j, bin] -> {"edges", "x", "p", "err", "L1_floor", "mass"} (block means)."""
    w = np.diff(edges)
    per_block = hist / (count[:, None, None] * w)
    p = per_block.mean(axis=0)
    err = per_block.std(axis=0, ddof=1) / math.sqrt(hist.shape[0])
    return {"edges": edges, "x": 0.5 * (edges[1:] + edges[:-1]), "p": p, "err": err,
            "L1_floor": np.sum(math.sqrt(2 / math.pi) * err * w, axis=1), "mass": p @ w}
