"""Adaptive multilevel splitting (AMS) in its generalised form (GAMS): the estimator of the
probability that a replica reaches q_hi before q_lo, unbiased for any number of replicas
killed per iteration and with ties (splitting.py's module docstring: the algorithm and its
sources), with each run's, each clone's and each pick's own random stream."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from vifpk.montecarlo import splitting_kernels as SK

KEY_START, KEY_CLONE, KEY_PICK, KEY_DIRECT = 0, 1, 2, 3  # spawn_key roots of the streams


def words(seed: int, key: tuple[int, ...], n: int) -> np.ndarray:
    """(n, 4) uint64 generator words from SeedSequence(seed, spawn_key=key): a fresh stream
    per row, the same for a seed whatever the thread count or the executor."""
    w = np.random.SeedSequence(seed, spawn_key=key).generate_state(4 * n, dtype=np.uint64)
    w = w.reshape(n, 4)
    w[~w.any(axis=1), 0] = 1
    return w


def t_quantile(dof: int) -> float:
    from scipy.stats import t

    return float(t.ppf(0.975, dof))


def ams(advance: Callable[..., None], starts: np.ndarray, q: np.ndarray, *, q_lo: float,
        q_hi: float, levels: int, kill: int, seed: int, first_group: int = 0
        ) -> dict[str, Any]:
    """GAMS (module docstring) for G independent runs of N replicas each, run in step so that
    one kernel call advances the killed replicas of every run (in parallel).

    starts: (G, N, S) state rows; q: (G, N) their reaction coordinate; advance(recs, rows,
    start, rng, maxlev, outcome) the kernel (splitting_kernels.advance_*, its physics bound).
    Run g's streams are keyed by first_group + g, so groups run in several calls give the
    numbers of one call.
    Returns {"p": (G,), "iterations": (G,), "killed": (G,) total killed, "extinct": (G,) bool,
    "timeouts": int}."""
    G, N, S = starts.shape
    M = int(levels)
    k = int(kill) if kill > 0 else max(1, N // 10)
    if not 1 <= k < N:
        raise ValueError(f"kill = {k}: must be in [1, {N - 1}] for {N} particles")
    recs = np.zeros((G * N, M + 1, S))
    lev0 = np.array([SK.level_of(float(v), q_lo, M / (q_hi - q_lo), M) for v in q.ravel()])
    recs[np.arange(G * N), lev0] = starts.reshape(G * N, S)
    maxlev = np.zeros(G * N, dtype=np.int64)
    outcome = np.zeros(G * N, dtype=np.int64)
    rows = np.arange(G * N, dtype=np.int64)
    rng = np.concatenate([words(seed, (KEY_START, first_group + g), N) for g in range(G)])
    advance(recs, rows, lev0.astype(np.int64), rng, maxlev, outcome)
    timeouts = int((outcome == SK.OUT_TIMEOUT).sum())
    log_c = np.zeros(G)
    iters = np.zeros(G, dtype=np.int64)
    killed_total = np.zeros(G, dtype=np.int64)
    extinct = np.zeros(G, dtype=bool)
    active = np.ones(G, dtype=bool)
    while active.any():
        job_rows, job_start, job_rng = [], [], []
        for g in np.flatnonzero(active):
            ml = maxlev[g * N:(g + 1) * N]
            Z = int(np.partition(ml, k - 1)[k - 1])
            if Z >= M:
                active[g] = False
                continue
            dead = np.flatnonzero(ml <= Z)
            K = dead.size
            if K == N:
                extinct[g] = True
                active[g] = False
                continue
            log_c[g] += math.log1p(-K / N)
            it = int(iters[g])
            iters[g] += 1
            killed_total[g] += K
            alive = np.flatnonzero(ml > Z)
            key = (first_group + int(g), it)
            pick = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(KEY_PICK, *key)))
            src = alive[pick.integers(0, alive.size, size=K)] + g * N
            dst = dead + g * N
            recs[dst, :Z + 2] = recs[src, :Z + 2]
            job_rows.append(dst)
            job_start.append(np.full(K, Z + 1, dtype=np.int64))
            job_rng.append(words(seed, (KEY_CLONE, *key), K))
        if job_rows:
            r = np.concatenate(job_rows).astype(np.int64)
            advance(recs, r, np.concatenate(job_start), np.concatenate(job_rng), maxlev, outcome)
            timeouts += int((outcome[r] == SK.OUT_TIMEOUT).sum())
    hits = (maxlev.reshape(G, N) >= M).sum(axis=1)
    p = np.where(extinct, 0.0, np.exp(log_c) * hits / N)
    return {"p": p, "iterations": iters, "killed": killed_total, "extinct": extinct,
            "timeouts": timeouts, "kill": k}


def mean_ci(values: np.ndarray) -> dict[str, Any]:
    """Mean of independent replicas, standard error and the Student-t 95% interval."""
    v = np.asarray(values, float)
    G = v.size
    m = float(v.mean())
    se = float(v.std(ddof=1) / math.sqrt(G)) if G > 1 else math.nan
    tq = t_quantile(G - 1) if G > 1 else math.nan
    return {"value": m, "stderr": se, "ci": [float(m - tq * se), float(m + tq * se)],
            "replicas": G,
            "level": 0.95}
