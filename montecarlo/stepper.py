"""The stationary run's arrays and how they are advanced: every path's generator and state,
the histograms, moments, events and energy sums the kernel (kernels.run_paths) fills, and the
``Stepper`` that calls the kernel in short calls (Ctrl-C is seen between them), checks the
state for finiteness after each and drives the progress bar.

The kernel advances all paths by a given number of steps, so a run may be cut into any number
of calls and still give bit-identical results for a seed, for any thread count (simulate.py).
"""

from __future__ import annotations

import time
from typing import Any, NamedTuple

import numpy as np
from vifpk.montecarlo import kernels as K
from vifpk.montecarlo.failures import diverged
from vifpk.montecarlo.pieces import record
from vifpk.montecarlo.timing import Laps

CHUNK_SECONDS = 0.4  # wall time of one kernel call: Ctrl-C is seen between calls
#: histogram edges for a run that fills no histogram (the pilots)
DUMMY_EDGES = {"edges_A": np.array([0.0, 1.0]), "edges_x": np.array([0.0, 1.0]),
               "edges_v": np.array([0.0, 1.0])}
#: the moments' columns that are maxima, not sums (path_sums)
MAX_COLUMNS = (K.MO_MAXA, K.MO_MAXX, K.MO_MAXV)


class Arrays(NamedTuple):
    """Everything the kernel reads and fills, [block, path, ...] or [block, ...]."""

    rng: np.ndarray
    state: np.ndarray
    hist: dict[str, Any]
    moments: np.ndarray | None
    events: np.ndarray
    stuck: np.ndarray  # per path: the time at rest (events[:, EV_STUCK] once summed)
    energy: np.ndarray | None


def hists(blocks: int, edges: dict[str, np.ndarray], obs: tuple[str, ...]) -> dict[str, Any]:
    """The edges and an empty histogram per block for each observable asked for (else None)."""
    na, nx, nv = (edges[k].size - 1 for k in ("edges_A", "edges_x", "edges_v"))
    return {
        **edges,
        "A": np.zeros((blocks, na)) if "A" in obs else None,
        "x": np.zeros((blocks, nx)) if "x1" in obs else None,
        "v": np.zeros((blocks, nv)) if "x2" in obs else None,
        "joint": np.zeros((blocks, nx, nv)) if "joint" in obs else None,
    }


def arrays(rng: np.ndarray, state: np.ndarray, edges: dict[str, np.ndarray],
           obs: tuple[str, ...]) -> Arrays:
    """The arrays of a run from its generators and starts, with the observables ``obs``."""
    blocks, paths = state.shape[0], state.shape[1]
    # moments and energy per path (summed over paths afterwards, path_sums): each path's
    # float sums are then in step order however the run is cut into kernel calls
    return Arrays(rng=rng, state=state, hist=hists(blocks, edges, obs),
                  moments=np.zeros((blocks, paths, K.N_MOMENTS)) if "moments" in obs else None,
                  events=np.zeros((blocks, K.N_EVENTS)), stuck=np.zeros((blocks, paths)),
                  energy=np.zeros((blocks, paths, K.N_ENERGY)) if "energy" in obs else None)


def path_sums(per_path: np.ndarray, max_columns: tuple[int, ...] = ()) -> np.ndarray:
    """[block, path, column] -> [block, column]: sums over the paths (in a fixed order), the
    maximum for ``max_columns``."""
    out = per_path.sum(axis=1)
    for c in max_columns:
        out[:, c] = per_path[:, :, c].max(axis=1)
    return out


def kernel_call(arr: Arrays, phys: dict[str, Any], h: float, n_steps: int, step0: int,
                n_burn: int, stride: int, spw: int, windows: np.ndarray | None) -> None:
    """One call of kernels.run_paths: ``n_steps`` steps from step ``step0`` (the burn-in's
    ``n_burn`` steps sample nothing; then every ``stride``-th step is a sample, ``spw``
    samples a certificate window)."""
    hi = arr.hist
    ea, ex, ev = hi["edges_A"], hi["edges_x"], hi["edges_v"]
    blocks, paths = arr.state.shape[:2]
    # an output not asked for is an empty array, not None: one compiled kernel for every
    # choice of observables (kernels.py's docstring)
    none1, none2 = np.zeros((blocks, 0)), np.zeros((blocks, 0, 0))
    per_path = np.zeros((blocks, paths, 0))

    def given(a: Any, empty: np.ndarray) -> np.ndarray:
        return empty if a is None else a

    bins = (ea[0], 1.0 / (ea[1] - ea[0]), ex[0], 1.0 / (ex[1] - ex[0]), ev[0],
            1.0 / (ev[1] - ev[0]))
    out = (given(hi["A"], none1), given(hi["x"], none1), given(hi["v"], none1),
           given(hi["joint"], none2), given(arr.moments, per_path), arr.events, arr.stuck,
           given(arr.energy, per_path), given(windows, per_path))
    K.run_paths(arr.rng, arr.state, n_steps, step0, n_burn, stride, h, record(phys, h), bins,
                out, spw)
    arr.events[:, K.EV_STUCK] = arr.stuck.sum(axis=1)  # per path first: order-independent


class Stepper:
    """Advances arrays in kernel calls of about CHUNK_SECONDS each (Ctrl-C is raised between
    calls), checks the state for finiteness after each call, and drives the progress bar."""

    def __init__(self, phys: dict[str, Any], h: float, threads: int, bar: Any,
                 cause: str = ""):
        self.phys, self.h, self.bar, self.cause = phys, h, bar, cause
        self.rate = 5e6 * threads  # steps per second: a cautious first guess, then measured
        self.busy = 0.0  # seconds spent in the kernel
        self.laps = Laps()  # the run's stage timing (timing.py); simulate.py passes its own

    def run(self, arr: Arrays, n_steps: int, step0: int, n_burn: int, stride: int,
            spw: int = 1, windows: np.ndarray | None = None) -> None:
        """Advance by n_steps."""
        n_paths = arr.state.shape[0] * arr.state.shape[1]
        done = 0
        while done < n_steps:
            chunk = int(max(1, min(n_steps - done, CHUNK_SECONDS * self.rate / n_paths)))
            t0 = time.perf_counter()
            kernel_call(arr, self.phys, self.h, chunk, step0 + done, n_burn, stride, spw,
                        windows)
            dt = time.perf_counter() - t0
            self.busy += dt
            if dt > 0:
                self.rate = 0.5 * self.rate + 0.5 * chunk * n_paths / dt if done else \
                    chunk * n_paths / dt
            if not np.all(np.isfinite(arr.state)):
                raise diverged(self.h, "non-finite position or velocity", self.cause)
            done += chunk
            if self.bar is not None:
                self.bar.update(chunk * n_paths)
