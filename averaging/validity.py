"""How far a scene is from the limits the averaged models are derived in, over the bulk of p(E).

Each number is evaluated at the 10%, 50% and 90% quantiles of the amplitude density of the
first-order model (``exact``), i.e. at the energies the answer is made of, not at one
amplitude (docs/report.md, "Warnings", gives the curves behind the thresholds that use them):

    band      rate / Omega(E)              noise bandwidth against the oscillation frequency
                                           Omega = 2 pi / T(E), rate the kind's declared
                                           correlation rate (OU: alpha1; bounded: sigma^2 / 2,
                                           the decay rate of its covariance's envelope; None
                                           for a kind without one: white noise)
    wall      delta(E) / E                 the energy-at-the-wall offset of ``corrected``
                                           against the energy (its linear response needs << 1)
    noise     sigma_E^2 T / E^2            relative energy variance the noise adds per period
    correlation  sigma_E^2 / (rate E^2)    ... per correlation time 1/rate of the noise: the
                                           small parameter of the O(D / alpha1) terms (the wall
                                           offset, the fast fluctuation) (kinds with a rate)
    lambda    -ln r^2                      the jump of ln E at an impact (0 without a wall;
                                           with walls other than the paper's, the largest
                                           -ln r^2 of them: the jump of ln K, K the kinetic
                                           energy at the wall, below v_yield)

``wall`` is None where ``corrected`` does not apply (walls other than the paper's under OU
noise, or walls under a correlated kind other than OU: its offset is derived for the paper's
wall and the OU covariance only). The exact model behind every number takes any spectrum (the
general harmonic sum), so every registered kind with a spectral density is checkable.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .corrected import CorrectedModel
from .exact import ExactModel
from .stationary import amplitude_density

QUANTILES = (0.1, 0.5, 0.9)


def bulk_amplitudes(A: np.ndarray, p: np.ndarray) -> np.ndarray:
    """The amplitudes at QUANTILES of a density on a grid (trapezoid cdf)."""
    c = np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(A))])
    return np.interp(QUANTILES, c / c[-1], A)


def validity(scene: Any) -> dict[str, Any]:
    """{"quantiles", "amplitudes": [A10, A50, A90], "band": [...] or None, "wall": [...],
    "noise": [...], "correlation": [...] or None, "lambda": float}: the numbers of the module
    docstring at the quantiles, plain floats (JSON-ready)."""
    ex = ExactModel.from_scene(scene)
    amp = amplitude_density(ex, points=401, tail_mass=False)
    A = bulk_amplitudes(amp.A, amp.p)
    et = ex.energy_terms(A)
    T, E = et["T"], et["E"]
    corrected = CorrectedModel.applies(scene) is None
    cm = CorrectedModel.from_scene(scene) if corrected else None
    lam = (float(cm.lam) if cm is not None and cm.barrier
           else max((-2.0 * float(np.log(w.r)) for w in ex.walls), default=0.0))
    out: dict[str, Any] = {"quantiles": list(QUANTILES), "amplitudes": A.tolist(),
                           "lambda": lam + 0.0}  # no -0.0 for r = 1
    rate = ex.spectrum.correlation_rate()  # None: a noise without correlation time
    out["band"] = (rate * T / (2 * np.pi)).tolist() if rate is not None else None
    out["wall"] = (cm.wall_offset(A) / E).tolist() if cm is not None else None
    out["noise"] = (et["sigma2"] * T / E**2).tolist()
    out["correlation"] = ((et["sigma2"] / (rate * E**2)).tolist()
                          if rate is not None else None)
    return out
