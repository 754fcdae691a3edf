"""First passage of the ORIGINAL system's energy through a threshold (issue 30).

Each path is advanced with the kernel's own step (``kernels.strang_step``: the Strang splitting of
the original system, nothing of its physics is repeated here) until its energy

    E = v^2/2 + U(x),   U the potential of the scene's spring (geometry.potential)

first reaches Ec = U(Ac), Ac the threshold amplitude, or until the horizon (censored).

**The crossing inside the step.** With OU noise xi is continuous, so E(t) = v (f xi - k v -
mu sgn v) is C^1 between impacts (an impact only lowers E). When E_n < Ec <= E_{n+1} the
crossing time is the root of the straight line through (t_n, E_n), (t_{n+1}, E_{n+1}):

    t* = t_n + h (Ec - E_n) / (E_{n+1} - E_n),

whose error is h^2 E'' / (8 E') on the step's own path: O(dt^2), the order of the scheme on
the smooth sub-system (CROSSING_ORDER, measured against solve_ivp in
tests/test_passage_mc.py; across impacts and stick-slip the scheme itself is first order).
With white noise E is a diffusion, which may cross and come back inside a step; a step that
ends below Ec is then counted as a crossing with the Brownian-bridge probability

    exp(-2 (Ec - E_n)(Ec - E_{n+1}) / (sigma_H^2 h))

(the law of the maximum of a Brownian bridge with the variance rate frozen over the step:
Gobet 2000; one uniform drawn from the path's stream only when that probability exceeds
1e-14), located at t_n + h (Ec - E_n) / (2 Ec - E_n - E_{n+1}); without it discrete
monitoring biases the first-passage time up by O(dt^(1/2)).

**The energy's variance rate.** With the Stratonovich parametric noises of scene.parametric,

    x'' + d(x) x' (1 + xi_c) + g(x) (1 + xi_k) + ... = f xi,
    E[xi_k xi_k] = 2 D_k delta, E[xi_c xi_c] = 2 D_c delta, independent of xi and each other,

the velocity's noise part is dv = f dW - g(x) sqrt(2 D_k) o dW_k - d(x) v sqrt(2 D_c) o dW_c
(d(x) the damping coefficient, kernels.damping_k). By Ito's formula dH = v dv + (dv)^2 / 2 +
g(x) dx for H = v^2/2 + U(x); the Stratonovich corrections and the (dv)^2 / 2 term are drifts
(dt), so the martingale part of dH is v (f dW - g sqrt(2 D_k) dW_k - d v sqrt(2 D_c) dW_c) and
its quadratic variation rate is (docs/averaging.md section 12, sigma_H^2 before averaging)

    sigma_H^2 = v^2 (2 D f^2 + 2 D_k g(x)^2 + 2 D_c d(x)^2 v^2),

the first term for white external noise only (OU noise is continuous: it adds nothing to the
quadratic variation, and with OU noise alone, D_k = D_c = 0, E is C^1 and no bridge is drawn).
``passage_kernels.energy_variance`` freezes it over the step at the velocity at the kick (the
middle of the step) and at x = x_n: sigma_H^2 h = v^2 (P.bridge h + 2 pk^2 g^2 + 2 pc^2 d^2
v^2) with P.bridge = 2 D f^2 (None for OU), pk^2 = D_k h, pc^2 = D_c h (pieces.record; None
when off). With both parametric intensities off the test is the additive-noise one, bit for
bit.

**Starts.** ``start = A0``: energy U(A0), a phase uniform in time along that conservative
orbit (geometry.orbit_start; folded onto x >= 0 with the barrier), xi from its stationary law
N(0, D / alpha1). ``start = "stationary"``: the stationary law restricted to A < Ac, by
rejection: each path starts at amplitude ``burn_start`` (Ac / 2 when 0) as above, runs
``burn_in`` time units of the free system (no threshold; "auto": BURN_FACTOR x the
relaxation time measured by the relaxation pilot (pilots.py), at least MIN_AUTO_BURN_IN), and is
accepted if then E < Ec;
else it starts again (its generator goes on) from ``burn_start``, at most ``max_restarts``
times (StartRejected beyond). The accepted states are the law at time burn_in conditioned on
A < Ac, which is the restricted stationary law when burn_in is several relaxation times. The
first-passage clock starts at the accepted state.

**Seeds.** Path p of block b has its own xoshiro state (rng.block_seeds: words of
SeedSequence(seed, spawn_key=(b,))) and its own state machine; kernel calls give each
unfinished path at most a budget of steps, and a path's arithmetic does not depend on the
budget, so any cut into calls and any thread count give bit-identical results. Times are
(step index + fraction) x dt with an integer step index, never a running float sum.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from numbers import Real
from typing import Any

import numba
import numpy as np
from vifpk.montecarlo.failures import diverged, likely_cause
from vifpk.montecarlo.passage_kernels import (
    CENSORED,
    CROSSED,
    DIVERGED,
    REFUSED,
    RUN,
    run_passage,
    starts_loop,
)
from vifpk.montecarlo.pilots import pilot_scale, relaxation
from vifpk.montecarlo.progress import progress_bar
from vifpk.montecarlo.rng import block_seeds
from vifpk.montecarlo.runplan import effects
from vifpk.montecarlo.stepper import CHUNK_SECONDS, Stepper

from vifpk.core.defaults import BURN_FACTOR
from vifpk.core.result import BadInput, Result, Status

from .geometry import amplitudes, potential
from .pieces import record
from .plan import (
    MIN_AUTO_BURN_IN,
    SCALE_SAMPLE_EVERY,
    bounds,
    fold,
    physics,
)

CROSSING_ORDER = 2  # O(dt^2) crossing time on the smooth sub-system with OU noise (see module)


class StartRejected(RuntimeError):
    """The "stationary" start failed: a path's burn-ins ended at or above the threshold more
    than ``max_restarts`` times in a row (the threshold is inside the bulk of the stationary
    law). One line."""


@dataclass(frozen=True, kw_only=True)
class PassageSettings:
    """Settings of first_passage and snapshots: plain numbers.

    paths (split over ``blocks`` as evenly as whole numbers allow), dt (the step), horizon
    (the censoring time), seed (root), threads (0: numba's default), progress (a tqdm bar on
    stderr for runs over 3 s); for start = "stationary": burn_in (time units of free
    simulation before the clock starts, > 0, or "auto": BURN_FACTOR x the relaxation time
    measured by the relaxation pilot (pilots.py)), burn_start (the amplitude the burn-in starts
    from; 0: half the threshold), max_restarts (burn-ins a path may repeat)."""

    paths: int
    blocks: int
    dt: float
    horizon: float
    seed: int
    threads: int = 0
    progress: bool = True
    burn_in: float | str = 0.0
    burn_start: float = 0.0
    max_restarts: int = 100


def _auto_burn_in(phys: dict[str, Any], h: float, seed: int, threads: int, cause: str,
                  threshold: float) -> tuple[dict[str, Any], float]:
    """(relaxation fit, burn-in) for burn_in = "auto": the scale pilot and relaxation
    pilot (pairs started low and high with common random numbers, tuning.fit_relaxation),
    then max(BURN_FACTOR tau, MIN_AUTO_BURN_IN), as the stationary run does."""
    step = Stepper(phys, h, threads, None, cause)
    a_hi = pilot_scale(phys, h, seed, step, threshold)
    relax = relaxation(phys, h, seed, step, a_hi, SCALE_SAMPLE_EVERY)
    if not math.isfinite(relax["tau"]):
        raise StartRejected("start 'stationary' with burn_in 'auto': the relaxation pilot "
                            "found no finite relaxation time; give burn_in explicitly")
    return relax, max(BURN_FACTOR * relax["tau"], MIN_AUTO_BURN_IN)


def layout(paths: int, blocks: int) -> np.ndarray:
    """Paths per block: ``paths`` split over ``blocks`` as evenly as whole numbers allow (the
    first paths % blocks blocks one more)."""
    return np.array([paths // blocks + (b < paths % blocks) for b in range(blocks)],
                    dtype=np.int64)


def check_settings(st: PassageSettings) -> None:
    """One line naming a setting out of range (BadInput), before any computation."""
    if not (isinstance(st.blocks, int) and st.blocks >= 2):
        raise BadInput(f"blocks must be a whole number >= 2 (got {st.blocks!r})")
    if not (isinstance(st.paths, int) and st.paths >= st.blocks):
        raise BadInput(f"paths must be a whole number >= blocks = {st.blocks} "
                       f"(got {st.paths!r})")
    for name in ("dt", "horizon"):
        val = getattr(st, name)
        if not (isinstance(val, Real) and math.isfinite(val) and val > 0):
            raise BadInput(f"{name} must be a finite number > 0 (got {val!r})")
    if st.horizon / st.dt >= 2.0**62:
        raise BadInput(f"horizon / dt = {st.horizon / st.dt:.3g} steps is beyond any run")
    if st.burn_in != "auto" and not (isinstance(st.burn_in, Real)
                                     and math.isfinite(st.burn_in) and st.burn_in >= 0):
        raise BadInput(f"burn_in must be a time >= 0 or 'auto' (got {st.burn_in!r})")
    if not (st.burn_start >= 0 and st.max_restarts >= 0):
        raise BadInput("burn_start and max_restarts must be >= 0")


def _check_threshold(threshold: float, start: float | str) -> None:
    if not (isinstance(threshold, Real) and math.isfinite(threshold) and threshold > 0):
        raise BadInput(f"threshold must be a finite amplitude > 0 (got {threshold!r})")
    if isinstance(start, str):
        if start != "stationary":
            raise BadInput(f"start must be an amplitude or 'stationary' (got {start!r})")
    elif not (isinstance(start, Real) and 0 <= start < threshold):
        raise BadInput(f"start must be an amplitude in [0, threshold = {threshold:g}) "
                       f"(got {start!r})")


def sample_starts(system: Any, noise: Any, *, amplitude: float, n: int, seed: int
                  ) -> np.ndarray:
    """(n, 3) starts (x, v, xi) at ``amplitude`` as first_passage draws them (orbit_start),
    path i from the stream of path i of one block (block_seeds(seed, 1, n))."""
    phys = physics(system, noise)
    rng = block_seeds(seed, 1, n)[0]
    out = np.empty((n, 3))
    # the record's class picks the kind's state start (its step coefficients are not used)
    starts_loop(rng, out, float(amplitude), phys["w0sq"], phys["alpha"], phys["khi"],
                (fold(phys), *bounds(phys)), record(phys, 1.0))
    return out


def first_passage(system: Any, noise: Any, settings: PassageSettings, *, threshold: float,
                  start: float | str, parametric: Any = None, bridge: bool = True) -> Result:
    """First passage of the energy through U(threshold) (see the module docstring), with the
    Stratonovich parametric noises of ``parametric`` (scene.parametric; None: off).
    ``bridge=False`` switches the Brownian-bridge test off (discrete monitoring at the step
    ends only): the uncorrected estimate, to measure the correction (tests).

    data["fpt"] = {"time": float64[paths] (the horizon where censored), "censored":
    bool[paths]}; data["start"] = {"x", "v", "xi", "A"}: each path's state when its clock
    started (for "stationary": after its accepted burn-in). Paths are ordered block by block.
    Raises BadInput (one line) on settings or a start it cannot use, SimulationDiverged on a
    non-finite state, StartRejected when "stationary" cannot place a path below Ac."""
    st = settings
    check_settings(st)
    _check_threshold(threshold, start)
    phys = physics(system, noise, parametric)
    stationary = isinstance(start, str)
    if stationary and st.burn_in != "auto" and not st.burn_in > 0:
        raise BadInput("start 'stationary' needs burn_in > 0 (time units of free simulation "
                       "before the clock starts; several relaxation times)")
    a_burn = (st.burn_start or 0.5 * threshold) if stationary else 0.0
    h = float(st.dt)
    n_max = int(math.ceil(st.horizon / h * (1 - 1e-12)))
    Ec = float(potential(float(threshold), phys["w0sq"], phys["alpha"], phys["khi"]))
    if not (math.isfinite(Ec) and Ec < 1e300):
        raise BadInput(f"threshold {threshold:g}: its energy U(threshold) = {Ec:g} is beyond "
                       "double precision")
    count = layout(st.paths, st.blocks)
    per = int(count.max())
    threads = st.threads or numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(threads)
    P = record(phys, h)  # bridge: None, or 2 D f^2 (white noise; 0 -> None: E is C^1)
    # the bridge test's terms; bridge=False keeps their types with the value 0 (a variance 0:
    # never a crossing, no draw, as with None), so it runs the kernel the bridged run compiled
    B = tuple(t if bridge or t is None else 0.0 for t in (P.bridge, P.pk, P.pc))

    def arrays(blocks: int, per_block: int, seed: int) -> dict[str, np.ndarray]:
        return {"rng": block_seeds(seed, blocks, per_block),
                "state": np.zeros((blocks, per_block, 3)),
                "init": np.zeros((blocks, per_block, 3)),
                "phase": np.zeros((blocks, per_block), dtype=np.int64),
                "steps": np.zeros((blocks, per_block), dtype=np.int64),
                "tries": np.zeros((blocks, per_block), dtype=np.int64),
                "fpt": np.zeros((blocks, per_block))}

    def call(a: dict[str, np.ndarray], cnt: np.ndarray, budget: int) -> None:
        arrs = (a["rng"], a["state"], a["init"], a["phase"], a["steps"], a["tries"], a["fpt"])
        run = (budget, n_max, n_burn, float(st.horizon), Ec, float(0.0 if stationary else start),
               float(a_burn), int(st.max_restarts))
        run_passage(arrs, cnt, run, h, B, P)

    relax = None
    cause = likely_cause(system, parametric, h)
    burn_in = float(st.burn_in) if stationary and st.burn_in != "auto" else 0.0
    if stationary and st.burn_in == "auto":
        relax, burn_in = _auto_burn_in(phys, h, st.seed, threads, cause, threshold)
    n_burn = int(round(burn_in / h))
    t0 = time.perf_counter()
    call(arrays(1, 1, st.seed), np.ones(1, dtype=np.int64), 1)  # compile (or load the cache)
    compile_s = time.perf_counter() - t0
    a = arrays(st.blocks, per, st.seed)
    total = float(st.paths) * (n_max + n_burn)
    bar = progress_bar(st.progress, total=total, desc="first passage")
    rate = 5e6 * threads
    t1 = time.perf_counter()
    shown = 0.0
    # the lanes that hold paths (a block with fewer paths than the widest has padding lanes,
    # which the kernel never advances: counted as active they kept this loop going forever)
    mask = np.arange(per)[None, :] < count[:, None]
    try:
        while True:
            active = int(np.sum(a["phase"][mask] < CROSSED))
            if active == 0:
                break
            budget = int(max(1, min(CHUNK_SECONDS * rate / active, n_max + n_burn)))
            t = time.perf_counter()
            call(a, count, budget)
            spent = time.perf_counter() - t
            if spent > 0:
                rate = 0.5 * rate + 0.5 * budget * active / spent
            if np.any(a["phase"] == DIVERGED):
                raise diverged(h, "non-finite position or velocity in the first-passage run",
                               cause)
            if np.any(a["phase"] == REFUSED):
                bad = int(np.sum(a["phase"] == REFUSED))
                raise StartRejected(
                    f"start 'stationary': {bad} path(s) ended {st.max_restarts + 1} burn-ins "
                    f"in a row at or above the threshold {threshold:g}: the threshold lies "
                    "inside the bulk of the stationary law; give a higher threshold or an "
                    "amplitude start")
            if bar is not None:
                done = _resolved(a, n_max, n_burn)
                bar.update(max(done - shown, 0.0))
                shown = max(shown, done)
    finally:
        if bar is not None:
            bar.close()
    run_s = time.perf_counter() - t1
    tm = a["fpt"][mask]
    censored = (a["phase"] == CENSORED)[mask]
    s = a["init"][mask]
    amp = _amplitudes(s[:, 0], s[:, 1], phys)
    path_steps = float(np.sum(a["steps"][mask])) + float(np.sum(a["tries"][mask])) * n_burn \
        + (float(st.paths) * n_burn if stationary else 0.0)
    info: dict[str, Any] = {
        "solver": "montecarlo", "method": "first_passage", "threshold": float(threshold),
        "energy_threshold": Ec, "start": start if stationary else float(start),
        "paths": int(st.paths), "blocks": int(st.blocks), "horizon": float(st.horizon),
        "dt": h, "seed": {"root": int(st.seed), "scheme": "path p of block b: words 4p..4p+3 "
                          "of numpy.random.SeedSequence(root, spawn_key=(b,)).generate_state"},
        "censored": int(censored.sum()), "threads": threads,
        "seconds": {"compile": compile_s, "run": run_s, "total": compile_s + run_s},
        "steps": path_steps,
        "steps_per_second": path_steps / run_s if run_s > 0 else math.nan,
        "effects": effects(system, noise),
        "crossing": _crossing_words(bridge and B[0] is not None,
                                    bridge and (B[1] is not None or B[2] is not None)),
        "start_law": _start_words(stationary, a_burn, n_burn * h, st.max_restarts),
        "status": (Status.CENSORED.record(f"{int(censored.sum())} of {censored.size} paths")
                   if censored.any() else Status.SIMULATED.record()),
    }
    if stationary:
        info["stationary"] = {"burn_in": n_burn * h, "burn_start": a_burn,
                              "restarts": int(np.sum(a["tries"][mask])),
                              "max_restarts": int(st.max_restarts),
                              "burn_in_mode": "auto" if relax is not None else "fixed"}
        if relax is not None:
            info["stationary"]["relaxation"] = relax
    data = {"fpt": {"time": tm.astype(np.float64), "censored": censored},
            "start": {"x": s[:, 0], "v": s[:, 1], "xi": s[:, 2], "A": amp}}
    return Result(data=data, info=info)


def _resolved(a: dict[str, np.ndarray], n_max: int, n_burn: int) -> float:
    """Path-steps resolved so far (a finished path counts in full): the progress bar."""
    ph, n = a["phase"], a["steps"]
    full = float(n_max + n_burn)
    return float(np.sum(np.where(ph >= CROSSED, full, np.where(ph == RUN, n_burn + n, n))))


def _amplitudes(x: np.ndarray, v: np.ndarray, phys: dict[str, Any]) -> np.ndarray:
    out = np.empty(x.size)
    amplitudes(np.ascontiguousarray(x), np.ascontiguousarray(v), phys["w0sq"], phys["alpha"],
               phys["khi"], out)
    return out


def _crossing_words(additive: bool, parametric: bool) -> dict[str, Any]:
    """The crossing test's description: linear interpolation alone (E is C^1: OU noise, no
    parametric noise), or with the bridge test and the terms of sigma_H^2 it uses."""
    out = {"method": "linear interpolation of E = v^2/2 + U(x) between the step ends",
           "order": CROSSING_ORDER,
           "note": "O(dt^2) on the smooth sub-system with OU noise (E is C^1); the scheme is "
                   "first order across impacts and stick-slip"}
    if additive or parametric:
        terms = " + ".join(t for t, on in (("2 D f^2", additive),
                                           ("2 D_k g(x)^2 + 2 D_c d(x)^2 v^2", parametric))
                           if on)
        out.update(method="linear interpolation, plus the Brownian-bridge crossing "
                          "probability exp(-2 (Ec - E_n)(Ec - E_n+1) / (sigma_H^2 dt)) for "
                          f"steps that end below Ec, sigma_H^2 = v^2 ({terms})",
                   order=1, note=("white external noise" if additive else "parametric noise")
                   + ": the bridge removes the O(dt^1/2) bias of discrete monitoring, "
                     "leaving O(dt) (Gobet 2000)")
    return out


def _start_words(stationary: bool, a_burn: float, burn_in: float, max_restarts: int) -> str:
    if not stationary:
        return ("energy U(A0), phase uniform in time along the conservative orbit (folded onto "
                "x >= 0 with the barrier), noise state from its stationary law")
    return (f"stationary law restricted to A < Ac by rejection: each path starts at amplitude "
            f"{a_burn:g} (phase uniform in time), runs a burn-in of {burn_in:g} time units "
            "of the free system and is accepted if then A < Ac, else starts again (at most "
            f"{max_restarts} times); the clock starts at the accepted state")
