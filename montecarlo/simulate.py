"""Driver of the Monte Carlo of the original system: seeding, batching, histograms, errors,
the burn-in, the equilibration certificate and the stop at a target noise floor.

Independent blocks of paths are the batches. Path p of block b has its own generator, seeded
from ``numpy.random.SeedSequence(seed, spawn_key=(b,))`` (the b-th child of
``SeedSequence(seed)``; its 4 x paths-per-block state words seed the block's paths), and its
own state (x, v, xi). The kernel advances all paths by a given number of steps, so a run may be
cut into any number of calls (short ones, so that Ctrl-C is seen within about a second, and
more of them when the run is extended toward a target floor) and still gives bit-identical
results for a seed, for any thread count. Densities are block means; the error bar of each bin
is the standard error of the block means (paths in different blocks are independent, samples
along one path are not). The L1 noise floor is the expected L1 of pure sampling noise,
sum_i sqrt(2/pi) se_i w_i (Gaussian bin errors).

The run: a short pilot sets the histogram ranges and the amplitude scale; with
``burn_in = "auto"`` a second pilot measures the relaxation time (tuning.py); the paths start
over-dispersed; after the burn-in the sampled time is 16 to 32 windows of whole samples
(sampling_plan; 8 windows of time / 16 when a target floor is set, then extended window by
window toward the floor, within the budget);
the certificate (certificate.py) reads the per-path window means.
"""

from __future__ import annotations

import math
import platform
import sys
import time
from dataclasses import dataclass, field, replace
from typing import Any, NamedTuple

import numba
import numpy as np

from vifpk.core.defaults import BURN_FACTOR
from vifpk.core.result import CostRefused, Resolved, Result, Status
from vifpk.core.scene import energy_balance
from vifpk.core.sections import Observables

from . import kernels as K
from .certificate import certificate
from .checkpoint import Checkpoint, run_key
from .pieces import record
from .plan import (
    MIN_AUTO_BURN_IN,
    RELAX_MAX_TIME,
    RELAX_PAIRS,
    RELAX_SEGMENT,
    RELAX_WINDOW,
    SCALE_BLOCKS,
    SCALE_BURN_IN,
    SCALE_PER_BLOCK,
    SCALE_SAMPLE_EVERY,
    SCALE_SAMPLES,
    bounds,
    fold,
    noise_piece,
    sampling_plan,
    step_size,
)
from .plan import physics as _params
from .tuning import (
    BIAS_FRACTION,
    CHECK_FACTOR,
    CHECK_FLOOR_RATIO,
    DEFAULT_FLOOR,
    OMEGA_REF,
    fit_relaxation,
    scene_omega,
    step_check,
)

OBSERVABLES = ("A", "x1", "x2", "joint", "moments", "events", "energy")
CHUNK_SECONDS = 0.4  # wall time of one kernel call: Ctrl-C is seen between calls
START_LOW = 0.05  # lowest start amplitude, as a fraction of the pilot's largest


class SimulationDiverged(RuntimeError):
    """The simulation produced a non-finite state, or no sample inside any histogram range.
    The message is one line and names the time step (the usual cause)."""


class BudgetExhausted(RuntimeError):
    """The wall-time budget of a run to a target floor ran out before the first sampling
    window (in the pilots or the burn-in): there is no sample. The message is one line."""


@dataclass(frozen=True, kw_only=True)
class Settings:
    """Monte Carlo settings: plain numbers, no defaults (the scene's [montecarlo] section
    holds the one set of defaults, vifpk.core.scene.MonteCarloSettings).

    dt: a step, or "auto" (tuning.auto_dt for the target floor); burn_in: a time, or "auto"
    (BURN_FACTOR x the relaxation time measured by a pilot); floor: target L1 noise floor of
    p(A), 0 for none (then exactly ``time`` is sampled); budget: wall seconds for reaching the
    floor (0: no limit); max_path_steps: the path-steps the burn-in and the (first) sampled
    windows may take once an "auto" burn-in is measured (inf: no limit), else
    vifpk.core.result.CostRefused is raised before the burn-in starts (the caller's cost
    guard prices the run with the measured burn-in); dt_check: with dt "auto", check the
    step's bias at run time (_step_check, tuning.step_check)."""

    paths: int
    dt: float | str
    time: float
    burn_in: float | str
    sample_every: float
    seed: int
    blocks: int
    bins: int
    threads: int
    floor: float
    budget: float
    observables: tuple[str, ...] = Observables().names()  # the scene's one default (issue 38)
    progress: bool = True
    certificate: bool = True
    dt_check: bool = True
    max_path_steps: float = math.inf
    edges: dict[str, Any] = field(default_factory=dict, compare=False)
    #: a checkpoint.Checkpoint (or its bytes) to continue from: the same paths, the next
    #: window on, toward this run's floor; no pilot, no burn-in (checkpoint.py)
    resume: Any = field(default=None, compare=False, repr=False)
    #: return where the run stopped as info["checkpoint"] (a checkpoint.Checkpoint)
    keep_state: bool = False


def block_seeds(seed: int, blocks: int, per_block: int = 1, key: int = 0) -> np.ndarray:
    """(blocks, per_block, 4) uint64 xoshiro states: block b from the state words of
    SeedSequence(seed, spawn_key=(key + b,)), i.e. the b-th child of SeedSequence(seed)."""
    out = np.empty((blocks, per_block, 4), dtype=np.uint64)
    for b in range(blocks):
        words = np.random.SeedSequence(seed, spawn_key=(key + b,)).generate_state(
            4 * per_block, dtype=np.uint64).reshape(per_block, 4)
        words[~words.any(axis=1), 0] = 1  # the all-zero state is a fixed point
        out[b] = words
    return out


def _potential(x: Any, phys: dict[str, Any]) -> Any:
    """U(x) of the kernel's spring (geometry.potential, vectorised)."""
    w0sq, alpha = phys["w0sq"], phys["alpha"]
    u = 0.5 * w0sq * x * x + 0.25 * alpha * x**4  # (the paper's form, operation for operation)
    for i, c in enumerate(phys["khi"] if phys["khi"] is not None else ()):
        u = u + c / (2 * i + 6) * x ** (2 * i + 6)
    return u


def effects(system: Any, noise: Any) -> dict[str, bool | str]:
    p = _params(system, noise)
    return {"friction": p["mu"] is not None, "barrier": p["lower"] is not None,
            "noise": p["noise"].kind}


# --------------------------------------------------------------------------------------------
class _Arrays(NamedTuple):
    rng: np.ndarray
    state: np.ndarray
    hist: dict[str, Any]
    moments: np.ndarray | None
    events: np.ndarray
    stuck: np.ndarray  # per path: the time at rest (events[:, EV_STUCK] once summed)
    energy: np.ndarray | None


def _hists(blocks: int, edges: dict[str, np.ndarray], obs: tuple[str, ...]) -> dict[str, Any]:
    na, nx, nv = (edges[k].size - 1 for k in ("edges_A", "edges_x", "edges_v"))
    return {
        **edges,
        "A": np.zeros((blocks, na)) if "A" in obs else None,
        "x": np.zeros((blocks, nx)) if "x1" in obs else None,
        "v": np.zeros((blocks, nv)) if "x2" in obs else None,
        "joint": np.zeros((blocks, nx, nv)) if "joint" in obs else None,
    }


def _kernel(arr: _Arrays, phys: dict[str, Any], h: float, n_steps: int, step0: int,
            n_burn: int, stride: int, spw: int, windows: np.ndarray | None) -> None:
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


def _diverged(h: float, what: str, cause: str = "") -> SimulationDiverged:
    """One line: what blew up, then the likely cause. ``cause``: the scene's large-amplitude
    energy balance when it says the energy may grow without bound (``_growth``): that comes
    first, before any advice on the time step."""
    step = (f"try a smaller --dt (e.g. {h / 4:g}) or --dt auto; if a smaller step blows up "
            "too, the amplitude grows without bound and no stationary density exists")
    if cause:
        return SimulationDiverged(f"the Monte Carlo blew up ({what}) at dt = {h:g}: most likely "
                                  f"{cause}; else the time step is too large: {step}")
    return SimulationDiverged(
        f"the Monte Carlo blew up ({what}) at dt = {h:g}: the time step is most likely too "
        f"large for this scene; {step} (negative damping c1 > 0 not held by c2, impacts or "
        "friction)")


def _growth(system: Any, parametric: Any = None) -> str:
    """'' when the losses win the large-amplitude energy balance (vifpk.core.scene.
    energy_balance, with the parametric noise), else the words of why the energy may grow."""
    if not hasattr(system, "restoring_law"):  # a duck-typed system with the paper's names
        return ""
    bal = energy_balance(system, parametric)
    if bal.grows:
        return f"the energy grows without bound ({bal.text})"
    if bal.tail is not None and not bal.tie and not bal.tail.mean_finite:
        return f"the parametric noise: {bal.text}"
    if bal.tie:
        return (f"the energy grows without bound: {bal.text}, and here the gain may win (no "
                "stationary density)")
    return ""


class _Stepper:
    """Advances arrays in kernel calls of about CHUNK_SECONDS each (Ctrl-C is raised between
    calls), checks the state for finiteness after each call, and drives the progress bar."""

    def __init__(self, phys: dict[str, Any], h: float, threads: int, bar: Any,
                 cause: str = ""):
        self.phys, self.h, self.bar, self.cause = phys, h, bar, cause
        self.rate = 5e6 * threads  # steps per second: a cautious first guess, then measured
        self.busy = 0.0  # seconds spent in the kernel

    def run(self, arr: _Arrays, n_steps: int, step0: int, n_burn: int, stride: int,
            spw: int = 1, windows: np.ndarray | None = None) -> None:
        """Advance by n_steps."""
        n_paths = arr.state.shape[0] * arr.state.shape[1]
        done = 0
        while done < n_steps:
            chunk = int(max(1, min(n_steps - done, CHUNK_SECONDS * self.rate / n_paths)))
            t0 = time.perf_counter()
            _kernel(arr, self.phys, self.h, chunk, step0 + done, n_burn, stride, spw, windows)
            dt = time.perf_counter() - t0
            self.busy += dt
            if dt > 0:
                self.rate = 0.5 * self.rate + 0.5 * chunk * n_paths / dt if done else \
                    chunk * n_paths / dt
            if not np.all(np.isfinite(arr.state)):
                raise _diverged(self.h, "non-finite position or velocity", self.cause)
            done += chunk
            if self.bar is not None:
                self.bar.update(chunk * n_paths)


def _arrays(rng: np.ndarray, state: np.ndarray, edges: dict[str, np.ndarray],
            obs: tuple[str, ...]) -> _Arrays:
    blocks, paths = state.shape[0], state.shape[1]
    # moments and energy per path (summed over paths afterwards, _per_block): each path's
    # float sums are then in step order however the run is cut into kernel calls
    return _Arrays(rng=rng, state=state, hist=_hists(blocks, edges, obs),
                   moments=np.zeros((blocks, paths, K.N_MOMENTS)) if "moments" in obs else None,
                   events=np.zeros((blocks, K.N_EVENTS)), stuck=np.zeros((blocks, paths)),
                   energy=np.zeros((blocks, paths, K.N_ENERGY)) if "energy" in obs else None)


def _per_block(per_path: np.ndarray, max_columns: tuple[int, ...] = ()) -> np.ndarray:
    """[block, path, column] -> [block, column]: sums over the paths (in a fixed order), the
    maximum for ``max_columns``."""
    out = per_path.sum(axis=1)
    for c in max_columns:
        out[:, c] = per_path[:, :, c].max(axis=1)
    return out


_MAX_COLUMNS = (K.MO_MAXA, K.MO_MAXX, K.MO_MAXV)


def _starts(amplitudes: np.ndarray, phys: dict[str, Any], gen: np.random.Generator
            ) -> np.ndarray:
    """(x, v, xi) on the conservative orbit of each amplitude, at a uniform random phase;
    xi from the stationary OU law."""
    def U(x: np.ndarray) -> np.ndarray:
        return _potential(x, phys)

    th = gen.uniform(0.0, 2 * math.pi, amplitudes.shape)
    x = amplitudes * np.cos(th)
    v = -np.sign(np.sin(th)) * np.sqrt(np.maximum(2 * (U(amplitudes) - U(x)), 0.0))
    if fold(phys):
        x = np.abs(x)
    x = np.clip(x, *bounds(phys))  # other walls: a pilot's start inside them (burnt in)
    xi = np.zeros_like(x)
    sd = noise_piece(phys, "start_sd")  # None: the noise kind has no state
    if sd is not None:
        xi = gen.standard_normal(x.shape) * sd
    return np.stack([x, v, xi], axis=-1)


_DUMMY = {"edges_A": np.array([0.0, 1.0]), "edges_x": np.array([0.0, 1.0]),
          "edges_v": np.array([0.0, 1.0])}


def _pilot_scale(phys: dict[str, Any], h: float, seed: int, step: _Stepper,
                 a_hint: float, path_max: list[float] | None = None) -> float:
    """The largest amplitude seen by the scale pilot (plan.py: 32 paths from small starts over
    200 + 1000 time units), times 1.25 (the histogram ranges and the top of the over-dispersed
    starts). ``path_max``, if given, receives each pilot path's largest amplitude."""
    gen = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1 << 20,)))
    amps = np.full((SCALE_BLOCKS, SCALE_PER_BLOCK), 0.1 * a_hint)
    arr = _arrays(block_seeds(seed, SCALE_BLOCKS, SCALE_PER_BLOCK, key=1 << 21),
                  _starts(amps, phys, gen), _DUMMY, ("moments",))
    n_burn = int(round(SCALE_BURN_IN / h))
    stride = max(int(round(SCALE_SAMPLE_EVERY / h)), 1)
    step.run(arr, n_burn + SCALE_SAMPLES * stride, 0, n_burn, stride)
    if path_max is not None:
        path_max.extend(float(a) for a in arr.moments[..., K.MO_MAXA].ravel())
    amax = 1.25 * float(np.max(arr.moments[..., K.MO_MAXA]))
    if not math.isfinite(amax):
        raise _diverged(h, "non-finite amplitude in the pilot run", step.cause)
    return amax if amax > 0 else a_hint


def _relaxation(phys: dict[str, Any], h: float, seed: int, step: _Stepper, a_hi: float,
                sample_every: float, pairs: int = RELAX_PAIRS,
                max_time: float = RELAX_MAX_TIME) -> dict[str, Any]:
    """tau from pairs started low and high with common random numbers (tuning.py); the
    pilot's sizes are plan.py's."""
    gen = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1 << 22,)))
    amps = np.empty((2, pairs))
    amps[0], amps[1] = START_LOW * a_hi, a_hi
    state = _starts(amps, phys, gen)
    state[1, :, 2] = state[0, :, 2]  # the same noise state in both members of a pair
    rng = block_seeds(seed, 1, pairs, key=1 << 23)
    rng = np.concatenate([rng, rng.copy()])
    arr = _arrays(rng, state, _DUMMY, ())
    stride = max(int(round(sample_every / h)), 1)
    spw = max(int(round(RELAX_WINDOW / (stride * h))), 1)  # windows of ~RELAX_WINDOW
    win_steps = spw * stride
    win_time = win_steps * h
    n_win_max = int(max_time / win_time)
    windows = np.zeros((2, pairs, n_win_max))
    seg = max(int(RELAX_SEGMENT / win_time), 4)  # windows per segment
    done = 0
    t_d = np.empty(0)
    d = se = np.empty(0)
    while done < n_win_max:
        n = min(seg, n_win_max - done)
        step.run(arr, n * win_steps, done * win_steps, 0, stride, spw, windows)
        done += n
        diff = (windows[1, :, :done] - windows[0, :, :done]) / spw
        d = diff.mean(axis=0)
        se = diff.std(axis=0, ddof=1) / math.sqrt(pairs)
        t_d = (np.arange(done) + 0.5) * win_time
        if done >= 8 and np.all(np.abs(d[-4:]) < 2 * np.maximum(se[-4:], 1e-300)):
            break
    fit = fit_relaxation(t_d, d, se)
    fit.update({"pilot_time": float(done * win_time), "pairs": pairs,
                "converged": bool(done < n_win_max), "factor": BURN_FACTOR,
                "start_amplitudes": [START_LOW * a_hi, a_hi]})
    return fit


def _density(counts: np.ndarray, samples: np.ndarray, widths: np.ndarray) -> dict[str, Any]:
    """Block-mean density per unit length, its standard error, the L1 noise floor and the
    blocks' own densities (``blocks``: the batch means, whose spread a metric's error bar reads,
    harness/workflows/compare.py)."""
    per_block = counts / (samples.reshape((-1,) + (1,) * (counts.ndim - 1)) * widths)
    mean = per_block.mean(axis=0)
    se = per_block.std(axis=0, ddof=1) / math.sqrt(counts.shape[0])
    floor = float(np.sum(math.sqrt(2.0 / math.pi) * se * widths))
    return {"p": mean, "err": se, "L1_floor": floor, "blocks": per_block}


def _floor_A(arr: _Arrays) -> float:
    e = arr.hist["edges_A"]
    return _density(arr.hist["A"], np.maximum(arr.events[:, K.EV_SAMPLES], 1.0),
                    np.diff(e))["L1_floor"]


def simulate(system: Any, noise: Any, settings: Settings, *, parametric: Any = None,
             **overrides: Any) -> Result:
    """Monte Carlo of the original system for (duck-typed) scene.system, scene.noise and
    scene.parametric (``parametric``: None, or its stiffness and damping intensities).

    Raises ValueError on settings it cannot use (a ``resume`` checkpoint of another run among
    them), SimulationDiverged when the run blows up and BudgetExhausted when a target floor's
    budget ends before the first sampling window.

    ``settings.resume``: continue a run from its checkpoint (checkpoint.py): its step, burn-in
    and histogram ranges are kept (``dt`` and ``edges`` are not read), and the result is that of
    the whole run so far. ``settings.keep_state``: info["checkpoint"] holds where it stopped.
    """
    st = replace(settings, **overrides)
    ck = st.resume
    if isinstance(ck, bytes | bytearray):
        ck = Checkpoint.from_bytes(bytes(ck))
    obs = tuple(o for o in st.observables if o in OBSERVABLES)
    target = float(st.floor) if st.floor else 0.0
    if target > 0 and "A" not in obs:
        obs = ("A", *obs)
    phys = _params(system, noise, parametric)
    h = ck.h if ck is not None else step_size(st.dt, target, phys, st.sample_every)
    if not (math.isfinite(h) and h > 0 and st.paths >= st.blocks >= 2):
        raise ValueError("need dt > 0 and paths >= blocks >= 2")
    t_start = time.perf_counter()
    threads = st.threads or numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(threads)
    stride, spw, n_win = sampling_plan(st.time, st.sample_every, h, target)
    per_block = st.paths // st.blocks
    blocks = st.blocks
    run = run_key(phys, h, st.seed, blocks, per_block, obs, st.certificate)
    if ck is not None and (ck.key != run or (st.dt != "auto" and float(st.dt) != ck.h)):
        raise ValueError("resume: the checkpoint belongs to another run (its physics, dt, seed, "
                         "paths, blocks or observables differ from these settings)")

    # compile (or load from the cache) apart from the run: a one-step call of the same types
    t0 = time.perf_counter()
    edges = {k: np.asarray(v, dtype=float) for k, v in st.edges.items()}
    if ck is not None:
        edges = {k: np.asarray(ck.hist[k], dtype=float) for k in ("edges_A", "edges_x",
                                                                   "edges_v")}
    tiny = _arrays(block_seeds(st.seed, 1, 1), np.full((1, 1, 3), 0.1),
                   edges or {"edges_A": np.linspace(0, 1, 3), "edges_x": np.linspace(0, 1, 3),
                             "edges_v": np.linspace(-1, 1, 3)}, obs)
    _kernel(tiny, phys, h, 2, 0, 1, 1, 1, np.zeros((1, 1, 1)) if st.certificate else None)
    compile_s = time.perf_counter() - t0
    # the budget counts the run (pilots, burn-in, windows), not numba's one-off compile: a cold
    # cache would otherwise eat a small budget before any physics ran
    t_run = time.perf_counter()
    deadline = t_run + st.budget if st.budget and st.budget > 0 else math.inf

    bar = _progress(st.progress)
    step = _Stepper(phys, h, threads, bar, _growth(system, parametric))
    try:
        dt_rule = None
        if ck is None:  # a new run: pilots, burn-in
            t1 = time.perf_counter()
            a_hint = float(edges["edges_A"][-1]) if "edges_A" in edges else 1.0
            path_max: list[float] = []
            a_hi = _pilot_scale(phys, h, st.seed, step, a_hint, path_max)
            if st.dt == "auto":  # the step from the orbits the pilot's paths reach (auto_dt)
                a_typ = float(np.median(path_max)) if np.isfinite(path_max).all() else math.nan
                h_pilot, h = h, step_size(st.dt, target, phys, st.sample_every, a_typ)
                step.h = h
                stride, spw, n_win = sampling_plan(st.time, st.sample_every, h, target)
                dt_rule = {"pilot_dt": h_pilot, "amplitude": a_typ, "omega_ref": OMEGA_REF,
                           "omega": scene_omega(phys, a_typ) if a_typ > 0 else None,
                           "rule": "dt = dt_ref(F) OMEGA_REF / Omega, Omega the fastest free "
                                   "orbit on amplitudes up to the median of the scale pilot's "
                                   "path maxima (montecarlo/tuning.py)"}
            if not edges:
                try:
                    vmax = math.sqrt(2 * _potential(a_hi, phys))
                except OverflowError:
                    vmax = math.inf
                if not math.isfinite(vmax):
                    raise _diverged(h, f"the pilot reached amplitude {a_hi:.3g}, whose energy "
                                    "overflows double precision", step.cause)
                edges = {"edges_A": np.linspace(0.0, a_hi, st.bins + 1),
                         # x1 lives on [a, b] (the walls), within the pilot's reach
                         "edges_x": np.linspace(max(-a_hi, bounds(phys)[0]),
                                                min(a_hi, bounds(phys)[1]), st.bins + 1),
                         "edges_v": np.linspace(-vmax, vmax, st.bins + 1)}
            relax = None
            if st.burn_in == "auto":
                _label(bar, "monte carlo: relaxation pilot")
                relax = _relaxation(phys, h, st.seed, step, a_hi, st.sample_every)
                burn_in = max(BURN_FACTOR * relax["tau"], MIN_AUTO_BURN_IN)
            else:
                burn_in = float(st.burn_in)
            pilot_s = time.perf_counter() - t1

            need = float(blocks * per_block) * (burn_in / h + n_win * spw * stride)
            if st.burn_in == "auto" and need > st.max_path_steps:
                raise CostRefused(
                    f"the relaxation pilot measured a relaxation time of {relax['tau']:.3g}, so "
                    f"the burn-in is {burn_in:.3g} and the run {need:.3g} path-steps, more "
                    f"than the {st.max_path_steps:.3g} allowed",
                    relaxation_time=float(relax["tau"]), burn_in=float(burn_in),
                    path_steps=need, limit=float(st.max_path_steps))
            if not burn_in / h < 2.0**53:  # beyond any run (and numba's integers)
                raise SimulationDiverged(
                    "the relaxation pilot measured a relaxation time of "
                    f"{burn_in / BURN_FACTOR:.3g} (burn-in {burn_in:.3g} = {burn_in / h:.3g} "
                    f"steps of dt = {h:g}): the paths "
                    "barely forget their start (most likely the noise is too weak to mix them: "
                    "check noise.D and f); give montecarlo.burn_in explicitly to run anyway")
            n_burn = int(round(burn_in / h))
            win_steps = spw * stride
            gen = np.random.default_rng(np.random.SeedSequence(st.seed, spawn_key=(1 << 24,)))
            frac = START_LOW + (1 - START_LOW) * (np.arange(per_block) + 0.5) / per_block
            amps = np.broadcast_to(a_hi * frac, (blocks, per_block)).copy()
            arr = _arrays(block_seeds(st.seed, blocks, per_block), _starts(amps, phys, gen),
                          edges, obs)
            windows = np.zeros((blocks, per_block, n_win)) if st.certificate else None

            t2 = time.perf_counter()
            if bar is not None:
                bar.reset(total=blocks * per_block * (n_burn + n_win * win_steps))
                _label(bar, "monte carlo")
            step.run(arr, n_burn, 0, n_burn, stride)
            run_to = 0  # windows simulated
        else:  # continued from a checkpoint: its plan, its paths, the next window on
            relax, pilot_s = ck.relax, 0.0
            n_burn, stride, spw = ck.n_burn, ck.stride, ck.spw
            burn_in, win_steps = n_burn * h, spw * stride
            arr = _Arrays(rng=ck.arrays["rng"].copy(), state=ck.arrays["state"].copy(),
                          hist={**edges, **{k: None if ck.hist[k] is None else
                                            ck.hist[k].copy() for k in ("A", "x", "v",
                                                                        "joint")}},
                          moments=_copy(ck.arrays["moments"]), events=ck.arrays["events"].copy(),
                          stuck=ck.arrays["stuck"].copy(), energy=_copy(ck.arrays["energy"]))
            windows = _copy(ck.windows)
            run_to = n_win = ck.run_to
            t2 = time.perf_counter()
            if bar is not None:
                bar.reset(total=1)
                _label(bar, "monte carlo: extending")
        stopped = "fixed time"
        floor = math.nan
        while True:
            while run_to < n_win:  # window by window: the budget is checked between windows
                if target > 0 and time.perf_counter() >= deadline:
                    stopped = "budget"
                    break
                step.run(arr, win_steps, n_burn + run_to * win_steps, n_burn, stride, spw,
                         windows)
                run_to += 1
            if run_to == 0:  # only a target floor's budget stops a run before its first window
                raise BudgetExhausted(
                    f"the budget of {st.budget:g} s ran out before the first sampling window "
                    f"(the pilots and the burn-in took {time.perf_counter() - t_run:.3g} s): "
                    "no sample was taken; give a larger budget, or 0 for no limit")
            if "A" in obs:
                floor = _floor_A(arr)
            if target <= 0:
                break
            if floor <= target:
                stopped = "floor reached"
                break
            if stopped == "budget" or time.perf_counter() >= deadline:
                stopped = "budget"
                break
            # the 1/sqrt(time) law, but at most doubling: early floors fall faster than the
            # law (the start of the sampled time is correlated with the burn-in's end), so a
            # long leap from a short run overshoots
            grow = min(max(math.ceil(run_to * ((floor / target) ** 2 * 1.02 - 1)), 1), run_to)
            n_win = run_to + grow
            if windows is not None:
                windows = np.concatenate([windows, np.zeros((blocks, per_block, grow))], axis=2)
            if bar is not None:
                bar.total += blocks * per_block * grow * win_steps
                bar.set_postfix_str(f"L1 floor {floor:.4f} -> {target:g}", refresh=False)
        run_s = time.perf_counter() - t2
    finally:
        if bar is not None:
            bar.close()

    if windows is not None and run_to < windows.shape[2]:
        windows = windows[:, :, :run_to]
    ev = arr.events
    samples = ev[:, K.EV_SAMPLES]
    if not samples.min() > 0:
        raise ValueError("no sample was taken: time must be at least sample_every")
    data: dict[str, dict[str, Any]] = {}
    names = {"A": ("A", "edges_A"), "x1": ("x", "edges_x"), "x2": ("v", "edges_v")}
    floors = {}
    for name, (key, ekey) in names.items():
        if arr.hist[key] is None:
            continue
        e = edges[ekey]
        d = _density(arr.hist[key], samples, np.diff(e))
        data[name] = {"x": 0.5 * (e[1:] + e[:-1]), "p": d["p"], "edges": e, "err": d["err"],
                      "p_blocks": d["blocks"]}
        floors[name] = d["L1_floor"]
    if "x2" in data or "joint" in obs:
        atom = _mean_se(ev[:, K.EV_ATOM] / samples)
        if "x2" in data:  # flat numbers, so that every density field stays an array
            data["x2"].update(atom_at=0.0, atom_weight=atom["value"], atom_err=atom["err"])
    if arr.hist["joint"] is not None:
        ex, evv = edges["edges_x"], edges["edges_v"]
        area = np.outer(np.diff(ex), np.diff(evv))
        d = _density(arr.hist["joint"], samples, area)
        data["joint"] = {"x1": 0.5 * (ex[1:] + ex[:-1]), "x2": 0.5 * (evv[1:] + evv[:-1]),
                         "p": d["p"], "err": d["err"], "edges_x1": ex, "edges_x2": evv}
        floors["joint"] = d["L1_floor"]
    for name, col in (("A", K.EV_OUT_A), ("x1", K.EV_OUT_X)):
        if name in data and ev[:, col].sum() >= samples.sum():
            raise _diverged(h, f"every sample of {name} fell outside its histogram range",
                           step.cause)

    sampled = run_to * win_steps * h
    steps = float(blocks * per_block * (n_burn + run_to * win_steps))
    info: dict[str, Any] = {
        "solver": "montecarlo",
        "steps_this_run": steps - (ck.steps if ck is not None else 0.0),
        "settings": {"paths": blocks * per_block, "dt": h, "time": sampled,
                     "burn_in": n_burn * h, "sample_every": stride * h, "blocks": blocks,
                     "bins": st.bins, "observables": list(obs),
                     "dt_mode": "auto" if st.dt == "auto" else "fixed",
                     "burn_in_mode": "auto" if st.burn_in == "auto" else "fixed"},
        "seed": {"root": st.seed, "scheme": "path p of block b: words 4p..4p+3 of "
                 "numpy.random.SeedSequence(root, spawn_key=(b,)).generate_state",
                 "first_path_state": [int(v) for v in block_seeds(st.seed, 1, 1)[0, 0]]},
        "effects": effects(system, noise),
        "threads": threads,
        "order": {"weak": K.WEAK_ORDER_NONSMOOTH, "weak_smooth": K.WEAK_ORDER_SMOOTH,
                  "note": "Strang splitting: 2 on the smooth sub-system (no barrier, no "
                          "friction), 1 across impacts and stick-slip; measured in tests"},
        "L1_floor": floors,
        "seconds": {"compile": compile_s, "pilot": pilot_s, "run": run_s,
                    "total": time.perf_counter() - t_start},
        "steps": steps, "steps_per_second": steps / step.busy if step.busy > 0 else math.nan,
        "versions": {"numba": numba.__version__, "numpy": np.__version__,
                     "python": platform.python_version()},
    }
    if relax is not None:
        info["relaxation"] = relax
    if dt_rule is not None:
        info["dt_rule"] = dt_rule
    conv: dict[str, Any] = {}
    if windows is not None and run_to >= 1 and arr.moments is not None:
        m = _per_block(arr.moments, _MAX_COLUMNS)
        var_A = float(np.sum(m[:, K.MO_A2]) / samples.sum()
                      - (np.sum(m[:, K.MO_A]) / samples.sum()) ** 2)
        conv = certificate(windows, spw, var_A, win_steps * h)
    elif windows is not None and run_to >= 1:
        conv = certificate(windows, spw, float(np.var(windows / spw)), win_steps * h)
    else:
        conv = {"equilibrated": None, "reason": "no certificate was asked for"}
    conv.update({"burn_in": n_burn * h, "burn_in_mode": info["settings"]["burn_in_mode"],
                 "target_floor": target if target > 0 else None,
                 "floor": floor if "A" in obs else None,
                 "reached": (bool(floor <= target) if target > 0 else None),
                 "stopped": stopped, "budget": st.budget if st.budget else None})
    if relax is not None:
        conv["relaxation_time"] = relax["tau"]
    if target > 0 and not conv["reached"]:
        why = f"the budget of {st.budget:g} s ran out at L1 floor {floor:.4f}"
        conv["reason"] = "; ".join(r for r in (conv.get("reason"), why) if r)
    info["convergence"] = conv
    if "events" in obs:
        info["events"] = _events(ev, ev[:, K.EV_TIME] * h, samples, h)
    if "moments" in obs:
        info["moments"] = _moments(_per_block(arr.moments, _MAX_COLUMNS), samples)
    if arr.energy is not None:
        info["energy"] = _energy(_per_block(arr.energy), ev[:, K.EV_TIME] * h, phys)
    if "x2" in data:
        info["atoms"] = {"x2": {"at": 0.0, "weight": data["x2"]["atom_weight"],
                                "err": data["x2"]["atom_err"]}}
    info["warnings"] = []
    if ck is not None and ck.notes.get("dt_check"):  # the step and its check: the first stage's
        chk = {**ck.notes["dt_check"], "note": "checked when the run began (at its floor), "
               "not again for its continuation"}
        info["dt_check"] = chk
        if chk.get("verdict") == "failed":
            info["warnings"].append(chk["message"])
    elif st.dt == "auto" and st.dt_check and "A" in data:
        t3 = time.perf_counter()
        chk = _step_check(system, noise, st, data["A"], edges, h, n_burn * h, sampled, floor,
                          target, deadline, (dt_rule or {}).get("omega"))
        info["seconds"]["dt_check"] = time.perf_counter() - t3
        info["seconds"]["total"] = time.perf_counter() - t_start
        info["dt_check"] = chk
        if chk["verdict"] == "failed":
            info["warnings"].append(chk["message"])
    ok = all(np.all(np.isfinite(d["p"])) for d in data.values())
    if not ok:
        raise _diverged(h, "non-finite histogram", step.cause)
    if ck is not None:
        info["resumed"] = {"windows": ck.run_to, "steps": ck.steps,
                           "note": "continued from a checkpoint: the same paths and random "
                                   "streams from its next window on (no pilot, no burn-in)"}
    if ck is not None and ck.notes.get("dt_rule"):
        info["dt_rule"] = ck.notes["dt_rule"]
    if st.keep_state:  # the key of the step it ran at (dt "auto" settles after the pilot)
        notes = {k: info[k] for k in ("dt_rule", "dt_check") if k in info}
        info["checkpoint"] = Checkpoint(
            key=run_key(phys, h, st.seed, blocks, per_block, obs, st.certificate), notes=notes,
            arrays={k: getattr(arr, k) for k in ("rng", "state", "moments", "events",
                                                           "stuck", "energy")},
            hist=dict(arr.hist), windows=windows, run_to=run_to, n_burn=n_burn, stride=stride,
            spw=spw, h=h, steps=steps, relax=relax)
    info["status"] = Status.SIMULATED.record()
    cfg = info["settings"]
    return Result(data=data, info=info, resolved=Resolved(
        dt=cfg["dt"], burn_in=cfg["burn_in"], time=cfg["time"], paths=cfg["paths"],
        blocks=cfg["blocks"], sample_every=cfg["sample_every"]))


def _copy(a: np.ndarray | None) -> np.ndarray | None:
    return None if a is None else a.copy()


def _step_check(system: Any, noise: Any, st: Settings, dens: dict[str, Any],
                edges: dict[str, np.ndarray], h: float, burn_in: float, sampled: float,
                floor: float, target: float, deadline: float, omega: float | None
                ) -> dict[str, Any]:
    """The run-time check of dt = "auto" (tuning.step_check): an independent run at
    CHECK_FACTOR x dt (its own seed, derived from the run's; the run's edges and burn-in, so
    no pilot measures anything again; the run's observables, so no kernel is compiled anew)
    to a floor CHECK_FLOOR_RATIO x the run's, within what is left of the budget; then the
    bias of p(A) at dt is judged against BIAS_FRACTION x the target floor. The verdict and a
    sentence (``message``); a failed check's sentence goes to the run's ``warnings``."""
    allowance = BIAS_FRACTION * (target if target > 0 else DEFAULT_FLOOR)
    k = CHECK_FACTOR
    head = f"dt = {h:.4g} (auto)"
    # the splitting's linear stability limit is dt omega < 2 (docs/montecarlo.md); the check
    # stays at half of it for the fastest orbit the rule saw
    if omega is not None and k * h * omega >= 1.0:
        return {"verdict": "not run", "dt": h, "message": f"{head}: the step check was not "
                f"run: {k} x dt is too close to the stability limit dt Omega = 2"}
    left = deadline - time.perf_counter()
    if left <= 0:
        return {"verdict": "not run", "dt": h, "message": f"{head}: the step check was not "
                "run: the budget was spent"}
    seed = int(np.random.SeedSequence(st.seed, spawn_key=(1 << 25,)).generate_state(1)[0])
    # a floor CHECK_FLOOR_RATIO x the run's takes 1 / CHECK_FLOOR_RATIO^2 of its sampled time:
    # the floor mode starts with half of ``time`` and extends from there
    time_c = max(2 * sampled / CHECK_FLOOR_RATIO**2, 16 * st.sample_every)
    chk_st = replace(st, dt=k * h, burn_in=burn_in, floor=CHECK_FLOOR_RATIO * floor,
                     time=time_c, seed=seed, edges=edges, dt_check=False, resume=None,
                     keep_state=False, max_path_steps=math.inf,
                     budget=left if math.isfinite(left) else 0.0)
    try:
        coarse = simulate(system, noise, chk_st).data["A"]
    except (SimulationDiverged, BudgetExhausted) as exc:
        return {"verdict": "not run", "dt": h, "message": f"{head}: the step check at "
                f"{k} x dt could not run ({str(exc).split(':')[0]})"}
    out = step_check(dens, coarse, dt=h, factor=k, allowance=allowance)
    lo, hi = out["bias_range"]
    said = {"passed": "within", "failed": "ABOVE", "undecided": "not decided against"}
    out["message"] = (f"{head}: the step check ({k} x dt, an independent run) puts the bias of "
                      f"p(A) at {lo:.2g}-{hi:.2g} in L1 (as it grows like dt^2 or dt), "
                      f"{said[out['verdict']]} the allowance {allowance:.2g} (half the target "
                      "floor)")
    if out["verdict"] == "failed":
        out["message"] += (": the step rule does not hold here and p(A) carries a step bias; "
                           f"run again with --dt {h / 4:.3g} or smaller")
    return out


def _mean_se(per_block: np.ndarray) -> dict[str, float]:
    return {"value": float(per_block.mean()),
            "err": float(per_block.std(ddof=1) / math.sqrt(per_block.size))}


def _events(events: np.ndarray, sim_time: np.ndarray, samples: np.ndarray, h: float
            ) -> dict[str, Any]:
    out = {
        "impacts_per_time": _mean_se(events[:, K.EV_IMPACTS] / sim_time),
        "stuck_fraction": _mean_se(events[:, K.EV_STUCK] / sim_time),
        "chatter_entries_per_time": _mean_se(events[:, K.EV_CHATTER] / sim_time),
        "chatter_entries": int(events[:, K.EV_CHATTER].sum()),
        "chatter_cutoff": {
            "rule": "after an impact the mass rests on the wall when its rebound speed r|v| is "
                    "below P dt, P = mu - f xi > 0 the net force pressing it back (the next "
                    "flight would be shorter than one step; at a wall at x = a != 0 the "
                    "spring's force -g(a) counts too, and r is the law's e(|v|))",
            "dt": h,
            "note": "in chattering motion the impact rate depends on this cut-off"},
        "outside_fraction": {k: float(events[:, c].sum() / samples.sum()) for k, c in
                             (("A", K.EV_OUT_A), ("x1", K.EV_OUT_X), ("x2", K.EV_OUT_V))},
    }
    return out


def _energy(en: np.ndarray, sim_time: np.ndarray, phys: dict[str, Any]) -> dict[str, Any]:
    """Stationary power balance, per unit time with block errors: input = damping + friction
    + impacts. ``residual`` = input - losses block by block (its error bar is the test)."""
    rate = en / sim_time[:, None]
    losses = rate[:, K.EN_DAMP] + rate[:, K.EN_FRICTION] + rate[:, K.EN_IMPACT]
    out = {"input": _mean_se(rate[:, K.EN_INPUT]), "damping": _mean_se(rate[:, K.EN_DAMP]),
           "friction": _mean_se(rate[:, K.EN_FRICTION]),
           "impacts": _mean_se(rate[:, K.EN_IMPACT]), "losses": _mean_se(losses),
           "residual": _mean_se(rate[:, K.EN_INPUT] - losses)}
    exact = noise_piece(phys, "input_power")  # white noise: f^2 D (Ito); else None
    if exact is not None:
        out["input_exact"] = exact
    return out


def _moments(mom: np.ndarray, samples: np.ndarray) -> dict[str, Any]:
    s = samples
    out = {}
    for name, c1, c2 in (("A", K.MO_A, K.MO_A2), ("x1", K.MO_X, K.MO_X2), ("x2", K.MO_V, K.MO_V2)):
        out[name] = {"mean": _mean_se(mom[:, c1] / s), "second": _mean_se(mom[:, c2] / s)}
    out["max"] = {"A": float(mom[:, K.MO_MAXA].max()), "x1": float(mom[:, K.MO_MAXX].max()),
                  "x2": float(mom[:, K.MO_MAXV].max())}
    return out


class _Lines:
    """A stream for a progress bar that is not drawn on a terminal (a log file, a pipe): each
    redraw becomes one plain line, never a run of carriage returns; the bar's erasures (blank
    redraws) are dropped."""

    def __init__(self, stream: Any) -> None:
        self.stream = stream

    def write(self, text: str) -> None:
        for part in text.split("\r"):
            part = part.strip()
            if part:
                self.stream.write(part + "\n")

    def flush(self) -> None:
        self.stream.flush()


#: seconds between two progress lines when stderr is not a terminal
PLAIN_PROGRESS_EVERY = 30.0


def _progress(enabled: bool, *, total: float = 1, desc: str = "monte carlo: pilot",
              unit: str = " steps") -> Any:
    """A tqdm bar in path-steps (it shows the ETA); quiet for runs under 3 s. (tqdm's
    ``reset`` draws the bar at once, delay or not: a caller that knows its total gives it
    here.) On a terminal it redraws in place; elsewhere it writes a plain line every
    PLAIN_PROGRESS_EVERY seconds."""
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None
    try:
        tty = sys.stderr.isatty()
    except (AttributeError, ValueError):
        tty = False
    if tty:
        return tqdm(total=total, desc=desc, unit=unit, unit_scale=True, delay=3.0,
                    file=sys.stderr, leave=False)
    return tqdm(total=total, desc=desc, unit=unit, unit_scale=True, delay=3.0,
                file=_Lines(sys.stderr), leave=False, ascii=True, ncols=100,
                mininterval=PLAIN_PROGRESS_EVERY)


def _label(bar: Any, text: str) -> None:
    if bar is not None:
        bar.set_description_str(text, refresh=False)
