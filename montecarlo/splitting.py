"""Rare events by adaptive multilevel splitting (AMS) and the cycle decomposition of the MFPT.

AMS (Cerou & Guyader 2007), in the generalised form whose estimator is unbiased for any number
k >= 1 of replicas killed per iteration and with ties (Brehier, Lelievre, Rousset et al.,
Ann. Appl. Probab. 26 (2016) 3559; "GAMS"): N replicas start from the entrance law and run
until absorbed (back at q <= q_lo, or at q >= q_hi). Each replica's score is the highest level
it reached (levels: splitting_kernels.level_of, M integer levels of the reaction coordinate q,
so ties happen and are handled as GAMS does). An iteration: Z = the k-th smallest score; if
Z = M, stop; kill EVERY replica with score <= Z (K >= k of them; if K = N the run dies, p = 0);
multiply C by (1 - K / N); each killed replica is replaced by a copy of a survivor drawn
uniformly, up to the survivor's first step at level > Z, and continues from there with a
fresh random stream. At the end p_hat = C * (number of replicas at q_hi) / N, and
E[p_hat] = p exactly (for the time-discrete chain being simulated; the theorem needs only the
Markov property of the chain, not of the score, and holds for a discrete score).

The cycle decomposition (renewal; e.g. Cerou, Guyader, Lelievre & Pommier, J. Chem. Phys. 134
(2011) 054108): levels q0 < q1 < qc. A cycle starts at the first step with q >= q1 after a
visit to q <= q0, and ends at the next cycle start or at the first step with q >= qc (a
success). With the cycles independent and identically distributed (exact for a 1-D diffusion,
whose cycle starts are all at q1; for the original system the cycle starts form a Markov chain,
taken in its stationary law, which the entries of many cycles sample), the number of cycles up
to the first success is N ~ Geometric(p), p = P(a cycle succeeds), a stopping time of the
cycles, so Wald's identity gives E[sum_{k<=N} tau_k] = E[N] E[tau] = E[tau] / p, where tau is a
cycle's duration (a successful cycle's: its time to qc). From a start law below q1:

    T = E[W] + (1 - q_w) E[tau] / p,

W the warm-up time (start to the first cycle start, or to qc when it gets there first: q_w the
probability of that). E[W], q_w and E[tau] come from direct simulation (paths stopped after a
fixed number of cycles or at a success, so Wald again makes the ratio (total time) / (cycles)
consistent), p from AMS started at cycle starts collected there.

Confidence intervals from G independent groups (each with its own direct paths and its own AMS
run): p_bar the mean of the G unbiased AMS estimates, its standard error their standard
deviation / sqrt(G); T by the delta method with the per-group influence
phi_g = (W_g - W) - (q_g - q_w) E[tau] / p + (1 - q_w)(S_g - E[tau] n_g) / (n p)
- (1 - q_w) E[tau] (p_g - p) / p^2 (S_g, n_g a group's total cycle time and count, n their mean):
se(T)^2 = sum phi_g^2 / (G (G - 1)); intervals value +- t_{G-1, 0.975} se.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from vifpk.montecarlo.ams import KEY_START, ams, mean_ci, t_quantile, words
from vifpk.montecarlo.cycles import cycle_mfpt, mfpt_by_cycles, numba_threads

from vifpk.core.result import BadInput, Result, Status

from . import sde_lanes_splitting as SDL
from . import splitting_kernels as SK
from . import splitting_lanes as SL
from .averaged_sde import sde_tables
from .geometry import potential
from .pieces import record
from .plan import bounds, fold, physics

#: the names this module has always offered (AMS and the cycle decomposition: ams.py, cycles.py)
__all__ = ["SplittingSettings", "ams", "cycle_mfpt", "mean_ci", "passage_splitting",
           "sde_escape_probability", "sde_passage_splitting", "t_quantile"]


@dataclass(frozen=True, kw_only=True)
class SplittingSettings:
    """groups: independent repetitions of the whole algorithm (the confidence interval's
    samples); particles: N replicas per AMS run; kill: k replicas killed per iteration (0:
    max(1, N // 10)); levels: M levels of the reaction coordinate between q0 and qc; dt: time
    step; seed: root of every stream; cycles: cycles per direct path; paths: direct paths per
    group (their cycle starts, spread over N particles, start the group's AMS run); max_time: the
    longest time one path is run (a path that reaches it is an error); threads: numba
    threads (0: numba's default); rel_ci: with > 0, batches of ``groups`` groups are added
    until the 95% interval of the MFPT is within rel_ci x its value (a sequential stop: the
    interval's coverage is then nominal only approximately), within ``budget`` seconds (0: no
    limit) and ``max_groups`` groups."""

    groups: int = 20
    particles: int = 200
    kill: int = 0
    levels: int = 200
    dt: float = 1e-3
    seed: int = 20190102
    cycles: int = 25
    paths: int = 8
    max_time: float = 1e7
    threads: int = 0
    rel_ci: float = 0.0
    budget: float = 0.0
    max_groups: int = 400

    def __post_init__(self) -> None:
        """Every setting in its range, one line naming it (BadInput): a negative dt ran time
        backwards and never ended, particles = 0 failed deep in numpy, groups = 1 left the
        Student-t interval with no degree of freedom (review of issue 31)."""
        def whole(name: str, lo: int, why: str) -> None:
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < lo:
                raise BadInput(f"splitting {name} = {v!r}: allowed: a whole number >= {lo} "
                               f"({why})")

        def positive(name: str, zero_ok: bool = False) -> None:
            v = getattr(self, name)
            ok = (not isinstance(v, bool) and isinstance(v, int | float | np.floating)
                  and math.isfinite(v) and (v >= 0 if zero_ok else v > 0))
            if not ok:
                raise BadInput(f"splitting {name} = {v!r}: allowed: a finite number "
                               f"{'>= 0' if zero_ok else '> 0'}")

        whole("groups", 2, "independent groups: the interval needs at least two")
        whole("particles", 2, "replicas per AMS run")
        whole("kill", 0, "0: max(1, particles // 10)")
        whole("levels", 1, "levels of the reaction coordinate")
        whole("cycles", 1, "cycles per direct path")
        whole("paths", 1, "direct paths per group")
        whole("threads", 0, "0: numba's default")
        whole("max_groups", 2, "the most groups rel_ci may add")
        whole("seed", 0, "the root seed")
        positive("dt")
        positive("max_time")
        positive("rel_ci", zero_ok=True)
        positive("budget", zero_ok=True)
        if self.kill >= self.particles:
            raise BadInput(f"splitting kill = {self.kill}: allowed: fewer than particles = "
                           f"{self.particles}")
        if self.dt >= self.max_time:
            raise BadInput(f"splitting dt = {self.dt:g}: allowed: below max_time = "
                           f"{self.max_time:g}")


# ---------------------------------------------------------------------- the averaged SDE
class _SDE:
    """The averaged amplitude SDE's kernels, q = Z = A^2."""

    width = 2

    def __init__(self, drift: Callable, diffusion: Callable, top: float, dt: float,
                 table_points: int = 4001) -> None:
        grid, self.a_tab, self.b_tab = sde_tables(drift, diffusion, top, table_points)
        self.inv_d = 1.0 / (grid[1] - grid[0])
        self.h = float(dt)

    def q(self, A: np.ndarray) -> np.ndarray:
        return np.asarray(A, float) ** 2

    def rows(self, A: np.ndarray) -> np.ndarray:
        A = np.asarray(A, float)
        return np.stack([A**2, np.zeros_like(A)], axis=-1)

    def advance(self, q_lo: float, q_hi: float, M: int, t_max: float) -> Callable[..., None]:
        def run(recs, rows, start, rng, maxlev, outcome) -> None:
            SDL.advance_sde(recs, rows, start, rng, maxlev, outcome, q_lo, q_hi, M, t_max,
                           self.h, self.a_tab, self.b_tab, self.inv_d)
        return run

    def cycles(self, starts: np.ndarray, rng: np.ndarray, n_cycles: int, q0: float, q1: float,
               qc: float, t_max: float) -> tuple[np.ndarray, np.ndarray]:
        entries = np.zeros((starts.shape[0], n_cycles, self.width))
        summary = np.zeros((starts.shape[0], 7))
        SDL.cycles_sde(starts[:, 0].copy(), rng, n_cycles, q0, q1, qc, t_max, self.h,
                      self.a_tab, self.b_tab, self.inv_d, entries, summary)
        return entries, summary


def sde_escape_probability(drift: Callable, diffusion: Callable, *, low: float,
                           threshold: float, start: float,
                           settings: SplittingSettings) -> Result:
    """P(A reaches ``threshold`` before ``low`` | A(0) = start) for the averaged SDE
    dA = m dt + sigma dB (the scheme of averaged_sde), by AMS from the point ``start``:
    data["p"] = {"value", "stderr", "ci", "replicas", "level", "runs": per-group estimates}."""
    if not 0.0 < low < start < threshold:
        raise ValueError(f"need 0 < low < start < threshold, got {low}, {start}, {threshold}")
    s = settings
    t0 = time.perf_counter()
    dyn = _SDE(drift, diffusion, 1.5 * threshold, s.dt)
    starts = np.broadcast_to(dyn.rows(np.array([start])), (s.groups, s.particles, 2)).copy()
    q = np.full((s.groups, s.particles), start**2)
    with numba_threads(s.threads):
        out = ams(dyn.advance(low**2, threshold**2, s.levels, s.max_time), starts, q,
                  q_lo=low**2, q_hi=threshold**2, levels=s.levels, kill=s.kill, seed=s.seed)
    est = mean_ci(out["p"])
    est["runs"] = out["p"].tolist()
    status = Status.SIMULATED if out["timeouts"] == 0 else Status.TIMED_OUT
    info = {"solver": "averaged-sde", "method": "splitting", "low": low, "threshold": threshold,
            "start": start, "settings": asdict(s), "kill": out["kill"],
            "iterations": out["iterations"].tolist(), "extinct": int(out["extinct"].sum()),
            "timeouts": out["timeouts"], "seconds": time.perf_counter() - t0,
            "status": status.record()}
    return Result(data={"p": est}, info=info)


def sde_passage_splitting(drift: Callable, diffusion: Callable, *, threshold: float,
                          start: float, low: float, entry: float,
                          settings: SplittingSettings) -> Result:
    """MFPT of the averaged SDE from A(0) = start to ``threshold`` by the cycle decomposition
    (module docstring) with levels low < entry < threshold in amplitude (start < entry).
    info["mfpt"] = {"value", "stderr", "ci", ..., "p": the cycle's success probability}."""
    if not 0.0 < low < entry < threshold or not 0.0 < start < entry:
        raise ValueError(f"need 0 < low < entry < threshold and 0 < start < entry, got low = "
                         f"{low}, entry = {entry}, threshold = {threshold}, start = {start}")
    s = settings
    dyn = _SDE(drift, diffusion, 1.5 * threshold, s.dt)

    def rows(n: int, _seed: int, _g: int) -> np.ndarray:
        return dyn.rows(np.full(n, float(start)))

    rec, det = mfpt_by_cycles(dyn, rows, lambda st: st[..., 0], low**2, entry**2, threshold**2, s)
    info = {"solver": "averaged-sde", "method": "splitting", "threshold": threshold,
            "start": start, "low": low, "entry": entry, "settings": asdict(s), "mfpt": rec,
            **det, "status": Status.SIMULATED.record()}
    return Result(data={"mfpt": rec}, info=info)


# ---------------------------------------------------------------------- the original system
class _Original:
    """The original system's kernels (kernels.strang_step), q = E = v^2/2 + U(x)."""

    width = 5

    def __init__(self, system: Any, noise: Any, dt: float, burn_in: float = 0.0,
                 parametric: Any = None) -> None:
        self.phys = physics(system, noise, parametric)
        self.h = float(dt)
        self.n_burn = int(round(burn_in / self.h))
        self.rec = record(self.phys, self.h)
        # the bridge test's terms (passage.py's docstring; all None under OU noise alone)
        self.B = (self.rec.bridge, self.rec.pk, self.rec.pc)

    def U(self, A: float) -> float:
        ph = self.phys
        return float(potential(float(A), ph["w0sq"], ph["alpha"], ph["khi"]))

    def q(self, rows: np.ndarray) -> np.ndarray:
        x, v = rows[..., 0], rows[..., 1]
        return 0.5 * v * v + np.vectorize(self.U)(x)

    def starts(self, A: float, n: int, seed: int, key: int) -> np.ndarray:
        ph = self.phys
        out = np.zeros((n, 5))
        SK.orbit_starts(float(A), out, words(seed, (KEY_START + 100, key), n), ph["w0sq"],
                        ph["alpha"], ph["khi"], (fold(ph), *bounds(ph)), self.rec)
        return out

    def advance(self, q_lo: float, q_hi: float, M: int, t_max: float) -> Callable[..., None]:
        def run(recs, rows, start, rng, maxlev, outcome) -> None:
            SL.advance_orig(recs, rows, start, rng, maxlev, outcome, (q_lo, q_hi, M, t_max),
                            self.h, self.B, self.rec)
        return run

    def cycles(self, starts: np.ndarray, rng: np.ndarray, n_cycles: int, q0: float, q1: float,
               qc: float, t_max: float) -> tuple[np.ndarray, np.ndarray]:
        entries = np.zeros((starts.shape[0], n_cycles, self.width))
        summary = np.zeros((starts.shape[0], 7))
        SL.cycles_orig(starts, rng, (n_cycles, q0, q1, qc, t_max, self.n_burn), self.h,
                       self.B, self.rec, entries, summary)
        return entries, summary


def passage_splitting(system: Any, noise: Any, settings: SplittingSettings, *,
                      threshold: float, start: float | str, low: float, entry: float,
                      burn_in: float = 0.0, parametric: Any = None) -> Result:
    """MFPT of the ORIGINAL system from a start at amplitude ``start`` (energy U(start), phase
    uniform in time on that conservative orbit, xi from its stationary law), or "stationary"
    (the stationary law restricted below the threshold: ``burn_in`` > 0 time units of free
    simulation from the orbit of amplitude ``low``, begun again when it reaches the threshold;
    splitting_lanes.cycles_orig), to the energy
    U(threshold), by the cycle decomposition with levels U(low) < U(entry) < U(threshold)
    (module docstring), the energy as the reaction coordinate. The same seed gives the same
    numbers for any thread count (every path and every clone has its own stream).
    data["mfpt"] = info["mfpt"] = {"value", "stderr", "ci", "level", "replicas",
    "mean_cycle", "mean_warm_up", "warm_up_hits", "p": {...}} (time units)."""
    stationary = start == "stationary"
    if stationary and not burn_in > 0:
        raise ValueError("start 'stationary' needs burn_in > 0 (time units)")
    a0 = low if stationary else start
    if not 0.0 < low < entry < threshold or not 0.0 <= a0 < threshold:
        raise ValueError(f"need 0 < low < entry < threshold and 0 <= start < threshold, got "
                         f"low = {low}, entry = {entry}, threshold = {threshold}, "
                         f"start = {start}")
    s = settings
    dyn = _Original(system, noise, s.dt, burn_in if stationary else 0.0, parametric)
    q0, q1, qc = dyn.U(low), dyn.U(entry), dyn.U(threshold)

    def rows(n: int, seed: int, g: int) -> np.ndarray:
        return dyn.starts(a0, n, seed, g)

    rec, det = mfpt_by_cycles(dyn, rows, dyn.q, q0, q1, qc, s)
    info = {"solver": "montecarlo", "method": "splitting", "threshold": threshold,
            "start": start, "burn_in": burn_in if stationary else 0.0, "low": low,
            "entry": entry, "energies": [q0, q1, qc],
            "reaction_coordinate": "energy E = v^2/2 + U(x)", "settings": asdict(s),
            "mfpt": rec, **det, "status": Status.SIMULATED.record()}
    return Result(data={"mfpt": rec}, info=info)

