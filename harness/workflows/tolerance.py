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

**Degrees of freedom.** The jackknife variance over n blocks has about n - 1 degrees of
freedom (Efron & Tibshirani, *An Introduction to the Bootstrap*, 1993, ch. 11): with ``dof``
the quantiles z and z1 and the probability are Student's t with n - 1 degrees instead of the
normal's (with the default 32 blocks: 2.04 instead of 1.96 at 95%, an interval 4% wider).

**A detected step bias** (issue 39). The Monte Carlo's histogram of p(A) is q = t + beta +
noise, beta the bias of the time step, ||beta||_1 = b. Every metric here is a distance, so
by the triangle inequality the true error L = d(p, t) lies within d(p, t + beta) -/+ d(t, t +
beta): L1 within +/- b; KS within +/- b / 2 (a CDF moves by at most the total variation
b / 2); Hellinger within +/- sqrt(b / 2) (H^2 <= total variation). When the run's step check
(montecarlo/tuning.py, ``step_check``) cannot rule a bias out (verdict "failed" or
"undecided"), its bound at the kernel's lowest declared weak order (``bias_range``'s upper
end: order 1 across impacts and stick-slip, the most the declared orders allow) is carried:
the interval widens by it on each side, the class is ``inside`` only if the error is within
``tolerance - bound`` at the confidence, ``outside`` only if it is beyond ``tolerance +
bound``, and ``p_within_tolerance_range`` gives P at both ends. The check is made on p(A)
(on merged bins: a smooth bias barely changes on the report's bins); for x1, x2 and W1 the
bias is not bounded and the record says so (``step_bias.note``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from statistics import NormalDist
from typing import Any

from vifpk.harness.request.tolerance import Tolerance

CLASSES = ("inside", "outside", "undecided")


def debias(value: float, floor: float) -> float:
    """sqrt(max(value^2 - floor^2, 0)): the measured distance with the noise's part removed
    (module docstring)."""
    return math.sqrt(max(value * value - floor * floor, 0.0))


def step_bias(dt_check: Mapping[str, Any] | None, tol: Tolerance) -> dict[str, Any] | None:
    """The step bias the tolerance verdict carries (module docstring): None when the run's
    step check passed or was not made; else {"bound" (in the tolerance's metric, or None
    where it is not bounded), "L1_bound" (on p(A)), "verdict", "note"}."""
    if not dt_check or dt_check.get("verdict") not in ("failed", "undecided"):
        return None
    b = float(dt_check["bias_range"][1])
    out: dict[str, Any] = {"L1_bound": b, "verdict": dt_check["verdict"], "bound": None,
                           "note": ""}
    if tol.observable != "A":
        out["note"] = (f"the step check measures p(A) only; the bias of "
                       f"p({tol.observable}) is not bounded here")
    elif tol.metric == "w1":
        out["note"] = "the step bias is bounded in L1, KS and Hellinger, not in W1"
    else:
        out["bound"] = {"L1": b, "ks": b / 2, "hellinger": math.sqrt(b / 2)}[tol.metric]
        out["note"] = (f"the step check could not rule out a bias of p(A) up to {b:.2g} in "
                       f"L1 ({dt_check['verdict']}); the interval and the class carry it")
    return out


def _quantile(q: float, dof: int | None) -> float:
    """Student's t quantile (normal without ``dof``) for 0 < q < 1: scipy.special.stdtrit,
    which scipy.stats.t.ppf calls there (the same bits, without importing scipy.stats: 0.7-1.4
    s of the check's start, issue 44)."""
    if dof is None:
        return NormalDist().inv_cdf(q)
    from scipy.special import stdtrit

    return float(stdtrit(dof, q))


def _cdf(x: float, dof: int | None) -> float:
    """Student's t CDF (normal without ``dof``): scipy.special.stdtr, as scipy.stats.t.cdf."""
    if dof is None:
        return NormalDist().cdf(x)
    from scipy.special import stdtr

    return float(stdtr(dof, x))


def tolerance_verdict(e: dict[str, Any], tol: Tolerance, *, dof: int | None = None,
                      bias: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The verdict on one comparison record ``e`` (compare.compare of the observable): the
    estimate of the true error, its error and interval, P(error <= tolerance), the class.
    ``dof``: the error bar's degrees of freedom (blocks - 1; None: normal quantiles);
    ``bias``: a step bias to carry (:func:`step_bias`)."""
    k = tol.metric
    value = float(e[k])
    floor = float(e.get(f"{k}_floor", 0.0))
    sigma = float(e.get(f"{k}_err", 0.0))
    b = float(bias["bound"]) if bias and bias.get("bound") is not None else 0.0
    z = _quantile(0.5 + tol.confidence / 2, dof)
    est = debias(value, floor)
    lo, hi = debias(max(value - z * sigma, 0.0), floor), debias(value + z * sigma, floor)
    # the class is one-sided (P(error <= T) against the confidence): its bounds are too
    z1 = _quantile(tol.confidence, dof)
    bounds = [debias(max(value - z1 * sigma, 0.0), floor), debias(value + z1 * sigma, floor)]

    def p_below(t: float) -> float:  # P(error <= t): t's expected measured value, hypot(t, F)
        at_t = math.hypot(max(t, 0.0), floor)
        if sigma > 0:
            return _cdf((at_t - value) / sigma, dof)
        return 1.0 if value <= at_t else 0.0

    p = p_below(tol.value)
    p_lo, p_hi = p_below(tol.value - b), p_below(tol.value + b)
    cls = ("inside" if p_lo >= tol.confidence else
           "outside" if p_hi <= 1 - tol.confidence else "undecided")
    out = {**tol.record(), "tolerance": tol.value, "measured": value, "floor": floor,
           "error_estimate": est, "error_estimate_err": (hi - lo) / (2 * z),
           # the interval's half-width over z: a standard error of the estimate only where
           # the interval does not touch 0 (near the floor the estimate is clipped there)
           "error_estimate_err_is_se": bool(value - z * sigma > floor),
           "error_estimate_ci": [max(lo - b, 0.0), hi + b],
           "error_estimate_bounds": [max(bounds[0] - b, 0.0), bounds[1] + b],
           "p_within_tolerance": p, "class": cls,
           "within_noise": bool(value < 2 * floor), "dof": dof}
    if bias is not None:
        out["step_bias"] = dict(bias)
        out["p_within_tolerance_range"] = [p_lo, p_hi]
    return out


def model_verdicts(metrics: dict[str, Any], tol: Tolerance, *, dof: int | None = None,
                   dt_check: Mapping[str, Any] | None = None) -> dict[str, dict[str, Any]]:
    """{model: verdict} for every model whose averaging error has the asked observable;
    ``dof`` and the run's step check (``dt_check``) as in :func:`tolerance_verdict`."""
    out = {}
    bias = step_bias(dt_check, tol)
    for m, entry in metrics["models"].items():
        e = entry.get("averaging_error", {}).get(tol.observable)
        if e is not None and tol.metric in e:
            out[m] = tolerance_verdict(e, tol, dof=dof, bias=bias)
    return out


def line(model: str, v: dict[str, Any]) -> str:
    """One line: the model's estimated error, the one-sided bounds its class is decided by
    (error above ``lo`` and below ``hi``, each at the confidence), probability and class."""
    lo, hi = v.get("error_estimate_bounds", v["error_estimate_ci"])
    sb = v.get("step_bias")
    if sb is not None and sb.get("bound") is not None:
        p_lo, p_hi = v["p_within_tolerance_range"]
        return (f"{model} model: {v['metric']}({v['observable']}) error estimate "
                f"{v['error_estimate']:.4f} (noise removed; with the step bias bound "
                f"+/-{sb['bound']:.4f} the step check could not rule out, at "
                f"{100 * v['confidence']:g}% confidence above {lo:.4f} and below {hi:.4f}), "
                f"P(error <= {v['tolerance']:g}) = {p_lo:.2f} to {p_hi:.2f}: "
                f"{v['class'].upper()} the tolerance")
    tail = f" ({sb['note']})" if sb is not None else ""
    return (f"{model} model: {v['metric']}({v['observable']}) error estimate "
            f"{v['error_estimate']:.4f} (noise removed; at {100 * v['confidence']:g}% "
            f"confidence above {lo:.4f} and below {hi:.4f}), P(error <= {v['tolerance']:g}) = "
            f"{v['p_within_tolerance']:.2f}: {v['class'].upper()} the tolerance{tail}")
