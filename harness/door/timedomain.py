"""The door's time-domain half: first passage and transients through the solvers.

The original system's first passage (``passage_montecarlo``) and transient law
(``transient_montecarlo``), an averaged model's SDE (``passage_sde``, ``transient_sde``), its
FPK with an absorbing wall (``passage_averaged``, ``transient_averaged``, ``mfpt_averaged``)
and rare events by adaptive multilevel splitting (``passage_splitting``). The stationary half
is ``door.solvers``; neither imports a harness module above the door.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from vifpk.harness.door.solvers import (
    SolverFailure,
    amplitude_density,
    averaged_model,
    boundary,
    fpk_stationary,
    model_label,
    model_period,
    phase_solution,
    solver_failure,
)

from vifpk.core.defaults import FPK_CELLS
from vifpk.core.result import BadInput, Result
from vifpk.core.scene import no_noise


# ------------------------------------------------------- time domain (issue 30): Monte Carlo
@boundary
def time_step(scene: Any, dt: Any = None) -> float:
    """The step of the original system's time-domain runs (first passage, splitting,
    snapshots), the one rule every caller uses (the CLI's plan and price, the doors): ``dt``
    when given, else the scene's montecarlo.dt; "auto" -- a step tuned to a stationary
    target floor, which has no meaning for a first-passage time -- gives the fixed step
    vifpk.core.sections.FIXED_DT."""
    from vifpk.core.sections import FIXED_DT

    h = scene.montecarlo.dt if dt is None else dt
    if h == "auto":
        h = FIXED_DT
    return float(h)


def _passage_settings(scene: Any, *, paths: int, horizon: float, **given: Any) -> Any:
    """montecarlo.PassageSettings: ``given`` (not None) over the scene's [montecarlo] dt (by
    time_step), blocks, seed, threads."""
    from vifpk import montecarlo

    mc = scene.montecarlo
    kw = {k: getattr(mc, k) for k in ("blocks", "seed", "threads")}
    kw.update({k: v for k, v in given.items() if v is not None and k != "dt"})
    kw["dt"] = time_step(scene, given.get("dt"))
    return montecarlo.PassageSettings(paths=paths, horizon=horizon, **kw)


@boundary
def passage_montecarlo(scene: Any, *, threshold: float, start: float | str, horizon: float,
                       paths: int, dt: float | None = None, blocks: int | None = None,
                       seed: int | None = None, threads: int | None = None,
                       burn_in: float | str | None = None, burn_start: float | None = None,
                       progress: bool = True) -> Result:
    """First passage of the original system's energy through U(threshold)
    (``montecarlo.first_passage``): data["fpt"] = {"time", "censored"}, data["start"].
    Unset options come from the scene's [montecarlo] section; for start "stationary" an unset
    burn_in is "auto" (BURN_FACTOR x the relaxation time the Monte Carlo's relaxation pilot
    measures). A run that blows up, or a "stationary" start that cannot be placed below the
    threshold, raises SolverFailure."""
    from vifpk import montecarlo

    if start == "stationary" and burn_in is None:
        burn_in = "auto"
    st = _passage_settings(scene, paths=paths, horizon=horizon, dt=dt, blocks=blocks,
                           seed=seed, threads=threads, burn_in=burn_in, burn_start=burn_start,
                           progress=progress)
    return montecarlo.first_passage(scene.system, scene.noise, st, threshold=threshold,
                                    start=start, parametric=getattr(scene, "parametric", None))


def _start_amplitudes(start: Any, paths: int, seed: int) -> Any:
    """An amplitude, or an array of start amplitudes used as an empirical law: as is when it
    has ``paths`` entries, else resampled with replacement (SeedSequence(seed, spawn_key=
    (2**25,)): the same draw for a seed)."""
    if isinstance(start, str):
        raise BadInput(f"the averaged SDE takes a start amplitude or an array of them, not "
                       f"{start!r}: for 'stationary' pass the original system's "
                       "data['start']['A'] from passage_montecarlo")
    a = np.asarray(start, dtype=float)
    if a.ndim == 0 or a.size == paths:
        return float(a) if a.ndim == 0 else a
    gen = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(1 << 25,)))
    return gen.choice(a.ravel(), size=paths, replace=True)


def _sde_run(scene: Any, model: Any, top: float, dt: float | None, blocks: int | None,
             seed: int | None) -> tuple[Any, float, int, int, dict[str, Any]]:
    """(model, dt, blocks, seed, info): unset dt is the SDE's own rule (tau / STEPS_PER_TAU,
    montecarlo.sde_time.auto_dt, tau on [0, top]: wide, or a wall there shortens tau; the
    scene's step by time_step when tau is not finite: the one rule of the time domain)."""
    from vifpk.montecarlo.sde_time import auto_dt

    m = averaged_model(scene, model)
    mc = scene.montecarlo
    extra: dict[str, Any] = {"model": model_label(model), "dt_mode": "fixed"}
    if dt is None:
        dt, tau = auto_dt(m.drift, m.diffusion, top, time_step(scene))
        extra.update(dt_mode="auto", relaxation_time=tau)
    return m, float(dt), blocks or mc.blocks, mc.seed if seed is None else seed, extra


@boundary
def passage_sde(scene: Any, model: Any, *, threshold: float, start: Any, horizon: float,
                paths: int, dt: float | None = None, blocks: int | None = None,
                seed: int | None = None, progress: bool = True) -> Result:
    """First passage of the averaged SDE of ``model`` (a name or a model object) through
    A = threshold (``montecarlo.sde_time.sde_first_passage``). ``start``: an amplitude, or
    start amplitudes (e.g. the original system's data["start"]["A"] for 'stationary')."""
    from vifpk.montecarlo.sde_time import sde_first_passage


    m, dt, blocks, seed, extra = _sde_run(scene, model, 4.0 * threshold, dt, blocks, seed)
    try:
        res = sde_first_passage(m.drift, m.diffusion, threshold=threshold,
                                start=_start_amplitudes(start, paths, seed), paths=paths,
                                blocks=blocks, dt=dt, horizon=horizon, seed=seed,
                                progress=progress)
    except ValueError as exc:  # coefficients not finite on the table: a numerical failure
        if isinstance(exc, BadInput) or solver_failure(exc) is None:
            raise  # any other ValueError is not the solver's failure (boundary.py)
        raise SolverFailure(f"averaged SDE of {model_label(model)}: {exc}") from None
    res.info.update(extra)
    return res


@boundary
def transient_montecarlo(scene: Any, *, start: float, times: Any, edges: dict[str, Any],
                         paths: int, dt: float | None = None, blocks: int | None = None,
                         seed: int | None = None, threads: int | None = None,
                         progress: bool = True) -> Result:
    """Histograms of A, x1, x2 of the original system at ``times`` from amplitude ``start``
    (``montecarlo.transient.snapshots``); edges: edges_A, edges_x, edges_v."""
    from vifpk.montecarlo.transient import snapshots


    t_end = float(np.max(times)) if np.size(times) else 1.0
    st = _passage_settings(scene, paths=paths, horizon=max(t_end, 1e-300), dt=dt,
                           blocks=blocks, seed=seed, threads=threads, progress=progress)
    return snapshots(scene.system, scene.noise, st, start=start, times=times, edges=edges,
                     parametric=getattr(scene, "parametric", None))


@boundary
def transient_sde(scene: Any, model: Any, *, start: Any, times: Any, edges_A: Any,
                  paths: int, dt: float | None = None, blocks: int | None = None,
                  seed: int | None = None, progress: bool = True) -> Result:
    """The law of A at ``times`` under the averaged SDE of ``model`` from ``start`` (an
    amplitude or start amplitudes) (``montecarlo.sde_time.sde_snapshots``)."""
    from vifpk.montecarlo.sde_time import sde_snapshots


    top = 4.0 * float(np.max(edges_A))
    m, dt, blocks, seed, extra = _sde_run(scene, model, top, dt, blocks, seed)
    try:
        res = sde_snapshots(m.drift, m.diffusion, start=_start_amplitudes(start, paths, seed),
                            times=times, edges_A=edges_A, paths=paths, blocks=blocks, dt=dt,
                            seed=seed, progress=progress)
    except ValueError as exc:  # coefficients not finite on the table: a numerical failure
        if isinstance(exc, BadInput) or solver_failure(exc) is None:
            raise  # any other ValueError is not the solver's failure (boundary.py)
        raise SolverFailure(f"averaged SDE of {model_label(model)}: {exc}") from None
    res.info.update(extra)
    return res


#: levels of the cycle decomposition (montecarlo.splitting) by default: the amplitudes at these
#: quantiles of the stationary amplitude density of the first-order averaged model ("exact"):
#: a cycle from the median down to the lower quartile and back lasts about one relaxation time
SPLITTING_QUANTILES = (0.25, 0.5)


@boundary
def splitting_levels(scene: Any, *, start: float, threshold: float) -> dict[str, Any]:
    """{"low", "entry", "source"}: the default levels of passage_splitting (see
    SPLITTING_QUANTILES), lowered to stay below the threshold when it is that low."""
    d = amplitude_density(scene, "exact")
    h = np.diff(d.A, prepend=d.A[0])
    cdf = np.cumsum(d.p * h)
    cdf /= cdf[-1]
    low, entry = (float(np.interp(q, cdf, d.A)) for q in SPLITTING_QUANTILES)
    source = (f"quantiles {SPLITTING_QUANTILES} of the 'exact' averaged model's stationary "
              "amplitude density")
    if entry >= threshold:
        low, entry = 0.5 * threshold, 0.75 * threshold
        source += f", lowered to 0.5 and 0.75 x the threshold (below {threshold:g})"
    return {"low": low, "entry": entry, "source": source}


#: passage_splitting's default groups and particles (montecarlo.SplittingSettings')
SPLITTING_GROUPS, SPLITTING_PARTICLES = 20, 200
#: what montecarlo.splitting says when every AMS run of a batch went extinct
DIED_OUT = "every AMS run died out"


class SplittingDiedOut(SolverFailure):
    """Splitting found no passage in any group: a numerical failure (exit 3) that more
    particles may cure; ``particles`` the number it had."""

    def __init__(self, message: str, *, particles: int):
        super().__init__(message)
        self.particles = particles


@boundary
def passage_splitting(scene: Any, *, threshold: float, start: float | str,
                      low: float | None = None,
                      entry: float | None = None, groups: int = SPLITTING_GROUPS,
                      particles: int = SPLITTING_PARTICLES,
                      levels: int = 200, kill: int = 0, paths: int | None = None,
                      cycles: int = 25,
                      dt: float | None = None, seed: int | None = None,
                      threads: int | None = None, rel_ci: float = 0.0, budget: float = 0.0,
                      max_groups: int = 400) -> Result:
    """MFPT of the original system from amplitude ``start`` to ``threshold`` by adaptive
    multilevel splitting on the energy and the cycle decomposition (montecarlo.splitting):
    data["mfpt"] = info["mfpt"] = {"value", "stderr", "ci" (Student-t 95% over ``groups``
    independent repetitions), ...}. ``paths`` direct paths of ``cycles`` cycles each give
    the AMS runs their starts: by default 8, or as many as ``particles`` needs (paths x
    cycles >= particles: twice the default particles, 400, died at 8 x 25 = 200 as an internal
    error, issue 45). ``start``: an amplitude or "stationary" (the law below the
    threshold after a burn-in: the scene's montecarlo.burn_in, or for "auto" BURN_FACTOR x the
    exact model's relaxation time; info["burn_in_rule"]). Levels low < entry default to
    splitting_levels; dt, seed
    and threads as passage_montecarlo takes them. rel_ci > 0: batches of ``groups`` groups
    until the interval's half-width is within rel_ci of the value, within ``budget`` seconds
    (info["target"] says whether it was reached)."""
    from vifpk.montecarlo.splitting import SplittingSettings
    from vifpk.montecarlo.splitting import passage_splitting as split

    stationary = start == "stationary"
    burn: dict[str, Any] = {}
    if stationary:  # the free run before the clock starts, as passage_montecarlo's "auto"
        from vifpk.core.defaults import BURN_FACTOR

        if scene.montecarlo.burn_in != "auto":
            burn = {"burn_in": float(scene.montecarlo.burn_in),
                    "rule": "the scene's montecarlo.burn_in"}
        else:
            m = averaged_model(scene, "exact")
            tau = float(fpk_stationary(m.drift, m.diffusion, method="direct").info[
                "relaxation_time"])
            burn = {"burn_in": BURN_FACTOR * tau,
                    "rule": f"BURN_FACTOR x the exact model's relaxation time ({tau:.4g})"}
    chosen = checked_splitting_levels(scene, threshold=threshold, start=start, low=low,
                                      entry=entry)
    st = _passage_settings(scene, paths=1, horizon=1.0, dt=dt, seed=seed, threads=threads)
    if paths is None:  # the AMS runs start from the direct paths' cycle starts: at least one
        # start a particle (montecarlo.cycles.groups_direct); 8 paths at the default particles
        paths = max(8, -(-particles // cycles))
    s = SplittingSettings(groups=groups, particles=particles, kill=kill, levels=levels,
                          dt=float(st.dt), seed=int(st.seed), cycles=cycles, paths=paths,
                          rel_ci=rel_ci, budget=budget, max_groups=max_groups,
                          threads=int(st.threads))
    try:
        res = split(scene.system, scene.noise, s, threshold=float(threshold),
                    start="stationary" if stationary else float(start), low=chosen["low"],
                    entry=chosen["entry"], burn_in=burn.get("burn_in", 0.0),
                    parametric=getattr(scene, "parametric", None))
    except RuntimeError as exc:  # montecarlo.splitting's plain RuntimeError: issue 39, X13
        if DIED_OUT not in str(exc):
            raise
        raise SplittingDiedOut(
            f"splitting: every AMS run died out before reaching Ac = {float(threshold):g} "
            f"(p = 0 in each of {groups} groups of {particles} particles): the passage is too "
            f"rare for {particles} particles; raise particles (--particles, now {particles}) "
            "or lower the threshold", particles=particles) from exc
    info = dict(res.info)
    info["levels_source"] = chosen["source"]
    if burn:
        info["burn_in_rule"] = burn["rule"]
    return Result(data=res.data, info=info)


def checked_splitting_levels(scene: Any, *, threshold: float, start: float | str,
                             low: float | None = None, entry: float | None = None
                             ) -> dict[str, Any]:
    """{"low", "entry", "source"}: the levels passage_splitting will use (given, else
    splitting_levels'), checked (BadInput naming them, _splitting_levels_ok). Cheap (the exact
    model's stationary density), so a workflow asks it before its first progress line."""
    chosen = {"low": low, "entry": entry, "source": "given"}
    if low is None or entry is None:
        auto = splitting_levels(scene, start=0.0 if start == "stationary" else float(start),
                                threshold=float(threshold))
        chosen = {"low": low if low is not None else auto["low"],
                  "entry": entry if entry is not None else auto["entry"],
                  "source": auto["source"]}
    _splitting_levels_ok(chosen, threshold, start)
    return chosen


def _splitting_levels_ok(chosen: dict[str, Any], threshold: float, start: float | str) -> None:
    """0 < low < entry < threshold and, from an amplitude, 0 < start < entry: a caller's
    mistake is BadInput (one line naming the levels), not a numerical failure (issue 39, A25,
    A29); montecarlo.splitting checks the same and raises ValueError."""
    low, entry = chosen["low"], chosen["entry"]
    for name, v in (("low", low), ("entry", entry)):
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise BadInput(f"passage_splitting {name} = {v!r}: not a finite amplitude; "
                           "allowed: 0 < low < entry < threshold")
    how = "given" if chosen["source"] == "given" else f"from {chosen['source']}"
    if not 0.0 < low < entry < float(threshold):
        raise BadInput(f"passage_splitting low = {low:g}, entry = {entry:g} ({how}): allowed: "
                       f"0 < low < entry < threshold = {float(threshold):g}")
    if start != "stationary" and not 0.0 < float(start) < entry:
        raise BadInput(f"passage_splitting start {float(start):g}: not below the entry level "
                       f"{entry:g} ({how}); allowed: 0 < start < entry (give low below and entry "
                       "above the start, or simulate directly, --method direct: a threshold "
                       "this near the start is within its reach)")


# ------------------------------------------------ time domain (issue 30): averaged models' FPK
def _averaged_coefficients(scene: Any, model: Any) -> Any:
    if no_noise(scene.system):
        raise SolverFailure(no_noise(scene.system))
    return averaged_model(scene, model)


@boundary
def passage_averaged(scene: Any, model: Any, *, threshold: float, start: float | str,
                     cells: int = FPK_CELLS, times: Any = None, t_end: float | None = None,
                     intervals: int = 16, quadrature: dict[str, Any] | None = None) -> Result:
    """First passage of an averaged model's amplitude through ``threshold`` (p = 0 there,
    zero flux at A = 0), from an amplitude or "stationary" (the model's own stationary p(A)
    restricted to A < threshold, normalised there).

    data["R"] = {"t", "R"}, data["fpt_density"] = {"t", "p"} (fpk.reliability, ``cells``
    cells), data["mfpt_curve"] = {"A", "T"} (T(A0) for every start on the quadrature's grid);
    info["mfpt"] (the Pontryagin quadrature, fpk.mfpt), info["mfpt_error"] (its two-grid
    estimate), info["mfpt_integral"] (int R dt of the time-stepped FPK), info["decay_rate"].
    ``quadrature``: fpk.mfpt's record for this model, threshold and start when already
    computed (mfpt_averaged, to price the run): used as is, not computed again.
    A threshold or start out of range raises BadInput; a numerical failure SolverFailure."""
    from vifpk import fpk

    m = _averaged_coefficients(scene, model)
    try:
        q = quadrature if quadrature is not None else fpk.mfpt(
            m.drift, m.diffusion, threshold=threshold, start=start, intervals=intervals)
        r = fpk.reliability(m.drift, m.diffusion, threshold=threshold, start=start,
                            cells=cells, times=times, t_end=t_end)
    except ValueError as exc:
        raise BadInput(str(exc)) from None
    info = dict(r.info)
    info.update(model=model_label(model), mfpt=q["value"], mfpt_error=q["error_estimate"],
                quadrature={k: q[k] for k in ("value_coarse", "order", "intervals", "nodes",
                                              "evaluations", "seconds", "method")},
                variable="the model's amplitude A (energy U(A)); a model that observes its "
                         "energy through a spread (observes) is taken at its own amplitude")
    info["diagnostics"] = dict(info["diagnostics"],
                               routes_gap=abs(q["value"] - r.info["mfpt_integral"]))
    data = dict(r.data, mfpt_curve=q["curve"])
    return Result(data=data, info=info)


@boundary
def transient_averaged(scene: Any, model: Any, *, start: float, times: Any,
                       cells: int = FPK_CELLS, phase: bool = True) -> Result:
    """The law of an averaged model's amplitude at ``times`` from a start at amplitude A0
    (fpk.transient on [0, hi], hi from the model's stationary density (fpk.choose_domain,
    tail 1e-10) and at least A0 + 10 widths).

    The start is a Gaussian of standard deviation w = h (one cell, h = hi / cells) at A0,
    clipped to the domain: the narrowest start the grid still samples (its cell masses sum to
    1 within 1e-8 for sd = h), so the point start of the Monte Carlo is matched up to w. Its
    width adds w^2 to the variance of a snapshot (widths add in quadrature while the law is
    locally a diffusion with smooth coefficients), a relative error of order
    w^2 / (2 D(A0) t) at time t (D = sigma^2 / 2) -- the same order as the scheme's own
    O(h^2 / (2 D t)) error on a law that narrow. info["start_width"] = w and
    info["start_width_time"] = w^2 / (2 D(A0)): snapshots earlier than 100 times it carry
    more than ~1% of relative variance error from the start (raise ``cells`` for them).
    ``phase``: also each snapshot mapped to x1, x2 (uniform-in-time phase along each orbit,
    as the averaged model assumes): data["snapshots"]["x1"], ["x2"] = {"x", "p": [n, points]}.
    """
    from vifpk import fpk

    m = _averaged_coefficients(scene, model)
    t = np.asarray(times, dtype=float)
    if not (math.isfinite(start) and start > 0):
        raise BadInput(f"start must be a positive amplitude, got {start!r}")
    if t.size == 0 or not np.all(np.isfinite(t)) or np.any(t <= 0):
        raise BadInput("times must be positive and finite")
    _, hi, _ = fpk.choose_domain(m.drift, m.diffusion)
    hi = max(hi, start + 10.0 * hi / cells)
    width = hi / cells
    a0 = float(start)

    def p0(A: Any) -> Any:
        return np.exp(-0.5 * ((np.asarray(A) - a0) / width) ** 2)

    res = fpk.transient(m.drift, m.diffusion, p0=p0, times=list(t), cells=cells, lo=0.0,
                        hi=hi)
    d0 = 0.5 * float(np.asarray(m.diffusion(np.array([a0])))[0])
    info = dict(res.info, model=model_label(model), start=a0, start_width=width,
                start_width_time=width**2 / (2.0 * d0),
                start_note="Gaussian of sd one cell at A0 (the discrete point start)")
    data = dict(res.data)
    if phase:
        snaps = dict(data["snapshots"])
        period, _ = model_period(scene, m)
        x1, x2 = [], []
        for p in snaps["p"]:
            rec = {"x": snaps["x"], "p": p}
            cells_rec = Result(data={"A_cells": rec, "A": rec}, info={})
            ph, _ = phase_solution(scene, cells_rec, period)
            x1.append(ph["x1"]), x2.append(ph["x2"])
        snaps["x1"] = {"x": x1[0]["x"], "p": np.array([d["p"] for d in x1])}
        snaps["x2"] = {"x": x2[0]["x"], "p": np.array([d["p"] for d in x2])}
        data["snapshots"] = snaps
    return Result(data=data, info=info)


@boundary
def mfpt_averaged(scene: Any, model: Any, *, threshold: float, start: float | str) -> dict:
    """An averaged model's MFPT alone (fpk.mfpt, the Pontryagin quadrature; no R(t)): what
    `vifpk passage --method splitting` compares the original system's against."""
    from vifpk import fpk

    m = _averaged_coefficients(scene, model)
    return fpk.mfpt(m.drift, m.diffusion, threshold=threshold, start=start)
