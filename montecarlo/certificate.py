"""The equilibration certificate of a Monte Carlo run: has every path forgotten its start?

The run starts its paths **over-dispersed** (amplitudes spread from near rest to beyond the
largest amplitude a pilot saw, the same design in every block, so blocks stay independent and
identically distributed). Three diagnostics, none of which knows the answer:

1. **Rank-normalised R-hat across start groups** (Vehtari, Gelman, Simpson, Carpenter &
   Buerkner 2021, *Bayesian Analysis* 16:667, doi:10.1214/20-BA1221; as in ArviZ's
   ``rhat(method="rank")``: ranks back-transformed to normal scores with Blom's offset 3/8,
   R-hat = max of the "bulk" value and the "tail" value of the draws folded about the median).
   A *group* is the set of paths that share a starting amplitude (one path of each block), its
   *draws* are their mean amplitudes over the first sampled window. Draws within a group are
   independent replicas, not a time series, so the chains need not mix individually (the
   situation of "many short chains", Margossian et al. 2024, nested R-hat, where chains that
   share a start form a super-chain): R-hat > 1 means the start still shows. The limit is
   the larger of Vehtari's 1.01 and the 1 - 1e-4 quantile of R-hat under the null hypothesis
   (between/within variance ratio ~ F(G - 1, G (n - 1)) for normal scores), so that a sound
   run fails by chance at most once in 10^4.
2. **Drift of the block means of A** between the first and the last quarter of the sampled
   windows, in units of its standard error over the (independent) blocks: |z| <= 4.
3. **Effective sample size** of the mean of A, var(A) / se(mean)^2 with the standard error from
   the blocks (batch means): at least 400 (Vehtari et al. 2021's recommendation).
"""

from __future__ import annotations

import math
from statistics import NormalDist
from typing import Any

import numpy as np

RHAT_LIMIT = 1.01
NULL_ALPHA = 1e-4
DRIFT_Z = 4.0
MIN_ESS = 400.0


def average_ranks(flat: np.ndarray) -> np.ndarray:
    """Ranks 1..S of the draws, ties given the mean of the ranks they span (as
    scipy.stats.rankdata(method="average"))."""
    _, inv, count = np.unique(flat, return_inverse=True, return_counts=True)
    first = np.cumsum(count) - count  # draws below each distinct value
    return (first + (count + 1) / 2.0)[inv.ravel()]


def normal_scores(x: np.ndarray) -> np.ndarray:
    """Ranks of all draws back-transformed to N(0, 1) quantiles, (r - 3/8) / (S + 1/4)
    (the quantile by statistics.NormalDist, Wichura's AS241 to double precision)."""
    flat = x.ravel()
    u = (average_ranks(flat) - 0.375) / (flat.size + 0.25)
    ppf = NormalDist().inv_cdf
    return np.array([ppf(v) for v in u.tolist()]).reshape(x.shape)


def basic_rhat(x: np.ndarray) -> float:
    """Classic R-hat of draws x[chain, draw]: sqrt(((n-1)/n W + B/n) / W)."""
    n = x.shape[1]
    w = float(np.mean(np.var(x, axis=1, ddof=1)))
    b_n = float(np.var(np.mean(x, axis=1), ddof=1))
    if w <= 0:
        return math.nan
    return math.sqrt(((n - 1) / n * w + b_n) / w)


def rank_rhat(x: np.ndarray) -> float:
    """max(bulk, tail) rank-normalised R-hat of x[chain, draw] (no splitting: see module)."""
    bulk = basic_rhat(normal_scores(x))
    tail = basic_rhat(normal_scores(np.abs(x - np.median(x))))
    return max(bulk, tail)


def rhat_limit(chains: int, draws: int) -> float:
    """max(1.01, the 1 - 1e-4 quantile of R-hat for independent normal draws)."""
    if chains < 2 or draws < 2:
        return RHAT_LIMIT
    F = f_quantile(1 - NULL_ALPHA, chains - 1, chains * (draws - 1))
    return max(RHAT_LIMIT, math.sqrt((draws - 1) / draws + F / draws))


def _betacf(a: float, b: float, x: float) -> float:
    """The continued fraction of the incomplete beta function, by the modified Lentz method
    (Press et al., Numerical Recipes, 3rd ed., section 6.4, betacf)."""
    tiny, qab, qap, qam = 1e-300, a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 10000):
        m2 = 2 * m
        for num in (m * (b - m) * x / ((qam + m2) * (a + m2)),
                    -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))):
            d = 1.0 + num * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + num / c
            c = c if abs(c) > tiny else tiny
            h *= d * c
        if abs(d * c - 1.0) < 1e-15:
            break
    return h


def beta_cdf(x: float, a: float, b: float) -> float:
    """The regularised incomplete beta function I_x(a, b) (Numerical Recipes, betai)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    ln = (math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
          + a * math.log(x) + b * math.log1p(-x))
    if x < (a + 1.0) / (a + b + 2.0):
        return math.exp(ln) * _betacf(a, b, x) / a
    return 1.0 - math.exp(ln) * _betacf(b, a, 1.0 - x) / b


def f_quantile(q: float, d1: float, d2: float) -> float:
    """The q quantile of Fisher's F(d1, d2): F = d2 y / (d1 (1 - y)), y the q quantile of
    Beta(d1 / 2, d2 / 2), by bisection on beta_cdf (it replaces scipy.stats.f.ppf, whose
    import costs more than a run's certificate): within 1e-9 of it, relative, up to d2 ~ 3e5
    (the log-gamma differences lose digits as d2 grows; tests/test_certificate.py)."""
    a, b = 0.5 * d1, 0.5 * d2
    lo, hi = 0.0, 1.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if beta_cdf(mid, a, b) < q:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-16 * hi:
            break
    y = 0.5 * (lo + hi)
    return d2 * y / (d1 * (1.0 - y))


def certificate(windows: np.ndarray, samples_per_window: int, var_A: float,
                window_time: float) -> dict[str, Any]:
    """Diagnostics from per-path window sums of A, windows[block, path, window].

    Returns a JSON-ready dict with ``equilibrated`` (bool), ``reason`` (why not; "" when
    equilibrated), ``failed`` (the diagnostics that failed: "rhat", "drift", "ess"),
    ``rhat``, ``rhat_limit``, ``drift_z``, ``ess`` and the design."""
    means = windows / samples_per_window  # mean A per path and window
    blocks, paths, n_win = means.shape
    reasons = []
    failed = []
    # 1. start groups: path index p in every block shares the start amplitude
    first = means[:, :, 0].T  # [group = start, draw = block]
    rh = rank_rhat(first) if blocks >= 2 and paths >= 2 else math.nan
    lim = rhat_limit(paths, blocks)
    if not rh <= lim:
        reasons.append(f"rank-normalised R-hat across starting amplitudes is {rh:.3f} > "
                       f"{lim:.3f} in the first sampled window: the paths still remember "
                       "where they started (burn-in too short)")
        failed.append("rhat")
    # 2. drift of the block means between the first and the last quarter of the windows
    q = max(n_win // 4, 1)
    block_means = means.mean(axis=1)  # [block, window]
    d = block_means[:, :q].mean(axis=1) - block_means[:, n_win - q:].mean(axis=1)
    se_d = float(d.std(ddof=1) / math.sqrt(blocks)) if blocks > 1 else math.nan
    drift_z = float(d.mean() / se_d) if se_d > 0 else 0.0
    if n_win >= 2 and not abs(drift_z) <= DRIFT_Z:
        reasons.append(f"the block means of A drift by {d.mean():+.3g} ({drift_z:+.1f} standard "
                       f"errors) from the first to the last quarter of the sampled time")
        failed.append("drift")
    # 3. effective sample size of the mean of A (batch means over the blocks)
    per_block = means.mean(axis=(1, 2))
    se = float(per_block.std(ddof=1) / math.sqrt(blocks))
    ess = var_A / se**2 if se > 0 else math.inf
    if not ess >= MIN_ESS:
        reasons.append(f"effective sample size of the mean amplitude is {ess:.0f} < "
                       f"{MIN_ESS:.0f}")
        failed.append("ess")
    return {
        "equilibrated": not reasons,
        "reason": "; ".join(reasons),
        "failed": failed,
        "rhat": rh, "rhat_limit": lim,
        "rhat_method": "rank-normalised (bulk and folded) across start groups, first window "
                       "(Vehtari et al. 2021)",
        "drift_z": drift_z, "drift_limit": DRIFT_Z,
        "ess": ess, "ess_min": MIN_ESS,
        "windows": n_win, "window_time": window_time,
    }
