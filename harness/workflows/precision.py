"""Time-domain runs that reach a stated precision (issue 39 item 5): the original system's paths
grown in units until the relative standard error of the quantity asked for -- the MFPT
(``vifpk passage``) or the relaxation time (``vifpk transient``) -- is at most a target, or a
budget is reached; and the rule that says when a model's error is an error at all.

**Units and seeds.** The paths come in units of U paths (the first run's: ``--paths`` is not
given, so U is the scene's montecarlo.paths). Unit 0 is seeded with the root seed S itself, so
that it is exactly the run of U paths a fixed-paths command makes; unit k >= 1 with the
128-bit integer of the words ``numpy.random.SeedSequence(S, spawn_key=(UNIT_KEY, k))
.generate_state(4, uint32)`` (:func:`unit_seed`). Each unit is one Monte Carlo call; the
estimate after K units pools units 0..K-1, so the result for a seed does not depend on when
the run stopped: a run that stopped at K units holds the same paths as the first K units of a
longer one.

**Growth.** After each batch the needed paths are predicted from SE ~ 1/sqrt(N):
N_needed = N (rse / target)^2 x GROWTH_MARGIN; the next batch brings N to that many, in whole
units, at least one more unit and at most GROWTH_MAX x N (a poor early estimate of the spread
cannot send the run far), and never past the cap. The run stops when

- ``target met``: the relative standard error is at most the target;
- ``paths cap``: N reached ``max_paths`` (default MAX_PATHS_FACTOR x U);
- ``budget``: the units' path-steps so far plus the next batch's (at the units' path-steps a
  path), at BUDGET_STEPS_PER_SECOND (one core at cost.MC_STEPS_PER_CORE), would pass the
  scene's montecarlo.budget seconds (0: no limit). Path-steps, not wall seconds: the stop is
  the same for a seed whatever the machine, its load, numba's cache or the executor;
- ``misfit`` (relaxation time only): the fit's error bar is widened by sqrt(chi2/dof) (the
  Birge ratio: the mean amplitude need not decay with one rate); once chi2/dof is significant
  (above its MISFIT_LEVEL = 99% quantile under a correct model, chi2.ppf(0.99, dof) / dof: 4.6
  at dof 2, 6.6 at dof 1; :func:`significant_misfit`) and the noise part alone is at the
  target, more paths shrink the noise but chi2/dof grows as N, so the widened bar stays: more
  paths cannot meet the target (give snapshot times around the relaxation time). A chi2/dof
  above 1 but within noise does not stop the run: the widened bar still shrinks as 1/sqrt(N);
- ``not measured``: the quantity is not an estimate (every path censored, no fit): more paths
  of the same question do not make it one.

**The verdict rule** (:func:`model_error_class`, docs/passage.md "Verdicts"): a relative model
error e with its 1-sigma error bar s is a model error only when |e| >= ERROR_BAR_FACTOR x s
(two error bars: about 95% two-sided); otherwise it is ``within the error bar`` and no class
is given. Above it, the class is by |e|: ``small`` below MFPT_SMALL, ``moderate`` below
MFPT_LARGE, ``large`` above (passage.py's thresholds for the MFPT, used for the relaxation time
alike).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from vifpk.harness.request.cost import MC_STEPS_PER_CORE

# The defaults (harness/request/timedomain.py) and why: REL_SE_MFPT (0.045) is the largest target
# at which a model error of MFPT_SMALL (10%, the small/moderate boundary) lies 2 error bars
# from zero on either side: the error bar of e = T_M / T_MC - 1 is (1 + e) x rse, so at
# e = +10% it is 1.1 rse, and 2 x 1.1 rse <= 0.1 needs rse <= 0.1 / 2.2 = 0.0455 (at 0.05 a
# +10% error was only 1.8 bars); the scene's 1024 paths meet it for a near-exponential FPT
# (1/sqrt(1024) = 3%). REL_SE_RELAXATION (0.045), the same reasoning; on paper-base from 0.2
# at times 20,50,100,200 the scene's 1024 paths give 9-14% over 4 seeds and the fit's misfit
# limits it near 7% from 4096 paths on (docs/passage.md, "Precision"). MAX_PATHS_FACTOR (16):
# the paths cap is 16 units (16384 paths at the scene's 1024).
GROWTH_MARGIN = 1.1  # 10% more paths than the 1/sqrt(N) law predicts
GROWTH_MAX = 4.0  # a batch at most brings N to 4 x N
# the budget stop prices path-steps, not wall seconds, so that it is the same for a seed on
# any machine, load, cache state or executor: seconds = path-steps / MC_STEPS_PER_CORE (one
# core at the cost guard's reference speed, faster than every kernel measured: a lower bound
# of the wall time, which is up to ~2.2x it at the measured 69-124 M path-steps/s a core)
BUDGET_STEPS_PER_SECOND = MC_STEPS_PER_CORE
UNIT_KEY = 0x7D5E  # the spawn key's first word of the units k >= 1
MISFIT_LEVEL = 0.99  # the misfit stop: chi2/dof beyond its 99% quantile under a correct fit
SEED_SCHEME = ("unit 0: the root seed S; unit k >= 1: sum_i w_i 2^(32 i) of the words w = "
               f"numpy.random.SeedSequence(S, spawn_key=({UNIT_KEY:#x}, k))"
               ".generate_state(4, uint32)")  # metrics' seed_scheme
ERROR_BAR_FACTOR = 2.0  # a model error is one when |e| >= 2 error bars
MFPT_SMALL = 0.1
MFPT_LARGE = 0.3
WITHIN = "within the error bar"


def unit_seed(seed: int, k: int) -> int:
    """The root seed of unit k (module docstring): S for k = 0, else the 128-bit integer of
    the four 32-bit words of SeedSequence(S, spawn_key=(UNIT_KEY, k)) (its whole entropy
    pool: no two units share a seed by a 32-bit collision)."""
    if k == 0:
        return int(seed)
    w = np.random.SeedSequence(int(seed), spawn_key=(UNIT_KEY, k)).generate_state(4, np.uint32)
    return sum(int(x) << (32 * i) for i, x in enumerate(w))


def next_total(n: int, rse: float, target: float, unit: int, cap: int) -> int:
    """The paths after the next batch (module docstring, "Growth"): whole units, at least one
    more unit, at most GROWTH_MAX x n, at most ``cap``."""
    need = n * (rse / target) ** 2 * GROWTH_MARGIN if target > 0 else math.inf
    need = min(need, GROWTH_MAX * n)
    units = max(math.ceil(need / unit), n // unit + 1)
    return int(min(units * unit, cap))


def model_error_class(value: float, err: float) -> str:
    """``within the error bar`` when |e| < ERROR_BAR_FACTOR x err (or not finite), else
    ``small`` / ``moderate`` / ``large`` by |e| (module docstring)."""
    if not (math.isfinite(value) and math.isfinite(err)) or abs(value) < ERROR_BAR_FACTOR * err:
        return WITHIN
    return "small" if abs(value) < MFPT_SMALL else ("moderate" if abs(value) < MFPT_LARGE
                                                    else "large")


def grow(run_unit: Callable[[int, int], Any], measure: Callable[[list[Any]], dict[str, Any]],
         *, seed: int, unit: int, target: float, max_paths: int, budget: float,
         quantity: str, misfit: bool = False) -> tuple[list[Any], dict[str, Any]]:
    """Run units until the target is met or a budget is reached (module docstring).

    ``run_unit(k, seed_k)``: the Monte Carlo of unit k (``unit`` paths); ``measure(units)``:
    {"value", "err"} of the quantity pooled over the units so far (and "chi2_per_dof" for the
    relaxation fit; "measured": False when it is not an estimate). Returns (the units, the
    ``precision`` record of metrics.json, with ``history``: the paths, value, err (and
    chi2_per_dof) after each batch; its first entry is the fixed-paths run of the seed)."""
    units: list[Any] = []
    history: list[dict[str, Any]] = []  # the estimate after each batch
    spent = 0.0  # path-steps of the units so far (their info["steps"])
    cap = max(unit, (int(max_paths) // unit) * unit)
    n_target = unit
    stopped = ""
    while True:
        while len(units) * unit < n_target:
            units.append(run_unit(len(units), unit_seed(seed, len(units))))
            spent += path_steps(units[-1])
        m = measure(units)
        n = len(units) * unit
        rse = _rse(m)
        history.append({"paths": n, **{k: m.get(k) for k in ("value", "err", "chi2_per_dof")
                                       if m.get(k) is not None}})
        if not m.get("measured", True) or not math.isfinite(rse):
            stopped = "not measured"
            break
        if rse <= target:
            stopped = "target met"
            break
        if misfit and significant_misfit(m) and rse / math.sqrt(m["chi2_per_dof"]) <= target:
            stopped = "misfit"
            break
        if n >= cap:
            stopped = "paths cap"
            break
        nxt = next_total(n, rse, target, unit, cap)
        if budget > 0 and (spent + spent / n * (nxt - n)) / BUDGET_STEPS_PER_SECOND > budget:
            stopped = "budget"
            break
        n_target = nxt
    out = record(quantity=quantity, target=target, rse=_rse(m), paths=n, unit=unit,
                 max_paths=cap, stopped=stopped, budget=budget, units=len(units))
    out["history"] = history
    out["path_steps"] = float(spent)
    return units, out


def path_steps(unit: Any) -> float:
    """A unit's path-steps (its Result's info["steps"]: deterministic for its seed); 0 when
    it has none (then the budget does not price it)."""
    s = getattr(unit, "info", {}).get("steps") if hasattr(unit, "info") else None
    return float(s) if isinstance(s, float | int) and math.isfinite(s) else 0.0


def significant_misfit(m: dict[str, Any]) -> bool:
    """True when the fit's chi2/dof is beyond noise: above chi2.ppf(MISFIT_LEVEL, dof) / dof
    (a correct one-rate model exceeds it with probability 1 - MISFIT_LEVEL = 1%; chi2/dof > 1
    alone happens with probability ~0.3-0.4 at the 1-2 dof of 3-4 snapshot times). ``m``:
    {"chi2_per_dof", "dof"} (dof 1 when not given: the strictest bound)."""
    from scipy.special import chdtri  # the chi2 law's inverse survival function

    c = m.get("chi2_per_dof")
    if c is None or not math.isfinite(c):
        return False
    dof = max(int(m.get("dof") or 1), 1)
    return bool(c > float(chdtri(dof, 1.0 - MISFIT_LEVEL)) / dof)


def _rse(m: dict[str, Any]) -> float:
    v, e = m.get("value"), m.get("err")
    if v is None or e is None or not (isinstance(v, float | int) and v > 0):
        return math.nan
    return float(e) / float(v)


_WHY = {"target met": "target met",
        "paths cap": "budget reached: the paths cap (--max-paths)",
        "budget": "budget reached: the scene's montecarlo.budget (seconds, priced in path-steps "
                  "at cost.MC_STEPS_PER_CORE on one core)",
        "misfit": "target not reachable by more paths: the one-rate fit's misfit (chi2/dof "
                  "beyond its 99% noise quantile) "
                  "dominates the error bar; give snapshot times around the relaxation time",
        "not measured": "not measured: more paths of the same question do not make it an "
                        "estimate",
        "paths given": "no target: exactly these paths (--paths)"}


def record(*, quantity: str, target: float | None, rse: float, paths: int, unit: int,
           max_paths: int | None, stopped: str, budget: float | None = None,
           units: int = 1) -> dict[str, Any]:
    """metrics.json's ``precision`` block (no wall seconds: only ``timings`` and
    ``provenance`` differ between two runs of one command and seed, unless the budget stopped
    it)."""
    return {"quantity": quantity, "target_rel_se": target,
            "achieved_rel_se": rse if math.isfinite(rse) else None, "paths": int(paths),
            "unit_paths": int(unit), "units": int(units), "max_paths": max_paths,
            "budget_seconds": budget, "stopped": stopped,
            "status": _WHY[stopped],
            "seed_scheme": SEED_SCHEME}


def line(p: dict[str, Any]) -> str:
    """One line for the terminal and the report."""
    got = (f"{100 * p['achieved_rel_se']:.1f}%" if p["achieved_rel_se"] is not None
           else "not measured")
    aim = (f" (target {100 * p['target_rel_se']:.1f}%)" if p["target_rel_se"] else "")
    return (f"precision: relative standard error of the {p['quantity']} {got}{aim} with "
            f"{p['paths']} paths: {p['status']}")


def original_system(scene: Any, *, threshold: float, start: float | str,
                    plan: dict[str, Any], burn: dict[str, Any], rel_se: float | None,
                    max_paths: int | None, quiet: bool = True,
                    reference: Any = None) -> tuple[Any, dict[str, Any]]:
    """(the original system's first-passage Result, metrics.json's "precision"): one run of
    plan["paths"] paths (``rel_se`` None), or units of plan["paths"] paths grown until the
    relative standard error of the (restricted) MFPT is at most ``rel_se``
    (:func:`grow`). A "stationary" start measures its burn-in once, in unit 0; the later
    units use it (one burn-in for the whole run). ``reference``: a stand-in for
    timedomain.passage_montecarlo (the testing API's cache)."""
    from vifpk.harness.door import timedomain
    from vifpk.harness.workflows import survival

    quantity = "MFPT of the original system"

    def one(paths: int, seed: int | None, kw: dict[str, Any]) -> Any:
        return (reference or timedomain.passage_montecarlo)(
            scene, threshold=threshold, start=start, horizon=plan["horizon"], paths=paths,
            progress=not quiet, seed=seed, **kw)

    def measure(units: list[Any]) -> dict[str, Any]:
        t, c = _fpt(pool_fpt(units))
        rm = survival.restricted_mean(t, c, plan["horizon"])
        measured = not not_measured(t, c, threshold, plan["horizon"], plan["dt"],
                                    float(rm["stderr"]))
        return {"value": float(rm["value"]), "err": float(rm["stderr"]), "measured": measured}

    if rel_se is None:
        mc = one(plan["paths"], None, burn)
        m = measure([mc])
        rse = m["err"] / m["value"] if m["measured"] and m["value"] > 0 else math.nan
        return mc, record(quantity=quantity, target=None, rse=rse, paths=plan["paths"],
                          unit=plan["paths"], max_paths=None, stopped="paths given")

    done: list[Any] = []  # the units so far (unit 0's burn-in is every later unit's)

    def run_unit(k: int, seed: int) -> Any:
        kw = dict(burn)
        stat = done[0].info.get("stationary") if done else None
        if stat:
            kw.update(burn_in=float(stat["burn_in"]), burn_start=float(stat["burn_start"]))
        r = one(plan["paths"], seed, kw)
        done.append(r)
        return r

    units, prec = grow(run_unit, measure, seed=int(plan["seed"]), unit=int(plan["paths"]),
                       target=rel_se, max_paths=int(max_paths or plan["paths"]),
                       budget=float(scene.montecarlo.budget), quantity=quantity)
    return pool_fpt(units), prec


def unmet(p: dict[str, Any]) -> list[str]:
    """A warning when a target was asked and not met (paths cap, budget, misfit), else []."""
    if p["target_rel_se"] and p["stopped"] in ("paths cap", "budget", "misfit"):
        return ["precision target NOT met: " + line(p).removeprefix("precision: ")]
    return []


def pool_fpt(results: list[Any]) -> Any:
    """One first-passage Result from units (passage_montecarlo's): the passage times, censoring
    flags and starts concatenated; the info of unit 0 with the pooled paths, censored count,
    steps."""
    from vifpk.core.result import Result

    if len(results) == 1:
        return results[0]
    data = {k: {f: np.concatenate([np.asarray(r.data[k][f]) for r in results])
                for f in results[0].data[k]} for k in results[0].data}
    info = dict(results[0].info)
    info.update(_summed(results, "paths", "censored", "steps"), units=_units(results))
    return Result(data=data, info=info)


def pool_snapshots(results: list[Any]) -> Any:
    """One snapshot Result from K units of equal paths (transient_montecarlo's): per
    observable the densities averaged, their standard errors combined as independent
    (sqrt(sum err_k^2) / K), the L1 floors scaled by 1/sqrt(K) (a floor goes as
    1/sqrt(paths)); the second moments from all units' blocks (:func:`_pooled_moment`); the
    info of unit 0 with the pooled paths and steps."""
    from vifpk.core.result import Result

    if len(results) == 1:
        return results[0]
    k = len(results)
    snaps = [r.data["snapshots"] for r in results]
    out: dict[str, Any] = {"t": snaps[0]["t"]}
    for name, first in snaps[0].items():
        if name == "t":
            continue
        if name == "moments":
            out[name] = {m: _pooled_moment([s[name][m] for s in snaps]) for m in first}
            continue
        d = dict(first)
        for key in ("p", "atom_weight"):
            if key in first:
                d[key] = sum(np.asarray(s[name][key], float) for s in snaps) / k
        for key in ("err", "atom_err"):
            if key in first:
                d[key] = np.sqrt(sum(np.asarray(s[name][key], float) ** 2 for s in snaps)) / k
        out[name] = d
    info = dict(results[0].info)
    info.update(_summed(results, "paths", "steps"), units=_units(results))
    if "L1_floor" in info:
        info["L1_floor"] = {o: (np.mean([np.asarray(r.info["L1_floor"][o], float)
                                         for r in results], axis=0) / math.sqrt(k)).tolist()
                            for o in info["L1_floor"]}
    return Result(data={"snapshots": out}, info=info)


def _pooled_moment(parts: list[dict[str, Any]]) -> dict[str, Any]:
    """One moment record (montecarlo.transient's "moments": value, err, blocks[blocks, n])
    from units of equal paths and blocks: the blocks stacked, the value their mean, the
    standard error of the block means std(ddof=1) / sqrt(all blocks), as one run of those
    blocks would give it."""
    blk = np.vstack([np.asarray(p["blocks"], float) for p in parts])
    return {"value": blk.mean(axis=0),
            "err": blk.std(axis=0, ddof=1) / math.sqrt(blk.shape[0]), "blocks": blk}


def _summed(results: list[Any], *keys: str) -> dict[str, Any]:
    """The info counts the units share, summed (those every unit has)."""
    return {k: type(results[0].info[k])(sum(r.info[k] for r in results)) for k in keys
            if all(k in r.info for r in results)}


def _units(results: list[Any]) -> list[dict[str, Any]]:
    return [{"seed": r.info["seed"]["root"] if isinstance(r.info.get("seed"), dict)
             else r.info.get("seed"), "paths": r.info.get("paths")} for r in results]


def _fpt(res: Any) -> tuple[np.ndarray, np.ndarray]:
    f = res.data["fpt"]
    return np.asarray(f["time"], float), np.asarray(f["censored"], bool)


def not_measured(t_mc: np.ndarray, cens: np.ndarray, threshold: float, horizon: float,
                 dt: float, stderr: float) -> str:
    """Why the original system's MFPT is not a measurement ("" when it is): no path passed
    within the horizon (every one censored: the restricted mean is the horizon itself), or
    every passage came within the first time step (the MFPT is below the step's resolution and
    its spread is zero), or the estimate has no error bar at all."""
    done = t_mc[~cens]
    if done.size == 0:
        return (f"no path of the original system passed Ac = {threshold:g} within the horizon "
                f"{horizon:.4g} ({cens.size} of {cens.size} censored): its MFPT is not "
                "measured; raise --horizon")
    if float(np.max(done)) <= dt * (1.0 + 1e-9):
        return (f"every passing path of the original system crossed Ac = {threshold:g} within "
                f"the first time step (dt = {dt:g}): its MFPT is below the step's resolution; "
                "start further below Ac, or give a smaller --dt")
    if not (math.isfinite(stderr) and stderr > 0):
        return "the original system's MFPT has no error bar (no spread in its passage times)"
    return ""
