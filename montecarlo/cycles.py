"""The cycle decomposition of the MFPT (splitting.py's module docstring: T = E[W] + (1 - q_w)
E[tau] / p by Wald's identity, with its delta-method interval): the direct part (groups of
paths run cycle after cycle, their cycle starts the AMS runs' entrance law), the AMS runs
(ams.py) from those starts, and the batches of groups run until a relative interval is
reached, the budget or the group limit."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from vifpk.montecarlo import splitting_kernels as SK
from vifpk.montecarlo.ams import KEY_DIRECT, ams, mean_ci, t_quantile, words

if TYPE_CHECKING:
    from vifpk.montecarlo.splitting import SplittingSettings


def cycle_mfpt(W: np.ndarray, qw: np.ndarray, S: np.ndarray, n: np.ndarray, p: np.ndarray
               ) -> dict[str, Any]:
    """T = E[W] + (1 - q_w) E[tau] / p with its delta-method standard error and Student-t 95%
    interval from per-group values (module docstring): W, qw the groups' mean warm-up time and
    fraction of warm-ups that reached qc; S, n their total cycle time and cycle count; p their
    AMS estimates."""
    W, qw, S, n, p = (np.asarray(a, float) for a in (W, qw, S, n, p))
    G = W.size
    Wm, qm, nm, pm = W.mean(), qw.mean(), n.mean(), p.mean()
    tau = S.sum() / n.sum()
    value = Wm + (1 - qm) * tau / pm
    phi = ((W - Wm) - (qw - qm) * tau / pm + (1 - qm) * (S - tau * n) / (nm * pm)
           - (1 - qm) * tau * (p - pm) / pm**2)
    se = float(math.sqrt((phi**2).sum() / (G * (G - 1)))) if G > 1 else math.nan
    tq = t_quantile(G - 1) if G > 1 else math.nan
    return {"value": float(value), "stderr": se,
            "ci": [float(value - tq * se), float(value + tq * se)],
            "level": 0.95, "replicas": G, "mean_cycle": float(tau), "mean_warm_up": float(Wm),
            "warm_up_hits": float(qm)}


def numba_threads(n: int) -> Any:
    """A context in which numba runs on min(n, NUMBA_NUM_THREADS) threads (n <= 0: as it is)."""
    import contextlib

    import numba

    if n <= 0:
        return contextlib.nullcontext()

    @contextlib.contextmanager
    def ctx() -> Any:
        old = numba.get_num_threads()
        numba.set_num_threads(min(n, numba.config.NUMBA_NUM_THREADS))
        try:
            yield
        finally:
            numba.set_num_threads(old)
    return ctx()


def groups_direct(dyn: Any, start_rows: Callable[[int, int, int], np.ndarray], q0: float,
                   q1: float, qc: float, s: SplittingSettings, first: int, G: int
                   ) -> dict[str, Any]:
    """The direct part: G groups of s.paths paths, each run to s.cycles cycles (or a success).
    Returns per-group W, qw, S, n, direct successes, and the (G, N, width) AMS starts (cycle
    starts of the group, taken in order, path after path, when enough)."""
    P, N = s.paths, s.particles
    if P * s.cycles < N:
        raise ValueError(f"paths x cycles = {P * s.cycles} < particles = {N}: too few cycle "
                         "starts to start the AMS runs from")
    starts = np.concatenate([start_rows(P, s.seed, first + g) for g in range(G)])
    rng = np.concatenate([words(s.seed, (KEY_DIRECT, first + g), P) for g in range(G)])
    entries, summ = dyn.cycles(starts, rng, s.cycles, q0, q1, qc, s.max_time)
    if (summ[:, 5] == 2).any():
        raise RuntimeError(f"start 'stationary': {int((summ[:, 5] == 2).sum())} direct path(s) "
                           f"reached the threshold in more than {SK.MAX_RESTARTS} burn-ins in "
                           "a row: the threshold is inside the bulk of the stationary law")
    if summ[:, 5].any():
        raise RuntimeError(f"{int(summ[:, 5].sum())} direct path(s) reached max_time = "
                           f"{s.max_time:g} before completing their cycles: lower levels "
                           "(low/entry) closer to the bulk of the law, or raise max_time")
    summ = summ.reshape(G, P, summ.shape[1])
    ent = entries.reshape(G, P, s.cycles, dyn.width)
    valid = np.arange(s.cycles)[None, None, :] < summ[:, :, 2, None]
    pools = np.zeros((G, N, dyn.width))
    for g in range(G):
        e = ent[g][valid[g]]
        if e.shape[0] == 0:
            raise RuntimeError(f"group {g}: no cycle start (every direct path reached the "
                               "threshold in its warm-up): the threshold is within reach of "
                               "direct simulation")
        # spread over the paths; with fewer starts than particles (direct successes ended
        # paths early) some are used twice: the AMS then samples the empirical entrance law
        take = np.linspace(0, e.shape[0] - 1, N).round().astype(int)
        pools[g] = e[take]
    return {"W": summ[:, :, 0].mean(axis=1), "qw": summ[:, :, 1].mean(axis=1),
            "S": summ[:, :, 3].sum(axis=1), "n": summ[:, :, 2].sum(axis=1),
            "successes": int(summ[:, :, 4].sum()), "pools": pools,
            "cycles": int(summ[:, :, 2].sum())}


def mfpt_by_cycles(dyn: Any, start_rows: Callable[[int, int, int], np.ndarray], qfun: Callable,
          q0: float, q1: float, qc: float, s: SplittingSettings
          ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The MFPT by the cycle decomposition: (mfpt record, details). Groups are run in batches
    of s.groups; with s.rel_ci > 0, batches are added until the 95% interval's half-width is at
    most rel_ci x the value, or s.budget seconds would be exceeded by one more batch, or
    s.max_groups are run (details["target"] says which). Group g's numbers do not depend on
    the batch it ran in."""
    t0 = time.perf_counter()
    keys = ("W", "qw", "S", "n", "p", "iterations")
    acc: dict[str, list[np.ndarray]] = {k: [] for k in keys}
    cycles = successes = extinct = 0
    t_direct = t_ams = 0.0
    first = 0
    target = "fixed groups"
    while True:
        tb = time.perf_counter()
        with numba_threads(s.threads):
            d = groups_direct(dyn, start_rows, q0, q1, qc, s, first, s.groups)
            t1 = time.perf_counter()
            out = ams(dyn.advance(q0, qc, s.levels, s.max_time), d["pools"], qfun(d["pools"]),
                      q_lo=q0, q_hi=qc, levels=s.levels, kill=s.kill, seed=s.seed,
                      first_group=first)
        t2 = time.perf_counter()
        t_direct += t1 - tb
        t_ams += t2 - t1
        if out["timeouts"]:
            raise RuntimeError(f"{out['timeouts']} AMS path(s) reached max_time = "
                               f"{s.max_time:g}")
        for k in ("W", "qw", "S", "n"):
            acc[k].append(d[k])
        acc["p"].append(out["p"])
        acc["iterations"].append(out["iterations"])
        cycles += d["cycles"]
        successes += d["successes"]
        extinct += int(out["extinct"].sum())
        first += s.groups
        p_all = np.concatenate(acc["p"])
        if np.all(p_all == 0):
            raise RuntimeError("every AMS run died out (p = 0 in each group): use more "
                               "particles")
        rec = cycle_mfpt(*(np.concatenate(acc[k]) for k in ("W", "qw", "S", "n", "p")))
        if s.rel_ci <= 0:
            break
        half = 0.5 * (rec["ci"][1] - rec["ci"][0]) / rec["value"]
        spent = time.perf_counter() - t0
        if half <= s.rel_ci:
            target = f"reached: relative half-width {half:.3g} <= {s.rel_ci:g}"
            break
        if first + s.groups > s.max_groups:
            target = f"NOT reached: {half:.3g} > {s.rel_ci:g} at max_groups = {s.max_groups}"
            break
        if s.budget > 0 and spent + (t2 - tb) > s.budget:
            target = (f"NOT reached: {half:.3g} > {s.rel_ci:g}; one more batch would exceed "
                      f"the budget of {s.budget:g} s")
            break
    prob = mean_ci(p_all)
    prob["runs"] = p_all.tolist()
    rec["p"] = prob
    details = {"groups": first, "direct_cycles": cycles, "direct_successes": successes,
               "iterations": np.concatenate(acc["iterations"]).tolist(), "kill": out["kill"],
               "extinct": extinct, "target": target,
               "seconds": {"direct": t_direct, "ams": t_ams,
                           "total": time.perf_counter() - t0}}
    return rec, details
