"""The tolerance verdict: is a model's averaging error within the user's tolerance, and how
sure is the answer (issue 29; derivation and measurements in docs/report.md, "Tolerance
verdict").

**Debiasing.** A Monte Carlo histogram has bin densities q_i = t_i + e_i, t the true density
and e_i ~ N(0, s_i^2) (s_i the batch standard error); the model's bin averages are p_i. The
true error is L = sum_i |d_i| w_i with d = p - t; the measured one L1 = sum_i |d_i - e_i| w_i.
Per bin E|d - e| is the folded-normal mean

    mu(d, s) = s sqrt(2/pi) exp(-d^2 / 2 s^2) + d erf(d / (s sqrt 2)),

s sqrt(2/pi) at d = 0 and |d| for |d| >> s, so L1 is biased up by up to the noise floor
F = sum_i sqrt(2/pi) s_i w_i (its value when L = 0). mu^2 ~ d^2 + (2/pi) s^2 (exact at both
ends), and summed over the bins Minkowski's inequality gives E L1 ~ sum_i w_i sqrt(d_i^2 +
(2/pi) s_i^2) >= sqrt(L^2 + F^2), with equality when |d_i| / s_i is the same in every bin.
The estimate inverts that equality:

    L_hat = sqrt(max(L1^2 - F^2, 0)).

Its residual bias, measured on synthetic histograms with a known truth (three error shapes:
a shift, a change of width, a wiggle; L from 0 to 4 F; tests/test_tolerance.py): below
+0.25 F at L = 0 (the max(., 0) keeps the noise's upward half), between -0.11 F (the change
of width, at L = F) and +0.02 F from L = F on, less than the estimate's own standard error
there (0.16 F); the raw L1 is 0.4 F high at L = F.

**Interval and probability.** With sigma the error bar of L1 (compare.py: the jackknife over
the Monte Carlo's blocks, which covers the seed-to-seed spread) and z the two-sided normal
quantile of the confidence c, the interval maps L1 -/+ z sigma through the same (monotone)
function; P(L <= tol) = Phi((sqrt(tol^2 + F^2) - L1) / sigma), the probability that the
measured L1's expectation is below the one a model exactly at the tolerance would give. The
class is ``inside`` when P >= c, ``outside`` when P <= 1 - c, else ``undecided`` (a longer run,
a smaller floor, decides it). For KS, W1 and Hellinger the same rule is applied with their
own floors (derived for L1; tested there).

``within_noise`` (L1 < 2 F) stays what it was: a statement about the sample size.
"""

from __future__ import annotations

import math
from statistics import NormalDist
from typing import Any

from vifpk.harness.request.tolerance import Tolerance

CLASSES = ("inside", "outside", "undecided")


def debias(value: float, floor: float) -> float:
    """sqrt(max(value^2 - floor^2, 0)): the measured distance with the noise's part removed
    (module docstring)."""
    return math.sqrt(max(value * value - floor * floor, 0.0))


def tolerance_verdict(e: dict[str, Any], tol: Tolerance) -> dict[str, Any]:
    """The verdict on one comparison record ``e`` (compare.compare of the observable): the
    estimate of the true error, its error and interval, P(error <= tolerance), the class."""
    k = tol.metric
    value = float(e[k])
    floor = float(e.get(f"{k}_floor", 0.0))
    sigma = float(e.get(f"{k}_err", 0.0))
    z = NormalDist().inv_cdf(0.5 + tol.confidence / 2)
    est = debias(value, floor)
    lo, hi = debias(max(value - z * sigma, 0.0), floor), debias(value + z * sigma, floor)
    # the class is one-sided (P(error <= T) against the confidence): its bounds are too
    z1 = NormalDist().inv_cdf(tol.confidence)
    bounds = [debias(max(value - z1 * sigma, 0.0), floor), debias(value + z1 * sigma, floor)]
    at_tol = math.hypot(tol.value, floor)  # the expected measured value of an error = tol
    if sigma > 0:
        p = NormalDist().cdf((at_tol - value) / sigma)
    else:
        p = 1.0 if value <= at_tol else 0.0
    cls = ("inside" if p >= tol.confidence else
           "outside" if p <= 1 - tol.confidence else "undecided")
    return {**tol.record(), "tolerance": tol.value, "measured": value, "floor": floor,
            "error_estimate": est, "error_estimate_err": (hi - lo) / (2 * z),
            "error_estimate_ci": [lo, hi], "error_estimate_bounds": bounds,
            "p_within_tolerance": p, "class": cls,
            "within_noise": bool(value < 2 * floor)}


def model_verdicts(metrics: dict[str, Any], tol: Tolerance) -> dict[str, dict[str, Any]]:
    """{model: verdict} for every model whose averaging error has the asked observable."""
    out = {}
    for m, entry in metrics["models"].items():
        e = entry.get("averaging_error", {}).get(tol.observable)
        if e is not None and tol.metric in e:
            out[m] = tolerance_verdict(e, tol)
    return out


def line(model: str, v: dict[str, Any]) -> str:
    """One line: the model's estimated error, the one-sided bounds its class is decided by
    (error above ``lo`` and below ``hi``, each at the confidence), probability and class."""
    lo, hi = v.get("error_estimate_bounds", v["error_estimate_ci"])
    return (f"{model} model: {v['metric']}({v['observable']}) error estimate "
            f"{v['error_estimate']:.4f} (noise removed; at {100 * v['confidence']:g}% "
            f"confidence above {lo:.4f} and below {hi:.4f}), P(error <= {v['tolerance']:g}) = "
            f"{v['p_within_tolerance']:.2f}: {v['class'].upper()} the tolerance")
