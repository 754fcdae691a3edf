"""The Monte Carlo's sampling plan, before any simulation: numbers only, no numba.

``simulate`` runs this plan and ``harness.request.validate`` checks and prices it, so both read the
same arithmetic: the time step (``dt`` or the "auto" one, tuning.py), the sampling stride, the
windows the certificate needs, the pilot runs' sizes, the nearest times that are sampled exactly
and a lower bound of the path-steps a run takes.

The pilots (simulate.py): the *scale pilot* runs SCALE_PATHS paths (SCALE_BLOCKS blocks of
SCALE_PER_BLOCK) from small starts for SCALE_BURN_IN time units and then SCALE_SAMPLES samples
SCALE_SAMPLE_EVERY apart; with ``burn_in = "auto"`` the *relaxation pilot* runs RELAX_PAIRS
pairs of paths (2 x RELAX_PAIRS paths) in windows of about RELAX_WINDOW time units, in segments
of RELAX_SEGMENT time units (so at least one segment, 20 windows), up to RELAX_MAX_TIME; the
burn-in is then max(BURN_FACTOR tau, MIN_AUTO_BURN_IN).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from vifpk.core.walls import Wall
from vifpk.physics import impact
from vifpk.physics import noise as noise_kinds

from .tuning import auto_dt

SOLVER = "montecarlo"  # the solver's name in vifpk.physics' registries

WINDOWS = 16  # at least 16 sampled windows (the certificate's draws along each path)
SCALE_BLOCKS, SCALE_PER_BLOCK = 8, 4
SCALE_PATHS = SCALE_BLOCKS * SCALE_PER_BLOCK
SCALE_BURN_IN = 200.0
SCALE_SAMPLES = 2000
SCALE_SAMPLE_EVERY = 0.5
RELAX_PAIRS = 128
RELAX_WINDOW = 10.0
RELAX_SEGMENT = 200.0
RELAX_MAX_TIME = 20000.0
MIN_AUTO_BURN_IN = 20.0


def _laws(system: Any) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...]]:
    """(k, d, e): the spring (k1, k3, ...), damping (d0, d2, ...) and velocity damping
    (e2, ...) coefficients, trailing zeros dropped, k and d padded to two terms. A system
    with the paper's names only (omega0, alpha, c1, c2) gives k = (omega0^2, alpha),
    d = (-c1, c2)."""
    if hasattr(system, "restoring_law"):
        k, d = tuple(system.restoring_law), tuple(system.damping_law)
        e = tuple(system.velocity_law)
    else:
        k = (float(system.omega0) ** 2, float(system.alpha))
        d, e = (-float(system.c1), float(system.c2)), ()

    def trim(c: tuple[float, ...], keep: int) -> tuple[float, ...]:
        c = tuple(float(v) for v in c)
        while len(c) > keep and c[-1] == 0.0:
            c = c[:-1]
        return c + (0.0,) * (keep - len(c))

    return trim(k, 2), trim(d, 2), trim(e, 0)


def physics(system: Any, noise: Any, parametric: Any = None) -> dict[str, Any]:
    """The physics of (duck-typed) scene.system, scene.noise and scene.parametric (None: off),
    on the Python side; a switched-off effect is None (a parametric intensity 0 too).
    ``pieces.record(phys, h)`` makes the kernels' record of it. An unknown noise kind, or one
    without Monte Carlo pieces (vifpk.physics.noise), raises in one line."""
    noise_kinds.pieces(noise.kind, SOLVER)  # NoPiece: one line naming kind and solver
    for w in walls(system):
        if w is not None:
            impact.law(w.law, solver=SOLVER)  # NoLaw: one line naming law and solver
    k, d, e = _laws(system)
    return {
        "c1": -d[0], "c2": d[1], "w0sq": k[0], "alpha": k[1],
        "khi": np.array(k[2:]) if len(k) > 2 else None,
        "dhi": np.array(d[2:]) if len(d) > 2 else None,
        "ev": np.array(e) if e else None,
        "f": float(system.f),
        "mu": float(system.mu) if system.mu > 0 else None,
        **dict(zip(("lower", "upper"), walls(system), strict=True)),
        "noise": noise,
        # Stratonovich parametric white noises: D_k on the spring, D_c on the damping
        "D_k": float(parametric.stiffness) or None if parametric is not None else None,
        "D_c": float(parametric.damping) or None if parametric is not None else None,
    }


def walls(system: Any) -> tuple[Wall | None, Wall | None]:
    """(lower, upper) walls of (duck-typed) scene.system: its ``walls`` (vifpk.core.walls.Wall,
    lower first), or for a system without them the old spelling: a lower wall at 0 with
    Newton's law and restitution ``r`` when ``barrier`` (default true)."""
    ws = getattr(system, "walls", None)
    if ws is None:
        ws = (Wall(side="lower", at=0.0, params=(("r", float(system.r)),)),) \
            if getattr(system, "barrier", True) else ()
    out: dict[str, Wall | None] = {"lower": None, "upper": None}
    for w in ws:
        out[w.side] = w
    return out["lower"], out["upper"]


def bounds(phys: dict[str, Any]) -> tuple[float, float]:
    """[a, b]: where the walls keep x (-inf, inf without)."""
    lo, up = phys["lower"], phys["upper"]
    return (float(lo.at) if lo is not None else -math.inf,
            float(up.at) if up is not None else math.inf)


def fold(phys: dict[str, Any]) -> bool:
    """Orbit starts fold y -> |y| (exact when one wall keeps x >= 0: the elastic impacting
    orbit is the fold of the free one); otherwise they reject points outside the walls."""
    return phys["lower"] is not None and phys["lower"].at == 0.0 and phys["upper"] is None


def noise_piece(phys: dict[str, Any], name: str) -> Any:
    """The scene's noise kind's Monte Carlo piece ``name`` (vifpk.core.protocols.
    MonteCarloNoise: "start_sd", "bridge", "input_power") applied to the kind's parameter
    values (and the gain f, where it takes it: all but start_sd)."""
    fn = getattr(noise_kinds.pieces(phys["noise"].kind, SOLVER), name)
    values = phys["noise"].values
    return fn(values) if name == "start_sd" else fn(values, phys["f"])


def noise_start(phys: dict[str, Any], gen: Any, shape: Any) -> Any:
    """``shape`` draws of the noise state from its stationary law with the numpy Generator
    ``gen`` (the kind's ``start``), or None for a kind without state (xi = 0)."""
    mc = noise_kinds.pieces(phys["noise"].kind, SOLVER)
    return mc.start(phys["noise"].values, phys["f"], gen, shape)


def step_size(dt: float | str, target: float, phys: dict[str, Any], sample_every: float,
              amplitude: float | None = None) -> float:
    """The time step: ``dt``, or for "auto" the largest whole fraction sample_every / k of
    sample_every not above tuning.auto_dt (so that samples fall on steps exactly);
    ``amplitude`` the scale pilot's (tuning.auto_dt; without it: the provisional step)."""
    if dt != "auto":
        return float(dt)
    h = auto_dt(target, phys, amplitude)
    return sample_every / math.ceil(sample_every / h * (1 - 1e-12))


def sampling_plan(time_: float, sample_every: float, h: float, target: float
                  ) -> tuple[int, int, int]:
    """(steps between samples, samples per window, windows) of a run.

    The n = time_ / (stride h) samples of each path are cut into the fewest windows from
    WINDOWS to 2 WINDOWS that divide n exactly (n windows of one sample below WINDOWS), so
    the sampled time is exactly ``time_`` whenever n is whole and has such a divisor (every
    multiple of 16 to 32 samples; harness.request.validate refuses the others, naming the nearest).
    Failing that, WINDOWS windows of n // WINDOWS samples, and what is left is not sampled.
    With a target floor the run starts with WINDOWS // 2 windows of n // WINDOWS samples."""
    stride = max(int(round(sample_every / h)), 1)
    n = max(int(time_ / (stride * h) * (1 + 1e-12)), 1)
    if target > 0:
        return stride, max(n // WINDOWS, 1), WINDOWS // 2
    if n < WINDOWS:
        return stride, 1, n
    for n_win in range(WINDOWS, 2 * WINDOWS + 1):
        if n % n_win == 0:
            return stride, n // n_win, n_win
    spw = n // WINDOWS
    return stride, spw, n // spw


def pilot_path_time(burn_in_auto: bool) -> float:
    """Simulated path-time of the pilots, at least: the scale pilot's, plus the relaxation
    pilot's first segment when the burn-in is "auto"."""
    scale = SCALE_PATHS * (SCALE_BURN_IN + SCALE_SAMPLES * SCALE_SAMPLE_EVERY)
    return scale + (2 * RELAX_PAIRS * RELAX_SEGMENT if burn_in_auto else 0.0)


@dataclass(frozen=True)
class Plan:
    """What a Monte Carlo run of the original system will do, known before it runs."""

    dt: float  # the time step
    stride: int  # steps between samples
    samples_per_window: int
    windows: int
    sample_interval: float  # stride x dt
    sampled_time: float  # per path, after the burn-in (with a target floor: the first stage)
    nearest_times: tuple[float, ...]  # the times nearest ``time`` that are sampled exactly
    burn_in: float  # the burn-in time, at least (MIN_AUTO_BURN_IN for "auto")
    pilot_path_time: float  # simulated path-time of the pilots, at least
    path_steps: float  # a lower bound of the path-steps of the run, pilots included


def plan(system: Any, noise: Any, mc: Any) -> Plan:
    """The plan of a run with settings ``mc`` (duck-typed scene.montecarlo: dt, time,
    sample_every, floor, burn_in, paths). With a target floor the run may stop anywhere from
    half of ``time``, so ``path_steps`` counts half of it; a burn-in "auto" counts at its
    minimum, MIN_AUTO_BURN_IN."""
    target = float(mc.floor) if mc.floor else 0.0
    h = step_size(mc.dt, target, physics(system, noise), mc.sample_every)  # (no parametric)
    stride, spw, n_win = sampling_plan(mc.time, mc.sample_every, h, target)
    interval = stride * h

    def sampled(n: int) -> float:
        s, w, k = sampling_plan(n * interval, mc.sample_every, h, 0.0)
        return k * w * s * h

    n = max(int(mc.time / interval), 1)
    exact = sorted({m for m in range(max(n - 40, 1), n + 42) if
                    abs(sampled(m) - m * interval) <= 1e-9 * m * interval}
                   | {WINDOWS * (n // WINDOWS + 1)}
                   | ({WINDOWS * (n // WINDOWS)} if n >= WINDOWS else set()))
    below = [m for m in exact if m * interval <= mc.time]
    above = [m for m in exact if m * interval > mc.time]
    sampled_time = n_win * spw * interval
    auto = mc.burn_in == "auto"
    burn = MIN_AUTO_BURN_IN if auto else float(mc.burn_in)
    run_time = mc.time / 2 if target > 0 else sampled_time
    pilots = pilot_path_time(auto)
    steps = (mc.paths * (burn + run_time) + pilots) / h
    return Plan(dt=h, stride=stride, samples_per_window=spw, windows=n_win,
                sample_interval=interval, sampled_time=sampled_time,
                nearest_times=tuple(m * interval for m in (below[-1:] + above[:1])),
                burn_in=burn, pilot_path_time=pilots, path_steps=steps)
