"""Run the solvers a scene asks for: the door between the harness and the solvers (its
stationary half; door/timedomain.py is the other).

The door is the only harness package that imports ``averaging``, ``fpk`` or ``montecarlo``
(enforced by tests/test_architecture.py); check, bifurcation, figures, workprecision, testing
and the CLI reach every solver through the functions below. The solvers never import the
harness or each other: data flows one way, scene -> solver -> record -> comparison. Every
door function is a :func:`boundary`: a solver's failure leaves it as :class:`SolverFailure`,
the one place exceptions are mapped.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from vifpk.harness.door.boundary import (  # noqa: F401 - SolverFailure: callers import it here
    SolverFailure,
    boundary,
    solver_failure,
)

from vifpk.core import registry
from vifpk.core.defaults import FPK_CELLS, REFERENCE_CELLS
from vifpk.core.energy import tail_note
from vifpk.core.guard import GuardedModel, PluginError
from vifpk.core.registry import CLOSED_FORM, one_of
from vifpk.core.result import Result, Status
from vifpk.core.scene import no_noise


@dataclass(kw_only=True)
class MonteCarloRun:
    """What a run of the original system is handed beyond its scene, passed explicitly (as
    py-pde passes a tracker) from the command or the sweep point through the workflow's
    signature to :func:`montecarlo_solution`: no hidden context, so a thread-pool executor
    cannot lose it (issue 38). Mutable on purpose: the door writes ``state`` after the run.

    ``cost_limit``: (seconds allowed, path-steps per second on every core the run uses), the
    cost guard of the command (harness.request.cost.run_cost_limit): a run with an automatic
    burn-in is priced again once its relaxation pilot has measured the burn-in, and stops
    before the burn-in above it (CostRefused, exit 2); None: no limit.
    ``keep_state``: continue from ``resume`` (the bytes of a montecarlo.checkpoint.Checkpoint;
    None: a new run) toward the scene's floor, and leave where it stopped in ``state`` (bytes)
    once it has run; False: a plain run, ``state`` stays None."""

    cost_limit: tuple[float, float] | None = None
    keep_state: bool = False
    resume: bytes | None = None
    state: bytes | None = None


@boundary
def run_solver(scene: Any, solver: str, *, model: str = "paper", grid: int | None = None,
               **options: Any) -> Any:
    """Run one solver on a concrete scene and return its Result(data, info).

    ``--solver averaging`` of a model with no closed form (a plugin that gives only drift
    and diffusion) is :func:`closed_form`'s FPK direct solve, and its info says so."""

    one_of("solver", solver, registry.solver_names())
    if solver == CLOSED_FORM:
        return closed_form(scene, model=model, **options)
    if solver == registry.ORIGINAL:
        return montecarlo_solution(scene, **options)
    if solver == registry.ORIGINAL_FPK:
        from vifpk.harness.door.original import original_fpk_solution

        return original_fpk_solution(scene, cells=grid, **options)
    return model_solution(scene, model=model, solver=solver, cells=grid or FPK_CELLS,
                          **options)


# ----------------------------------------------------------------------- averaged models
@boundary
def closed_form(scene: Any, *, model: Any, tail_mass: bool = True, **options: Any) -> Any:
    """The averaged model's stationary densities: its closed form (``averaging.solve``) when
    the model gives one (``log_stationary_parts`` and ``period``), else the FPK direct solve of
    its drift and diffusion on REFERENCE_CELLS cells, mapped to phase space
    (``info["closed_form"]`` is False and ``info["method"]`` says which). ``model``: a
    registered name or a model object; ``tail_mass=False`` skips the closed form's measurement
    of the mass beyond its grid. A scene with no stationary density raises SolverFailure."""
    from vifpk import averaging

    m = averaged_model(scene, model, **options)
    if averaging.has_closed_form(m):
        with _blamed(m), _heavy_tail(scene):
            res = averaging.solve(scene, model=m, tail_mass=tail_mass)
        res.info.update(model=model_label(model), closed_form=True)
        if said := tail_note(scene.system, getattr(scene, "parametric", None)):  # E[H], metastable
            res.info["warnings"] = [*res.info.get("warnings", ()), said]
        return res
    res = fpk_solution(scene, model=m, cells=REFERENCE_CELLS, method="direct")
    res.info.update(model=model_label(model), closed_form=False,
                    method=f"FPK direct solve, {REFERENCE_CELLS} cells (the model gives no "
                           "closed form: no log_stationary_parts/period)")
    return res


@contextmanager
def _heavy_tail(scene: Any) -> Iterator[None]:
    """A parametric scene whose law exists with a power-law tail E^-kappa (vifpk.core.energy)
    that the closed form's grid cannot hold (it asks for a fall by e^60 before A = 1e4): say
    so, instead of "no stationary density"; where no law exists, say which noise outgrows
    the losses (energy_balance's words)."""
    from vifpk import averaging
    from vifpk.core.energy import parametric_tail
    from vifpk.core.scene import energy_balance

    try:
        yield
    except averaging.NoStationaryDensity as exc:
        par = getattr(scene, "parametric", None)
        tail = parametric_tail(scene.system, par)
        if tail is None or not isinstance(exc, averaging.DensityDoesNotDecay):
            raise
        if not tail.normalisable:
            raise averaging.NoStationaryDensity(
                f"{exc}: {energy_balance(scene.system, par).text}") from exc
        raise averaging.NoStationaryDensity(
            f"the amplitude density decays too slowly for the closed form's grid: the "
            f"parametric noise gives the averaged law a power-law tail p(E) ~ "
            f"E^-{tail.kappa:.3g} (a stationary law exists, kappa > 1"
            f"{'' if tail.mean_finite else ', but its mean energy is infinite'}), which does "
            "not fall by e^60 before A = 1e4") from exc


def model_label(model: Any) -> str:
    """A model's name in outputs: the registered name, or the class name of an object."""
    return model if isinstance(model, str) else type(model).__name__


@boundary
def averaged_model(scene: Any, model: Any, **options: Any) -> Any:
    """The averaged model named ``model`` (any registered name, vifpk.core.registry) or a
    model object itself: something with drift(A), diffusion(A) and maybe period(A)."""
    from vifpk import averaging

    if isinstance(model, str):
        return averaging.build_model(scene, model, **options)
    for attr in ("drift", "diffusion"):
        if not callable(getattr(model, attr, None)):
            raise TypeError(f"model must be a registered name or provide {attr}(A) "
                            "(the averaged-model protocol, docs/testing.md)")
    return model


@boundary
def model_period(scene: Any, m: Any) -> tuple[Any, str]:
    """(T(A), where it comes from): the model's ``period`` if it gives one, else the period of
    the scene's exact orbit (the averaged-model protocol's default, docs/testing.md)."""
    if callable(getattr(m, "period", None)):
        return m.period, "model"
    s = scene.system

    def T(A: Any) -> Any:
        return orbit_period(A, s.restoring_law)

    return T, "exact orbit (the model gives no period)"


@boundary
def amplitude_density(scene: Any, model: Any, **options: Any) -> Any:
    """p(A) alone (``averaging.stationary.AmplitudeDensity``: fields A, p, log_h) of the model
    named ``model`` (or a model object), on the scene's [averaging] grid settings; a model with
    no closed form gets it from the FPK direct solve (REFERENCE_CELLS cells)."""
    from vifpk.averaging.stationary import AmplitudeDensity
    from vifpk.averaging.stationary import amplitude_density as density

    from vifpk import averaging

    m = averaged_model(scene, model, **options)
    with _blamed(m):
        if averaging.has_closed_form(m):
            return density(m, points=scene.averaging.points, tail=scene.averaging.tail)
        res = fpk_stationary(m.drift, m.diffusion, cells=REFERENCE_CELLS, method="direct")
    A, p = res.data["A_cells"]["x"], res.data["A_cells"]["p"]
    s = scene.system
    T, _ = model_period(scene, m)
    with np.errstate(divide="ignore"):
        log_p = np.log(p)
    log_h = log_p - np.log(restoring_force(A, s.restoring_law)) - np.log(T(A))
    return AmplitudeDensity(A=A, p=p, log_p=log_p, log_h=log_h,
                            tail_mass=float(res.info["diagnostics"].get("tail_mass", 0.0)),
                            scans=0)


@boundary
def orbit_period(A: Any, restoring: tuple[float, ...]) -> Any:
    """T(A) of the exact orbit of amplitude A of the spring g = k1 x + k3 x^3 + ...
    (``restoring`` = (k1, k3, ...): System.restoring_law; ``averaging.geometry.period_k``)."""
    from vifpk.averaging.geometry import period_k

    return period_k(A, tuple(restoring))


@boundary
def restoring_force(A: Any, restoring: tuple[float, ...]) -> Any:
    """g(A) = k1 A + k3 A^3 + ... (``averaging.geometry.restoring_k``)."""
    from vifpk.averaging.geometry import restoring_k

    return restoring_k(A, tuple(restoring))


@boundary
def potential_energy(scene: Any, A: Any) -> Any:
    """U(A) of the scene's restoring law (``averaging.geometry.potential_k``): the energy of
    the conservative orbit of amplitude A, which a threshold Ac stands for."""
    from vifpk.averaging.geometry import potential_k

    return potential_k(A, tuple(scene.system.restoring_law))


@boundary
def energy_rates(scene: Any, A: float) -> dict[str, float]:
    """The exact orbit's energy rates by effect at amplitude A (``averaging.exact``)."""
    from vifpk.averaging.exact import energy_rates as rates

    return rates(scene, A)


@boundary
def validity(scene: Any) -> dict[str, Any]:
    """How far the scene is from the averaging limits over the bulk of p(E)
    (``averaging.validity``: band alpha1 / Omega, wall delta / E, noise sigma_E^2 T / E^2)."""
    from vifpk.averaging.validity import validity as numbers

    return numbers(scene)


# ----------------------------------------------------------------------------- FPK
@boundary
def fpk_stationary(drift: Any, diffusion: Any, **options: Any) -> Any:
    """``fpk.stationary`` on any drift m(A) and diffusion sigma^2(A) (cells, method, ...)."""
    from vifpk import fpk

    return fpk.stationary(drift, diffusion, **options)


@boundary
def fpk_solution(scene: Any, *, model: Any, cells: int, method: str = "direct",
                 **options: Any) -> Result:
    """vifpk's FPK on the averaged model's m and sigma^2 (``fpk.stationary``, ``method``
    "direct" or "stepping"), mapped to phase space like the closed form (:func:`_phase_result`)."""
    from vifpk import fpk

    _require_noise(scene)
    m = averaged_model(scene, model, **options)
    with _blamed(m):
        out = fpk.stationary(m.drift, m.diffusion, cells=cells, method=method)
    return _phase_result(scene, m, model, out)


@boundary
def model_solution(scene: Any, *, model: Any, solver: str, cells: int, **options: Any
                   ) -> Result:
    """The registered FPK solver ``solver`` (vifpk.core.registry.solver; vifpk's own ``fpk``
    or a plugin's) on the averaged model's m and sigma^2 with ``cells`` cells, mapped to
    phase space like the closed form (:func:`_phase_result`). A plugin's failure, or a density
    that is not finite, non-negative and of mass 1, is a PluginError naming it."""
    _require_noise(scene)
    spec, entry = registry.solver(solver)
    m = averaged_model(scene, model, **options)
    if entry.builtin:
        with _blamed(m):
            out = spec.stationary(m.drift, m.diffusion, cells=cells)
    else:
        out = _plugin_stationary(spec, entry, m, cells)
    return _phase_result(scene, m, model, _as_result(out, entry))


@contextmanager
def _blamed(m: Any) -> Iterator[None]:
    """A solver's failure on a plugin model's drift and diffusion (GuardedModel) is named as
    the plugin's (issue 39, G08: a drift with no stationary law, e.g. m(A) > 0 for large A,
    read "the stationary density does not decay up to A = 10000" with no plugin named): a
    PluginError naming it, the solver's reason kept. vifpk's own models are not touched."""
    if not isinstance(m, GuardedModel):
        yield
        return
    try:
        yield
    except Exception as exc:
        mapped = solver_failure(exc)
        if mapped is None:
            raise
        raise PluginError(f"{m.plugin_label}: no stationary law was found for its drift and "
                          f"diffusion ({mapped})", m.plugin_name) from exc


def _require_noise(scene: Any) -> None:
    from vifpk import averaging

    if no_noise(scene.system):
        raise averaging.NoStationaryDensity(no_noise(scene.system))


def _plugin_stationary(spec: Any, entry: Any, m: Any, cells: int) -> Any:
    """A plugin solver's ``stationary``; what it raises is a PluginError naming it."""
    from vifpk.core.guard import describe, source_of

    try:
        return spec.stationary(m.drift, m.diffusion, cells=cells)
    except (KeyboardInterrupt, GeneratorExit, PluginError):
        raise
    except BaseException as exc:  # noqa: BLE001 - the plugin's own failure, named
        src = source_of(entry.value.partition(":")[0].strip())
        raise PluginError(f"solver plugin {entry.name!r} (from {entry.distribution}): "
                          f"stationary(drift, diffusion) {describe(exc, src)}") from exc


#: how far a solver's density may be from mass 1 on its own grid (trapezoid rule) before the
#: door refuses it: a normalisation bug, not a discretisation error (those are what the check
#: measures, and they are below 1e-2 at any usable resolution)
MASS_TOLERANCE = 1e-2


def _as_result(out: Any, entry: Any) -> Result:
    """A solver's output as a Result with data ``A`` and ``A_cells`` (``{"x", "p"}``): a
    Result passes as it is; a pair (A, p) is checked (increasing finite A > 0; p finite,
    >= 0, of mass 1 within MASS_TOLERANCE) and renormalised to mass 1 exactly."""
    if isinstance(out, Result):
        return out
    where = f"solver plugin {entry.name!r} (from {entry.distribution})"
    try:
        A, p = (np.asarray(a, dtype=float) for a in out)
    except (TypeError, ValueError):
        raise PluginError(f"{where}: stationary() returned {type(out).__name__}; it must "
                          "return a pair (A, p) of arrays or a Result") from None
    if A.ndim != 1 or A.shape != p.shape or A.size < 4:
        raise PluginError(f"{where}: stationary() returned A and p of shapes {A.shape} and "
                          f"{p.shape}; they must be one-dimensional, of one length >= 4")
    if not (np.all(np.isfinite(A)) and np.all(np.diff(A) > 0) and A[0] >= 0):
        raise PluginError(f"{where}: stationary() returned cell centres A that are not "
                          "finite, non-negative and increasing")
    if not (np.all(np.isfinite(p)) and np.all(p >= 0)):
        raise PluginError(f"{where}: stationary() returned a density p that is not finite "
                          "and non-negative")
    mass = float(np.trapezoid(p, A))
    if not abs(mass - 1.0) <= MASS_TOLERANCE:
        raise PluginError(f"{where}: stationary() returned a density of mass {mass:.6g} on "
                          f"its grid; it must be 1 within {MASS_TOLERANCE}")
    rec = {"x": A, "p": p / mass}
    info = {"solver": entry.name, "method": "plugin", "grid": {"cells": int(A.size),
            "A_min": float(A[0]), "A_max": float(A[-1])},
            "diagnostics": {"mass_before_normalisation": mass},
            "status": Status.DENSITY.record()}
    return Result(data={"A": rec, "A_cells": rec}, info=info)


def _phase_result(scene: Any, m: Any, model: Any, res: Any) -> Result:
    """A stationary p(A) of model ``m`` (a solver's Result) mapped to phase space like the
    closed form, with the model's period or the exact orbit's (``info["period"]`` says which);
    an observing model's (``observes``) p(A) is first mapped to the observed energy."""
    if getattr(m, "observes", False):  # the observed energy, as the closed form
        from vifpk.averaging.corrected import observed_density

        obs = {}
        for key in ("A", "A_cells"):
            x, p = observed_density(m, res.data[key]["x"], res.data[key]["p"])
            obs[key] = {"x": x, "p": p}
        res = res._replace(data=dict(res.data, **obs))
    period, period_from = model_period(scene, m)
    data, raw_mass = phase_solution(scene, res, period)
    info = dict(res.info)
    info["model"] = model_label(model)
    info["period"] = period_from
    xa, pa = data["A"]["x"], data["A"]["p"]
    mean = float(np.trapezoid(xa * pa, xa))
    info["summary"] = {"mean": mean, "mode": float(xa[int(np.argmax(pa))]),
                       "std": float(np.sqrt(max(np.trapezoid((xa - mean) ** 2 * pa, xa), 0)))}
    info["diagnostics"] = dict(info.get("diagnostics", {}),
                               phase_mass_before_normalisation=raw_mass)
    return res._replace(data=data, info=info)


@boundary
def phase_solution(scene: Any, res: Any, period: Any) -> tuple[dict[str, Any], dict]:
    """An FPK result's p(A) mapped to p(E), p(x1, x2), p(x1), p(x2) as for the closed form,
    with p(y, y') = p_A / (g T); ``period`` gives T(A). Returns (data, raw masses)."""
    from vifpk.averaging.geometry import restoring_k
    from vifpk.averaging.phase import phase_densities
    from vifpk.averaging.walls import phase_walls

    s = scene.system
    k = tuple(s.restoring_law)
    A, p = res.data["A_cells"]["x"], res.data["A_cells"]["p"]
    log_T = np.log(period(A))
    log_h = np.log(np.maximum(p, 1e-300)) - np.log(restoring_k(A, k)) - log_T
    ph = phase_densities(A, log_h, log_T, restoring=k, **phase_walls(s),
                         points=scene.averaging.phase_points)
    data = {"A": res.data["A"], "E": {"x": ph.E, "p": ph.p_E}, "x1": {"x": ph.x1, "p": ph.p_x1},
            "x2": {"x": ph.x2, "p": ph.p_x2},
            "joint": {"x1": ph.x1, "x2": ph.x2, "p": ph.joint}}
    return data, ph.raw_mass


@boundary
def montecarlo_solution(scene: Any, *, progress: bool = True, run: MonteCarloRun | None = None,
                        **edges: Any) -> Result:
    """The Monte Carlo of the original system with the scene's settings and observables.

    ``run``: its cost limit and checkpoint (:class:`MonteCarloRun`; None: neither).

    ``edges``: optional histogram edges (``edges_A``, ``edges_x``, ``edges_v``); by default
    the Monte Carlo picks its ranges from a pilot run, independently of the other solvers.
    """
    import dataclasses
    import math

    from vifpk import montecarlo

    if no_noise(scene.system):
        raise SolverFailure(no_noise(scene.system))
    limit = run.cost_limit if run is not None else None
    settings = montecarlo.Settings(**dataclasses.asdict(scene.montecarlo),
                                   observables=scene.observables.names(), progress=progress,
                                   edges=edges,
                                   max_path_steps=limit[0] * limit[1] if limit else math.inf)
    keep = run is not None and run.keep_state
    if keep:
        settings = dataclasses.replace(settings, resume=run.resume, keep_state=True)
    res = montecarlo.simulate(scene.system, scene.noise, settings,
                              parametric=getattr(scene, "parametric", None))
    info = dict(res.info)
    if keep:
        run.state = info.pop("checkpoint").to_bytes()
    mom = info.get("moments", {}).get("A", {}).get("mean")
    if mom is not None:
        info["summary"] = {"mean": mom["value"], "mean_err": mom["err"]}
    return res._replace(info=info)


@boundary
def averaged_sde_solution(scene: Any, model: Any, *, edges: dict[str, Any], seed: int,
                          phase: bool = False, **settings: Any) -> Any:
    """Monte Carlo of the averaged amplitude SDE of ``model`` (a name or a model object).

    The run settings (paths, blocks, dt, time, burn_in, sample_every) are the scene's
    [montecarlo] ones unless given in ``settings`` (e.g. the resolved dt of a run of the
    original system). ``edges``: ``edges_A`` (and ``edges_x``, ``edges_v`` with ``phase``:
    x1, x2 from time-uniform points of each sampled orbit). On ``montecarlo.threads``."""
    from vifpk.montecarlo.averaged_sde import simulate_sde

    mc = scene.montecarlo
    keys = ("paths", "blocks", "dt", "time", "burn_in", "sample_every")
    unknown = set(settings) - set(keys)
    if unknown:
        raise ValueError(f"unknown averaged-SDE settings {sorted(unknown)}; allowed: {keys}")
    kw = {k: settings.get(k, getattr(mc, k)) for k in keys}
    m = averaged_model(scene, model)
    s = scene.system
    # the orbit as the system moves on it: the paper's wall folds it (x1 = |y|), other walls
    # cut it (a lower wall at its ``at`` <= 0, an upper one at ``at`` >= 0)
    at = {w.side: float(w.at) for w in s.walls}
    extra = ({"restoring": tuple(s.restoring_law), "barrier": s.barrier,
              "lower": at.get("lower", -math.inf), "upper": at.get("upper", math.inf),
              "edges_x": edges["edges_x"], "edges_v": edges["edges_v"]} if phase else None)
    observe = ({"sd": m.observation_sd, "restoring": tuple(s.restoring_law)}
               if getattr(m, "observes", False) else None)
    return simulate_sde(m.drift, m.diffusion, edges=edges["edges_A"], paths=kw["paths"],
                        blocks=kw["blocks"], dt=kw["dt"], time_=kw["time"],
                        burn_in=kw["burn_in"], sample_every=kw["sample_every"], seed=seed,
                        phase=extra, observe=observe, threads=int(mc.threads))


@boundary
def montecarlo_plan(scene: Any) -> Any:
    """What the Monte Carlo would do with the scene's settings, before running it
    (``montecarlo.plan``: the time step, the sampling interval, the sampled time, the nearest
    times it samples exactly, the path-steps including the pilots'), as a ``montecarlo.Plan``."""
    from vifpk import montecarlo

    return montecarlo.plan(scene.system, scene.noise, scene.montecarlo)


def solution_record(scene: Any, solver: str, model: str | None, result: Any, *,
                    joint: bool = False, provenance: dict[str, Any] | None = None
                    ) -> dict[str, Any]:
    """The public JSON contract of ``vifpk solve``::

        {"scene": {...}, "solver": ..., "model": ..., "pdf": {"A": {"x", "p"[, "edges", "err"]},
         "x1": {...}, "x2": {...}[, "E", "joint"]}, "info": {..., "provenance": {...}}}

    ``provenance``: the run's block (vifpk/core/provenance.py), stored as ``info.provenance``.
    """
    # the blocks' own densities (p_blocks: the error bars' input) stay out of the contract
    pdf = {k: {f: a for f, a in v.items() if f != "p_blocks"} for k, v in result.data.items()
           if k in ("A", "E", "x1", "x2") or (joint and k == "joint")}
    rec: dict[str, Any] = {"scene": scene.to_dict(), "solver": solver}
    if model is not None:
        rec["model"] = model
    rec["pdf"] = pdf
    rec["info"] = result.info if provenance is None else dict(result.info, provenance=provenance)
    return rec
