"""Distances between two densities of one observable, with the Monte Carlo noise floor.

A density is a record ``{"x", "p"}`` (smooth, on a grid; trapezoid mass 1) or a histogram
``{"x", "p", "edges", "err"}`` (bin averages and their batch standard errors).

    L1        = int |p - q|                       (0 to 2)
    Hellinger = sqrt(1 - int sqrt(p q))           (0 to 1)
    KS        = max |P - Q|, P, Q the CDFs        (0 to 1)
    W1        = int |P - Q| dx                    (Wasserstein-1, in the observable's units)
    moments   = mean and standard-deviation differences

KS and W1 read the CDFs, which a histogram gives exactly at its edges (the counts below each
edge): they do not depend on the binning beyond the interpolation between edges (linear, as
the histogram's CDF is), unlike L1, whose bins average the difference before its modulus is
taken. They are the binning-free distances reported beside the binned L1 (issue 29).

When one side is a histogram, the smooth side is averaged over its bins (through its CDF); the
mass beyond the bins is one more cell (the overflow), so it adds |P_out - Q_out| to L1 (a
histogram's overflow is 1 - its mass inside, less the atom of p(x2) at rest), and every metric
gets a **noise floor** and an **error bar** from a parametric bootstrap of the histogram: draws
q* = q + err N(0, 1).
floor = mean of metric(q, q*) (the distance that noise alone produces; for L1 it equals
sum sqrt(2/pi) err w). **Error bar**: when the histogram carries its blocks' own densities
(``p_blocks``, the batch means of the Monte Carlo), the delete-one-block jackknife of the metric:
the blocks are independent, so it holds the noise that moves many bins together (a block whose
paths sit higher shifts the whole histogram), which the bin-by-bin draws miss: on paper-base
with 256 paths the L1 of the exact model spread 4x more over seeds than those draws said
(benchmarks/results/seed_spread.json, docs/report.md); without blocks, the standard deviation
of metric(p, q*). Two histograms must share their edges; their errors add in quadrature.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

DRAWS = 400


def is_histogram(d: dict[str, Any]) -> bool:
    return "edges" in d and d.get("err") is not None


def _cdf(x: np.ndarray, p: np.ndarray) -> np.ndarray:
    c = np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(x))])
    return c / c[-1] if c[-1] > 0 else c


def bin_average(smooth: dict[str, Any], edges: np.ndarray) -> np.ndarray:
    """Average of a smooth density over each bin (exact for its trapezoid interpolant)."""
    x, p = np.asarray(smooth["x"], float), np.asarray(smooth["p"], float)
    cdf = _cdf(x, p)
    at = np.interp(edges, x, cdf, left=0.0, right=1.0)
    return np.diff(at) / np.diff(edges)


def _w1_linear(c: np.ndarray, w: np.ndarray) -> np.ndarray:
    """int |C(x)| dx for C linear between edges, C = 0 at the first edge and c[..., k] at the
    right edge of bin k (the difference of two histograms' CDFs): per bin w (|a| + |b|) / 2,
    or w (a^2 + b^2) / (2 (|a| + |b|)) where C changes sign inside it."""
    a = np.concatenate([np.zeros(c.shape[:-1] + (1,)), c[..., :-1]], axis=-1)
    b = c
    same = a * b >= 0
    s = np.abs(a) + np.abs(b)
    cross = np.divide(a * a + b * b, s, out=np.zeros_like(s), where=s > 0)
    return np.sum(np.where(same, 0.5 * s, 0.5 * cross) * w, axis=-1)


def _binned_metrics(p: np.ndarray, q: np.ndarray, w: np.ndarray, outside: float) -> np.ndarray:
    """(L1, Hellinger, KS, W1) for bin densities on widths w; shape (..., 4). ``outside``:
    |P_out - Q_out|, the overflow cell's part of L1."""
    qc = np.maximum(q, 0.0)
    l1 = np.sum(np.abs(p - q) * w, axis=-1) + outside
    bc = np.sum(np.sqrt(np.maximum(p, 0.0) * qc) * w, axis=-1)
    hell = np.sqrt(np.maximum(1.0 - bc, 0.0))
    c = np.cumsum((p - q) * w, axis=-1)
    ks = np.max(np.abs(c), axis=-1)
    return np.stack([l1, hell, ks, _w1_linear(c, w)], axis=-1)


def _jackknife(p: np.ndarray, hist: dict[str, Any], w: np.ndarray, outside: float
               ) -> np.ndarray:
    """Standard error of the binned metrics of (p, hist) by the delete-one-block jackknife
    over the histogram's blocks (``p_blocks``, equal-weight batch means):
    sqrt((n - 1) / n sum_j (m_(j) - mean m)^2), m_(j) the metric with block j left out."""
    blocks = np.asarray(hist["p_blocks"], float)
    n = blocks.shape[0]
    loo = (blocks.sum(axis=0) - blocks) / (n - 1)
    m = _binned_metrics(p, loo, w, outside)
    return np.sqrt((n - 1) / n * np.sum((m - m.mean(axis=0)) ** 2, axis=0))


def _moments_binned(c: np.ndarray, q: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    m = np.sum(q * w)
    mean = float(np.sum(c * q * w) / m)
    return mean, float(math.sqrt(max(np.sum((c - mean) ** 2 * q * w) / m, 0.0)))


def _moments_smooth(d: dict[str, Any]) -> tuple[float, float]:
    x, p = np.asarray(d["x"], float), np.asarray(d["p"], float)
    m = np.trapezoid(p, x)
    mean = float(np.trapezoid(x * p, x) / m)
    return mean, float(math.sqrt(max(np.trapezoid((x - mean) ** 2 * p, x) / m, 0.0)))


def compare(a: dict[str, Any], b: dict[str, Any], *, seed: int = 0) -> dict[str, float]:
    """Metrics between densities a and b (see module docstring), JSON-ready.

    Keys: L1, hellinger, ks, w1, mean_diff, std_diff; for histogram comparisons also
    L1_floor, hellinger_floor, ks_floor, w1_floor and L1_err, hellinger_err, ks_err, w1_err.
    """
    if is_histogram(a) and not is_histogram(b):
        a, b = b, a
    if not is_histogram(b):
        return _smooth_pair(a, b)
    edges = np.asarray(b["edges"], float)
    w = np.diff(edges)
    c = 0.5 * (edges[1:] + edges[:-1])
    q = np.asarray(b["p"], float)
    err = np.asarray(b["err"], float)
    if is_histogram(a):
        ea = np.asarray(a["edges"], float)
        if ea.shape != edges.shape or not np.allclose(ea, edges):
            raise ValueError("two histograms must share their edges")
        p = np.asarray(a["p"], float)
        err_p = np.asarray(a["err"], float)
        outside = 0.0
        ma = _moments_binned(c, p, w)
    else:
        p = bin_average(a, edges)
        err_p = np.zeros_like(p)
        out_p = max(1.0 - float(np.sum(p * w)), 0.0)
        out_q = max(1.0 - float(np.sum(q * w)) - float(b.get("atom_weight", 0.0)), 0.0)
        outside = abs(out_p - out_q)
        ma = _moments_smooth(a)
    base = _binned_metrics(p, q, w, outside)
    mb = _moments_binned(c, q, w)
    rng = np.random.default_rng(seed)
    total_err = np.sqrt(err**2 + err_p**2)
    noise = rng.standard_normal((DRAWS, q.size)) * total_err
    floor = _binned_metrics(q, q + noise, w, 0.0).mean(axis=0)
    spread = _binned_metrics(p, q + rng.standard_normal((DRAWS, q.size)) * err, w,
                             outside).std(axis=0, ddof=1)
    jack = [_jackknife(p, b, w, outside)] if "p_blocks" in b else []
    if jack and is_histogram(a) and "p_blocks" in a:
        jack.append(_jackknife(q, a, w, outside))
    if jack:
        spread = np.sqrt(sum(j**2 for j in jack))
    out = {
        "L1": float(base[0]), "hellinger": float(base[1]), "ks": float(base[2]),
        "L1_floor": float(floor[0]), "hellinger_floor": float(floor[1]),
        "ks_floor": float(floor[2]), "w1": float(base[3]), "w1_floor": float(floor[3]),
        "L1_err": float(spread[0]), "hellinger_err": float(spread[1]), "ks_err": float(spread[2]),
        "w1_err": float(spread[3]),
        "mean_diff": ma[0] - mb[0], "std_diff": ma[1] - mb[1],
    }
    return out


def _smooth_pair(a: dict[str, Any], b: dict[str, Any]) -> dict[str, float]:
    xa, pa = np.asarray(a["x"], float), np.asarray(a["p"], float)
    xb, pb = np.asarray(b["x"], float), np.asarray(b["p"], float)
    x = np.union1d(xa, xb)
    fa = np.interp(x, xa, pa, left=0.0, right=0.0)
    fb = np.interp(x, xb, pb, left=0.0, right=0.0)
    l1 = float(np.trapezoid(np.abs(fa - fb), x))
    bc = float(np.trapezoid(np.sqrt(fa * fb), x))
    dc = np.abs(np.interp(x, xa, _cdf(xa, pa), left=0, right=1)
                - np.interp(x, xb, _cdf(xb, pb), left=0, right=1))
    ks = float(np.max(dc))
    ma, mb = _moments_smooth(a), _moments_smooth(b)
    return {"L1": l1, "hellinger": math.sqrt(max(1.0 - bc, 0.0)), "ks": ks,
            "w1": float(np.trapezoid(dc, x)),
            "L1_floor": 0.0, "hellinger_floor": 0.0, "ks_floor": 0.0, "w1_floor": 0.0,
            "mean_diff": ma[0] - mb[0], "std_diff": ma[1] - mb[1]}


#: the metrics a paired comparison reads, by their index in _binned_metrics
METRICS = ("L1", "hellinger", "ks", "w1")


def _smooth_side(a: dict[str, Any], b: dict[str, Any], edges: np.ndarray, w: np.ndarray
                 ) -> tuple[np.ndarray, float]:
    """(bin averages of smooth density a on the edges, |P_out - Q_out|) as compare() has
    them against histogram b."""
    p = bin_average(a, edges)
    q = np.asarray(b["p"], float)
    out_p = max(1.0 - float(np.sum(p * w)), 0.0)
    out_q = max(1.0 - float(np.sum(q * w)) - float(b.get("atom_weight", 0.0)), 0.0)
    return p, abs(out_p - out_q)


def paired(a: dict[str, Any], b: dict[str, Any], truth: dict[str, Any], *,
           metric: str = "L1", seed: int = 0) -> dict[str, Any]:
    """The difference of two models' distances to the SAME truth, with its standard error:
    diff = metric(a, truth) - metric(b, truth) (negative: a is nearer).

    Against a Monte Carlo histogram both distances move with the same noise (a block whose
    paths sit higher moves both), so their difference carries much less of it than either
    distance: its error bar is the delete-one-block jackknife of the DIFFERENCE over the
    histogram's blocks (``p_blocks``; compare.py's error bar of one distance, applied to the
    pair), else the standard deviation of the difference over DRAWS paired parametric draws
    q* = q + err N(0, 1), both models against each draw. A truth without sampling noise (a
    smooth density: an FPK solve, a closed form) gives diff_err = 0, and ``dof`` None.
    Returns {"metric", "diff", "diff_err", "dof", "a", "b"} (a, b: the two distances).
    For L1 the raw difference has the sign of the true one: both distances share the truth's
    noise floor F and E L1 ~ sqrt(L^2 + F^2) is increasing in L (docs/report.md)."""
    k = METRICS.index(metric)
    if is_histogram(a) or is_histogram(b):  # no smooth side to pair: each with its own bar
        ea, eb = compare(a, truth, seed=seed), compare(b, truth, seed=seed)
        err = math.hypot(ea.get(f"{metric}_err", 0.0), eb.get(f"{metric}_err", 0.0))
        return {"metric": metric, "diff": ea[metric] - eb[metric], "diff_err": err,
                "dof": None, "a": ea[metric], "b": eb[metric]}
    if not is_histogram(truth):  # noise-free truth: the difference is exact
        va, vb = compare(a, truth)[metric], compare(b, truth)[metric]
        return {"metric": metric, "diff": va - vb, "diff_err": 0.0, "dof": None,
                "a": va, "b": vb}
    edges = np.asarray(truth["edges"], float)
    w = np.diff(edges)
    q = np.asarray(truth["p"], float)
    pa, oa = _smooth_side(a, truth, edges, w)
    pb, ob = _smooth_side(b, truth, edges, w)
    va = float(_binned_metrics(pa, q, w, oa)[k])
    vb = float(_binned_metrics(pb, q, w, ob)[k])
    if "p_blocks" in truth:
        blocks = np.asarray(truth["p_blocks"], float)
        n = blocks.shape[0]
        loo = (blocks.sum(axis=0) - blocks) / (n - 1)
        d = _binned_metrics(pa, loo, w, oa)[:, k] - _binned_metrics(pb, loo, w, ob)[:, k]
        err = float(np.sqrt((n - 1) / n * np.sum((d - d.mean()) ** 2)))
        dof: int | None = n - 1
    else:
        rng = np.random.default_rng(seed)
        qs = q + rng.standard_normal((DRAWS, q.size)) * np.asarray(truth["err"], float)
        d = _binned_metrics(pa, qs, w, oa)[:, k] - _binned_metrics(pb, qs, w, ob)[:, k]
        err, dof = float(np.std(d, ddof=1)), None
    return {"metric": metric, "diff": va - vb, "diff_err": err, "dof": dof, "a": va, "b": vb}
