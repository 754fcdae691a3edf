"""The statistics of a stationary run's blocks: densities per unit length with their standard
errors and L1 noise floor (block means: paths in different blocks are independent, samples
along one path are not), and the means with standard errors of the events, moments and power
balance that info carries."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from vifpk.montecarlo import kernels as K
from vifpk.montecarlo.plan import noise_piece
from vifpk.montecarlo.stepper import Arrays


def density(counts: np.ndarray, samples: np.ndarray, widths: np.ndarray) -> dict[str, Any]:
    """Block-mean density per unit length, its standard error, the L1 noise floor and the
    blocks' own densities (``blocks``: the batch means, whose spread a metric's error bar reads,
    harness/workflows/compare.py)."""
    per_block = counts / (samples.reshape((-1,) + (1,) * (counts.ndim - 1)) * widths)
    mean = per_block.mean(axis=0)
    se = per_block.std(axis=0, ddof=1) / math.sqrt(counts.shape[0])
    floor = float(np.sum(math.sqrt(2.0 / math.pi) * se * widths))
    return {"p": mean, "err": se, "L1_floor": floor, "blocks": per_block}


def floor_A(arr: Arrays) -> float:
    """The L1 noise floor of p(A) so far (the stop test of a run to a target floor)."""
    e = arr.hist["edges_A"]
    return density(arr.hist["A"], np.maximum(arr.events[:, K.EV_SAMPLES], 1.0),
                   np.diff(e))["L1_floor"]


def mean_se(per_block: np.ndarray) -> dict[str, float]:
    """The mean of the blocks' values and its standard error."""
    return {"value": float(per_block.mean()),
            "err": float(per_block.std(ddof=1) / math.sqrt(per_block.size))}


def events_summary(events: np.ndarray, sim_time: np.ndarray, samples: np.ndarray, h: float
                   ) -> dict[str, Any]:
    """Impacts, sticking and chatter per unit time, and the fractions of samples outside the
    histograms' ranges."""
    out = {
        "impacts_per_time": mean_se(events[:, K.EV_IMPACTS] / sim_time),
        "stuck_fraction": mean_se(events[:, K.EV_STUCK] / sim_time),
        "chatter_entries_per_time": mean_se(events[:, K.EV_CHATTER] / sim_time),
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


def energy_summary(en: np.ndarray, sim_time: np.ndarray, phys: dict[str, Any]
                   ) -> dict[str, Any]:
    """Stationary power balance, per unit time with block errors: input = damping + friction
    + impacts. ``residual`` = input - losses block by block (its error bar is the test)."""
    rate = en / sim_time[:, None]
    losses = rate[:, K.EN_DAMP] + rate[:, K.EN_FRICTION] + rate[:, K.EN_IMPACT]
    out = {"input": mean_se(rate[:, K.EN_INPUT]), "damping": mean_se(rate[:, K.EN_DAMP]),
           "friction": mean_se(rate[:, K.EN_FRICTION]),
           "impacts": mean_se(rate[:, K.EN_IMPACT]), "losses": mean_se(losses),
           "residual": mean_se(rate[:, K.EN_INPUT] - losses)}
    exact = noise_piece(phys, "input_power")  # white noise: f^2 D (Ito); else None
    if exact is not None:
        out["input_exact"] = exact
    return out


def moments_summary(mom: np.ndarray, samples: np.ndarray) -> dict[str, Any]:
    """First and second moments of A, x1, x2 per sample with block errors, and their maxima."""
    s = samples
    out = {}
    for name, c1, c2 in (("A", K.MO_A, K.MO_A2), ("x1", K.MO_X, K.MO_X2), ("x2", K.MO_V, K.MO_V2)):
        out[name] = {"mean": mean_se(mom[:, c1] / s), "second": mean_se(mom[:, c2] / s)}
    out["max"] = {"A": float(mom[:, K.MO_MAXA].max()), "x1": float(mom[:, K.MO_MAXX].max()),
                  "x2": float(mom[:, K.MO_MAXV].max())}
    return out

