"""Defaults from the physics: the burn-in from a measured relaxation time, dt from a target.

**Relaxation time (for ``burn_in = "auto"``).** A pilot runs pairs of paths, one started near
rest and one at the largest amplitude a first pilot saw, each pair driven by the *same*
random numbers (common random numbers: the difference of the pair carries no noise of its
own at the start). The mean difference d(t) of their amplitudes over the pairs decays with the
slowest relaxation of the amplitude; tau is the negative inverse slope of log d(t), fitted
over the windows where d is above 3 standard errors, after d has fallen by e (so that faster
modes are gone). The Monte Carlo measures this itself, so the ground truth does not lean on
the averaged models whose error it judges. The burn-in is ``BURN_FACTOR`` = 6 tau: the start
leaves e^-6 = 2.5e-3 of its offset at the first sample, and tau / time of that in the time
averages. The certificate (certificate.py) still checks the result.

**Time step (for ``dt = "auto"``).** The weak bias of p(A) in L1 was fitted on the paper's
base scene family (OU noise, restitution near 1, light friction; docs/performance.md,
1024 paths x 2000 time units on a dt ladder): L1 bias = C dt^p with C = 0.173, p = 1.11.
``auto_dt(F)`` is the largest dt whose predicted bias is ``BIAS_FRACTION`` = 1/2 of the target
floor F (combined error sqrt(1 + 1/4) F = 1.12 F), clipped to [0.0025, 0.04] and to 1/100 of
the small-amplitude period 2 pi / omega0 (the OU update is exact for any dt, so the noise's
correlation time sets no limit). Other scene families may have other constants: there the
floor is still honest, the bias may not be, so compare with a run at dt / 2 when it matters.

Re-measured 2026-11-23 (the work-precision ladder, docs/performance.md): the bias is below the
noise floor (about 0.01) at every dt <= 0.08, and a fit through the two larger steps gives
0.653 dt^1.94, whose order that ladder does not pin down. Below the measured steps the two fits
differ by 7x (at dt = 0.02: 0.0023 here, 0.00033 from the new fit). The constants here are
kept: they are the larger prediction there, and their order 1.11 matches the kernel's declared
weak order 1 across impacts (kernels.WEAK_ORDER_NONSMOOTH, measured in the tests), while 1.94
would be the smooth sub-system's. The rate of the kernel is not a constant: simulate._Stepper
measures it on every call.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from vifpk.core.defaults import BURN_FACTOR  # noqa: F401  (re-exported; its one home)

BIAS_C, BIAS_P = 0.173, 1.11
BIAS_FRACTION = 0.5
DT_RANGE = (0.0025, 0.04)
DEFAULT_FLOOR = 0.01  # the floor dt "auto" aims at when no target is given


def auto_dt(target_floor: float | None, phys: dict[str, Any]) -> float:
    """Largest dt with predicted bias C dt^p <= BIAS_FRACTION x target (see module)."""
    F = target_floor if target_floor and target_floor > 0 else DEFAULT_FLOOR
    dt = (BIAS_FRACTION * F / BIAS_C) ** (1.0 / BIAS_P)
    # no linear spring (k1 = 0): no small-amplitude period to resolve, only DT_RANGE
    period = 2 * math.pi / math.sqrt(phys["w0sq"]) if phys["w0sq"] > 0 else math.inf
    dt = min(dt, period / 100.0, DT_RANGE[1])
    return float(max(dt, DT_RANGE[0]))


def fit_relaxation(t: np.ndarray, d: np.ndarray, se: np.ndarray) -> dict[str, Any]:
    """tau from the decay of d(t) (see module); returns tau and how it was found."""
    sig = d > 3 * se
    if not sig.any():
        return {"tau": float(t[0]), "method": "no significant offset at the first window"}
    d0 = d[0]
    below = np.nonzero(~sig)[0]
    last = int(below[0]) if below.size else t.size  # first window lost in the noise
    after = np.nonzero(d[:last] < d0 / math.e)[0]
    lo = int(after[0]) if after.size else 0
    idx = np.arange(lo, last)
    if idx.size >= 3:
        slope = np.polyfit(t[idx], np.log(d[idx]), 1)[0]
        if slope < 0:
            return {"tau": float(-1.0 / slope), "method": "fit of log d(t)",
                    "fit_windows": int(idx.size)}
    t_end = t[last - 1] if last > 0 else t[0]
    ratio = d0 / max(3 * float(se[last - 1]) if last > 0 else d0, 1e-300)
    tau = float(t_end / max(math.log(max(ratio, math.e)), 1.0))
    return {"tau": tau, "method": "time to reach the noise / log(offset / noise)"}
