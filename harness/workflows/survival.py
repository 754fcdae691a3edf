"""Survival statistics of first-passage times (pure numpy/scipy; docs/passage.md derives them).

Input: ``time`` (first-passage times, or the censoring time where ``censored``) and a boolean
``censored``. Formulas and sources (Klein & Moeschberger, Survival Analysis, 2nd ed. 2003,
KM below; Hall & Wellner, Biometrika 67 (1980) 133-143):

- Kaplan-Meier (KM 4.2.1): R(t) = prod_{t_i <= t} (1 - d_i / Y_i), d_i events at t_i, Y_i at
  risk just before (events before censorings at tied times); Greenwood's variance (KM 4.2.2)
  Var R(t) = R(t)^2 sigma^2(t), sigma^2(t) = sum_{t_i <= t} d_i / (Y_i (Y_i - d_i)).
- The simultaneous 95% band: **Hall-Wellner** (KM 4.4.2), linear form,
  R(t) [1 +- c (1 + n sigma^2(t)) / sqrt(n)] for t <= t_U, with c the 95% point of
  sup_{0 <= x <= a} |B0(x)| (B0 a Brownian bridge), a = n sigma^2(t_U) / (1 + n sigma^2(t_U)).
  Why this band: it is valid under independent random censoring (the DKW band is not), and
  without censoring it is exactly the Kolmogorov-Smirnov band (1 + n sigma^2 = 1 / R there), so
  one rule covers both; c is computed, not tabulated (``hall_wellner_c``: the bridge's law on
  [0, a] by the method of images, derived in docs/passage.md). Beyond t_U the band is
  [0, upper(t_U)]: still simultaneous, because R is non-increasing. Coverage measured in
  tests/test_survival.py (n = 200, 200 seeds, ~1/3 random censoring): 0.945 (exponential),
  0.930 (Weibull); the log-log transformed band was no closer to 0.95 there (0.945, 0.920).
- Restricted mean (KM 4.5.1-4.5.2): mu(tau) = int_0^tau R dt, Var = sum_{t_i <= tau} A_i^2
  d_i / (Y_i (Y_i - d_i)), A_i = int_{t_i}^tau R dt. It is the MFPT only when R(tau) = 0;
  otherwise ``restricted`` is True and it estimates E[min(T, tau)], which a model must be
  compared with through the same restriction (``restricted_model_mean``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from scipy.optimize import brentq
from scipy.special import ndtr

LEVEL = 0.95
MIN_AT_RISK = 10  # the band's default t_U: the last event time with at least this many at risk


def _arrays(time: Any, censored: Any) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(time, dtype=float).ravel()
    c = np.asarray(censored, dtype=bool).ravel()
    if t.shape != c.shape or t.size == 0:
        raise ValueError("time and censored must be non-empty and of one length")
    if not np.all(np.isfinite(t)) or np.any(t < 0):
        raise ValueError("times must be finite and >= 0")
    return t, c


def bridge_sup_cdf(c: float, a: float, terms: int = 8) -> float:
    """P(sup_{0 <= x <= a} |B0(x)| < c) for a Brownian bridge B0 on [0, 1], 0 < a <= 1:
    sum_k [e^{-(4kc)^2/2} D(4kc) - e^{-(2c+4kc)^2/2} D(2c+4kc)],
    D(mu) = Phi((c - (1-a) mu) / s) - Phi((-c - (1-a) mu) / s), s = sqrt(a (1-a))
    (images for Brownian motion killed outside (-c, c), weighted by the bridge's end density;
    a = 1 gives Kolmogorov's distribution)."""
    total = 0.0
    for k in range(-terms, terms + 1):
        for mu, sign in ((4 * k * c, 1.0), (2 * c + 4 * k * c, -1.0)):
            w = math.exp(-0.5 * mu * mu)
            if a >= 1.0:
                d = 1.0
            else:
                s = math.sqrt(a * (1.0 - a))
                d = float(ndtr((c - (1 - a) * mu) / s) - ndtr((-c - (1 - a) * mu) / s))
            total += sign * w * d
    return total


def hall_wellner_c(a: float, level: float = LEVEL) -> float:
    """The Hall-Wellner critical value: P(sup_{[0, a]} |B0| < c) = level."""
    if not 0.0 < a <= 1.0:
        raise ValueError(f"a must lie in (0, 1], got {a}")
    return brentq(lambda c: bridge_sup_cdf(c, a) - level, 1e-3, 10.0, xtol=1e-12)


def kaplan_meier(time: Any, censored: Any, *, level: float = LEVEL,
                 t_upper: float | None = None) -> dict[str, Any]:
    """The Kaplan-Meier R(t) with Greenwood standard errors and the Hall-Wellner simultaneous
    band (module docstring). Step function: R[k] holds on [t[k], t[k+1]); t[0] = 0.

    Keys: t, R, se, lower, upper, at_risk, events (per step time), n, censored (count),
    band (its name), level, critical (c), t_upper (the band's t_U), sigma2 (n sigma^2 on t).
    """
    t_all, cen = _arrays(time, censored)
    n = t_all.size
    ut, counts = np.unique(t_all[~cen], return_counts=True)
    events = counts.astype(float)
    at_risk = (n - np.searchsorted(np.sort(t_all), ut, side="left")).astype(float)
    factor = 1.0 - events / at_risk
    R = np.concatenate([[1.0], np.cumprod(factor)])
    with np.errstate(divide="ignore", invalid="ignore"):
        inc = np.where(at_risk > events, events / (at_risk * (at_risk - events)), 0.0)
    sig2 = np.concatenate([[0.0], np.cumsum(inc)])
    t = np.concatenate([[0.0], ut])
    se = R * np.sqrt(sig2)
    ok = np.concatenate([[True], (at_risk >= MIN_AT_RISK) & (at_risk > events)])
    if t_upper is None:
        k_u = int(np.nonzero(ok)[0][-1])
    else:
        k_u = int(np.searchsorted(t, float(t_upper), side="right")) - 1
        if not ok[k_u] and k_u > 0:
            raise ValueError(f"t_upper = {t_upper} lies where the risk set is exhausted")
    lower, upper = np.zeros_like(R), np.ones_like(R)
    crit = float("nan")
    if k_u > 0:
        a = n * sig2[k_u] / (1.0 + n * sig2[k_u])
        crit = hall_wellner_c(a, level)
        half = crit * (1.0 + n * sig2[: k_u + 1]) * R[: k_u + 1] / math.sqrt(n)
        lower[: k_u + 1] = np.maximum(R[: k_u + 1] - half, 0.0)
        upper[: k_u + 1] = np.minimum(R[: k_u + 1] + half, 1.0)
        upper[k_u + 1:] = upper[k_u]
    return {"t": t, "R": R, "se": se, "lower": lower, "upper": upper,
            "at_risk": np.concatenate([[float(n)], at_risk]),
            "events": np.concatenate([[0.0], events]), "n": n, "censored": int(cen.sum()),
            "band": "Hall-Wellner (linear), simultaneous on [0, t_U]; [0, upper(t_U)] beyond",
            "level": level, "critical": crit, "t_upper": float(t[k_u]), "sigma2": n * sig2}


def _km_value(km: dict[str, Any], x: Any) -> np.ndarray:
    """R(x) of the KM step function (right-continuous)."""
    k = np.searchsorted(km["t"], np.asarray(x, dtype=float), side="right") - 1
    return km["R"][np.maximum(k, 0)]


def restricted_mean(time: Any, censored: Any, horizon: float | None = None) -> dict[str, Any]:
    """mu(tau) = int_0^tau R_KM dt and its standard error (module docstring), tau = horizon
    (default: the largest observed time). ``restricted``: R_KM(tau) > 0, i.e. the mean is
    E[min(T, tau)], not the MFPT."""
    t_all, cen = _arrays(time, censored)
    km = kaplan_meier(t_all, cen)
    tau = float(np.max(t_all)) if horizon is None else float(horizon)
    t, R = km["t"], km["R"]
    keep = t <= tau
    tk, Rk = t[keep], R[keep]
    widths = np.diff(np.append(tk, tau))
    pieces = Rk * widths
    value = float(np.sum(pieces))
    A = np.cumsum(pieces[::-1])[::-1]  # A_k = int_{t_k}^tau R dt
    d, y = km["events"][keep], km["at_risk"][keep]
    with np.errstate(divide="ignore", invalid="ignore"):
        w = np.where((y > d) & (d > 0), d / (y * (y - d)), 0.0)
    var = float(np.sum(A[1:] ** 2 * w[1:]))
    return {"value": value, "stderr": math.sqrt(var), "horizon": tau,
            "restricted": bool(Rk[-1] > 0), "paths": int(t_all.size),
            "censored": int(cen.sum())}


def restricted_model_mean(t: Any, R: Any, horizon: float, *,
                          decay_rate: float | None = None) -> float:
    """int_0^horizon R dt of a model curve (trapezoid on its times). A curve that ends before
    the horizon is continued as R_last e^{-decay_rate (t - t_last)} (its slowest mode) when
    ``decay_rate`` is given; otherwise that is an error."""
    t, R = np.asarray(t, dtype=float), np.asarray(R, dtype=float)
    if t[-1] < horizon:
        if decay_rate is None or not decay_rate > 0:
            raise ValueError(f"the model curve ends at {t[-1]:g} before the horizon "
                             f"{horizon:g}; give its decay_rate to continue it")
        tail = float(R[-1]) * -math.expm1(-decay_rate * (horizon - t[-1])) / decay_rate
        return float(np.trapezoid(R, t)) + tail
    x = np.append(t[t < horizon], horizon)
    return float(np.trapezoid(np.interp(x, t, R), x))


def sup_distance(t_model: Any, R_model: Any, km: dict[str, Any]) -> dict[str, Any]:
    """sup_t |R_model(t) - R_KM(t)| over [0, min(t_U, last model time)] (the model curve
    linearly interpolated; at each KM step the sup over [t_k, t_k+1) of a non-increasing
    model is at one of its ends). ``floor``: the largest half-width of the simultaneous 95%
    band there -- a model equal to the truth stays below it in 95% of runs; ``inside_band``:
    whether the model curve lies inside the band everywhere (its 95% test)."""
    tm, Rm = np.asarray(t_model, dtype=float), np.asarray(R_model, dtype=float)
    t, R, lo, up = km["t"], km["R"], km["lower"], km["upper"]
    end = min(km["t_upper"], float(tm[-1]))
    k = t <= end
    left = t[k]
    right = np.append(t[k][1:], end)
    m_left, m_right = np.interp(left, tm, Rm), np.interp(right, tm, Rm)
    dev = np.maximum(np.abs(m_left - R[k]), np.abs(m_right - R[k]))
    i = int(np.argmax(dev))
    half = np.maximum(up[k] - R[k], R[k] - lo[k])
    inside = bool(np.all(m_left <= up[k] + 1e-15) and np.all(m_right >= lo[k] - 1e-15))
    return {"value": float(dev[i]), "at": float(left[i]), "floor": float(np.max(half)),
            "inside_band": inside, "t_max": end}


def relative_mfpt_error(model_T: float, mc: dict[str, Any], *,
                        model_err: float = 0.0) -> dict[str, Any]:
    """(T_model - T_mc) / T_mc with its 1-sigma error bar by the delta method,
    err = (T_model / T_mc) sqrt((se_mc / T_mc)^2 + (model_err / T_model)^2). ``mc`` is a
    ``restricted_mean`` record; when it is restricted, ``model_T`` must be the model's mean
    restricted to the same horizon (``restricted_model_mean``), and the record says so."""
    tm, se = float(mc["value"]), float(mc["stderr"])
    if not tm > 0:
        raise ValueError("the Monte Carlo mean must be positive")
    ratio = float(model_T) / tm
    rel = math.hypot(se / tm, model_err / model_T if model_T else 0.0)
    return {"value": ratio - 1.0, "err": abs(ratio) * rel, "restricted": bool(mc["restricted"]),
            "horizon": mc.get("horizon")}


def fpt_density_l1(t_model: Any, R_model: Any, time: Any, censored: Any, *,
                   edges: Any = None, seed: int = 0, draws: int = 400) -> dict[str, Any]:
    """L1 distance between the model's FPT density and the Monte Carlo's, both averaged over
    bins: sum_i |q_model_i - q_i|, q_i the mass in bin i (model: R(a_i) - R(b_i) from its R
    curve, so no differentiation; Monte Carlo: the KM increments, which are the uncensored
    counts / n when censoring happens only at the horizon). Default edges: uniform from 0 to
    the largest event time, max(10, min(100, 2 events^(1/3))) bins (Rice's rule).

    ``floor`` = sum_i sqrt(2/pi) sd_i, the L1 that sampling noise alone produces (as
    harness.workflows.compare), sd_i = sqrt(q_i (1 - q_i) / n_i), n_i = Y(a_i) / R_KM(a_i) (= n
    without censoring before the bin; an approximation under random censoring); ``err``: the spread
    of the L1 under a parametric bootstrap q + sd N(0, 1) (``draws`` draws, ``seed``)."""
    edges, q, sd = fpt_bins(time, censored, edges)
    tm, Rm = np.asarray(t_model, dtype=float), np.asarray(R_model, dtype=float)
    qm = -np.diff(np.interp(edges, tm, Rm))
    value = float(np.sum(np.abs(qm - q)))
    rng = np.random.default_rng(seed)
    boot = np.abs(qm[None, :] - q[None, :] - sd[None, :] * rng.standard_normal((draws, q.size)))
    return {"value": value, "floor": float(math.sqrt(2 / math.pi) * np.sum(sd)),
            "err": float(boot.sum(axis=1).std(ddof=1)), "edges": edges, "q_model": qm,
            "q": q, "sd": sd}


def fpt_bins(time: Any, censored: Any, edges: Any = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(edges, q, sd): the Monte Carlo's FPT mass per bin, q_i = R_KM(a_i) - R_KM(b_i), and its
    standard error sd_i = sqrt(q_i (1 - q_i) / n_i), n_i = Y(a_i) / R_KM(a_i)
    (:func:`fpt_density_l1` explains both and the default edges). ValueError when no path
    passed and no edges are given."""
    t_all, cen = _arrays(time, censored)
    km = kaplan_meier(t_all, cen)
    ev = t_all[~cen]
    if edges is None:
        if ev.size == 0:
            raise ValueError("no uncensored passage: no FPT histogram")
        bins = max(10, min(100, int(2 * ev.size ** (1 / 3))))
        edges = np.linspace(0.0, float(ev.max()), bins + 1)
    edges = np.asarray(edges, dtype=float)
    Rk = _km_value(km, edges)
    q = Rk[:-1] - Rk[1:]
    y = t_all.size - np.searchsorted(np.sort(t_all), edges[:-1], side="left")
    k_before = np.searchsorted(km["t"], edges[:-1], side="left") - 1  # R(a-)
    r_before = np.where(k_before >= 0, km["R"][np.maximum(k_before, 0)], 1.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        n_eff = np.where(r_before > 0, y / np.maximum(r_before, 1e-300), 0.0)
        sd = np.where(n_eff > 0, np.sqrt(np.clip(q * (1 - q), 0, None) / n_eff), 0.0)
    return edges, q, sd


def reliability_at(km: dict[str, Any], when: float, horizon: float) -> dict[str, Any]:
    """R_KM(T) at a mission time T with its Greenwood standard error, the pointwise 95%
    interval R +/- 1.96 se clipped to [0, 1] (the normal approximation of Greenwood's formula)
    and the simultaneous Hall-Wellner band at T (wider: it holds on the whole curve at once).
    Beyond the censoring horizon the Monte Carlo did not observe R: value None, and why."""
    if when > horizon:
        return {"T": float(when), "value": None,
                "why": f"T = {when:g} is beyond the Monte Carlo's horizon {horizon:.4g}: R(T) "
                       "was not observed (raise --horizon)"}
    k = max(int(np.searchsorted(km["t"], float(when), side="right")) - 1, 0)
    r, se = float(km["R"][k]), float(km["se"][k])
    z = 1.959963984540054  # the standard normal's 97.5% quantile
    return {"T": float(when), "value": r, "se": se,
            "ci": [max(r - z * se, 0.0), min(r + z * se, 1.0)],
            "band": [float(km["lower"][k]), float(km["upper"][k])], "at_risk": float(
                km["at_risk"][k])}


def model_reliability_at(t: Any, R: Any, when: float, decay_rate: float) -> float:
    """R_M(T) of a model's reliability curve: linear interpolation on its own times; beyond
    its last time R_M decays at its slowest rate (exp(-lambda (T - t_last)), as the FPK's own
    int R dt assumes)."""
    t, R = np.asarray(t, float), np.asarray(R, float)
    if when <= t[-1]:
        return float(np.interp(when, t, R))
    if math.isfinite(decay_rate) and decay_rate > 0:
        return float(R[-1] * math.exp(-decay_rate * (when - t[-1])))
    return float(R[-1])


def mission(km: dict[str, Any], fpks: dict[str, Any], at: Any, horizon: float
            ) -> list[dict[str, Any]]:
    """R(T) at each mission time T: the original system's Kaplan-Meier value with its
    Greenwood error, pointwise 95% interval and simultaneous band (:func:`reliability_at`),
    and every model's R_M(T) from its FPK result (data["R"], info["decay_rate"]:
    :func:`model_reliability_at`)."""
    out = []
    for T in at:
        row: dict[str, Any] = {"T": float(T),
                               "original_system": reliability_at(km, T, horizon)}
        for m, r in fpks.items():
            row[m] = model_reliability_at(r.data["R"]["t"], r.data["R"]["R"], T,
                                          float(r.info.get("decay_rate", math.nan)))
        out.append(row)
    return out
