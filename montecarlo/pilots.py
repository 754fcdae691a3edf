"""The pilots of a stationary run and the starts of its paths: ``starts`` (each path on the
conservative orbit of its amplitude at a uniform random phase), the *scale pilot* (the largest
amplitude the paths reach: the histogram ranges and the top of the over-dispersed starts) and
the *relaxation pilot* (pairs started low and high with common random numbers: the relaxation
time an "auto" burn-in is made of, tuning.fit_relaxation). Their sizes are plan.py's."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from vifpk.montecarlo import kernels as K
from vifpk.montecarlo.failures import diverged
from vifpk.montecarlo.plan import (
    RELAX_MAX_TIME,
    RELAX_PAIRS,
    RELAX_SEGMENT,
    RELAX_WINDOW,
    SCALE_BLOCKS,
    SCALE_BURN_IN,
    SCALE_PATHS,
    SCALE_PER_BLOCK,
    SCALE_SAMPLE_EVERY,
    SCALE_SAMPLES,
    bounds,
    fold,
    noise_start,
)
from vifpk.montecarlo.rng import block_seeds
from vifpk.montecarlo.stepper import DUMMY_EDGES, Stepper, arrays
from vifpk.montecarlo.tuning import fit_relaxation

from vifpk.core.defaults import BURN_FACTOR
from vifpk.physics import spring

START_LOW = 0.05  # lowest start amplitude, as a fraction of the pilot's largest


def potential(x: Any, phys: dict[str, Any]) -> Any:
    """U(x) of the kernel's spring on arrays (vifpk.physics.spring.potential_parts)."""
    return spring.potential_parts(x, phys["w0sq"], phys["alpha"], phys["khi"])


def starts(amplitudes: np.ndarray, phys: dict[str, Any], gen: np.random.Generator
           ) -> np.ndarray:
    """(x, v, xi) on the conservative orbit of each amplitude, at a uniform random phase;
    xi from the stationary OU law."""
    def U(x: np.ndarray) -> np.ndarray:
        return potential(x, phys)

    th = gen.uniform(0.0, 2 * math.pi, amplitudes.shape)
    x = amplitudes * np.cos(th)
    v = -np.sign(np.sin(th)) * np.sqrt(np.maximum(2 * (U(amplitudes) - U(x)), 0.0))
    if fold(phys):
        x = np.abs(x)
    x = np.clip(x, *bounds(phys))  # other walls: a pilot's start inside them (burnt in)
    xi = noise_start(phys, gen, x.shape)  # the kind's stationary law; None: no state
    if xi is None:
        xi = np.zeros_like(x)
    return np.stack([x, v, xi], axis=-1)


def pilot_scale(phys: dict[str, Any], h: float, seed: int, step: Stepper,
                a_hint: float, path_max: list[float] | None = None) -> float:
    """The largest amplitude seen by the scale pilot (plan.py: 32 paths from small starts over
    200 + 1000 time units), times 1.25 (the histogram ranges and the top of the over-dispersed
    starts). ``path_max``, if given, receives each pilot path's largest amplitude."""
    gen = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1 << 20,)))
    amps = np.full((SCALE_BLOCKS, SCALE_PER_BLOCK), 0.1 * a_hint)
    # the paths of SCALE_BLOCKS blocks (their streams and starts) run as ONE block of
    # SCALE_PATHS lanes: a path's steps do not depend on its block, group or lane (lanes.py),
    # so every path maximum is the same bit for bit, and a full lane group costs a third of
    # the CPU of eight groups of SCALE_PER_BLOCK lanes (issue 44: 0.133 -> 0.040 s, paper-base)
    rng = block_seeds(seed, SCALE_BLOCKS, SCALE_PER_BLOCK, key=1 << 21)
    arr = arrays(rng.reshape(1, SCALE_PATHS, -1),
                 starts(amps, phys, gen).reshape(1, SCALE_PATHS, -1), DUMMY_EDGES,
                 ("moments",))
    n_burn = int(round(SCALE_BURN_IN / h))
    stride = max(int(round(SCALE_SAMPLE_EVERY / h)), 1)
    step.run(arr, n_burn + SCALE_SAMPLES * stride, 0, n_burn, stride)
    if path_max is not None:
        path_max.extend(float(a) for a in arr.moments[..., K.MO_MAXA].ravel())
    amax = 1.25 * float(np.max(arr.moments[..., K.MO_MAXA]))
    if not math.isfinite(amax):
        raise diverged(h, "non-finite amplitude in the pilot run", step.cause)
    return amax if amax > 0 else a_hint


def relaxation(phys: dict[str, Any], h: float, seed: int, step: Stepper, a_hi: float,
               sample_every: float, pairs: int = RELAX_PAIRS,
               max_time: float = RELAX_MAX_TIME) -> dict[str, Any]:
    """tau from pairs started low and high with common random numbers (tuning.py); the
    pilot's sizes are plan.py's."""
    gen = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1 << 22,)))
    amps = np.empty((2, pairs))
    amps[0], amps[1] = START_LOW * a_hi, a_hi
    state = starts(amps, phys, gen)
    state[1, :, 2] = state[0, :, 2]  # the same noise state in both members of a pair
    rng = block_seeds(seed, 1, pairs, key=1 << 23)
    rng = np.concatenate([rng, rng.copy()])
    arr = arrays(rng, state, DUMMY_EDGES, ())
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

