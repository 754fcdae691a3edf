"""Run the solvers a scene asks for. The only place that knows every solver package."""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

SOLVERS = ("averaging", "fpk", "montecarlo")


class SolverFailure(RuntimeError):
    """A solver could not produce a trustworthy result; the message says why (one line)."""


class Solution(NamedTuple):
    data: dict[str, dict[str, Any]]
    info: dict[str, Any]


def run_solver(scene: Any, solver: str, *, model: str = "paper", grid: int | None = None,
               **options: Any) -> Any:
    """Run one solver on a concrete scene and return its Result(data, info)."""
    import averaging
    import fpk

    try:
        if solver == "averaging":
            return averaging.solve(scene, model=model, **options)
        if solver == "fpk":
            return fpk_solution(scene, model=model, cells=grid or 400, **options)
        if solver == "montecarlo":
            return montecarlo_solution(scene, **options)
    except (averaging.NoStationaryDensity, fpk.FPKFailure) as exc:
        raise SolverFailure(str(exc)) from None
    raise ValueError(f"solver must be one of {SOLVERS}, not {solver!r}")


def fpk_solution(scene: Any, *, model: str, cells: int, method: str = "stepping",
                  **options: Any) -> Solution:
    """FPK on the averaged model's m and sigma^2, mapped to phase space like the closed form."""
    import averaging
    import fpk

    if scene.system.f == 0.0:
        raise averaging.NoStationaryDensity(
            "f = 0: there is no noise, so the averaged FPK has no stationary density")
    m = averaging.build_model(scene, model, **options)
    res = fpk.stationary(m.drift, m.diffusion, cells=cells, method=method)
    data, raw_mass = phase_solution(scene, res, m.period)
    info = dict(res.info)
    info["model"] = model
    xa, pa = data["A"]["x"], data["A"]["p"]
    mean = float(np.trapezoid(xa * pa, xa))
    info["summary"] = {"mean": mean, "mode": float(xa[int(np.argmax(pa))]),
                       "std": float(np.sqrt(max(np.trapezoid((xa - mean) ** 2 * pa, xa), 0)))}
    info["diagnostics"] = dict(info["diagnostics"], phase_mass_before_normalisation=raw_mass)
    return Solution(data=data, info=info)


def phase_solution(scene: Any, res: Any, period: Any) -> tuple[dict[str, Any], dict]:
    """An FPK result's p(A) mapped to p(E), p(x1, x2), p(x1), p(x2) as for the closed form,
    with p(y, y') = p_A / (g T); ``period`` gives T(A). Returns (data, raw masses)."""
    from averaging.geometry import restoring
    from averaging.phase import phase_densities

    s = scene.system
    A, p = res.data["A_cells"]["x"], res.data["A_cells"]["p"]
    log_T = np.log(period(A))
    log_h = np.log(np.maximum(p, 1e-300)) - np.log(restoring(A, s.omega0, s.alpha)) - log_T
    ph = phase_densities(A, log_h, log_T, omega0=s.omega0, alpha=s.alpha, barrier=s.barrier,
                         points=scene.averaging.phase_points)
    data = {"A": res.data["A"], "E": {"x": ph.E, "p": ph.p_E}, "x1": {"x": ph.x1, "p": ph.p_x1},
            "x2": {"x": ph.x2, "p": ph.p_x2},
            "joint": {"x1": ph.x1, "x2": ph.x2, "p": ph.joint}}
    return data, ph.raw_mass


def montecarlo_solution(scene: Any, *, progress: bool = True, **edges: Any) -> Solution:
    """The Monte Carlo of the original system with the scene's settings and observables.

    ``edges``: optional histogram edges (``edges_A``, ``edges_x``, ``edges_v``); by default
    the Monte Carlo picks its ranges from a pilot run, independently of the other solvers.
    """
    import dataclasses

    import montecarlo

    if scene.system.f == 0.0:
        raise SolverFailure("f = 0: there is no noise; the Monte Carlo would only relax to a "
                            "deterministic attractor, so there is no stationary density")
    settings = montecarlo.Settings(**dataclasses.asdict(scene.montecarlo),
                                   observables=scene.observables.names(), progress=progress,
                                   edges=edges)
    try:
        res = montecarlo.simulate(scene.system, scene.noise, settings)
    except montecarlo.SimulationDiverged as exc:
        raise SolverFailure(str(exc)) from None
    info = dict(res.info)
    mom = info.get("moments", {}).get("A", {}).get("mean")
    if mom is not None:
        info["summary"] = {"mean": mom["value"], "mean_err": mom["err"]}
    return Solution(data=res.data, info=info)


def solution_record(scene: Any, solver: str, model: str | None, result: Any, *,
                    joint: bool = False, provenance: dict[str, Any] | None = None
                    ) -> dict[str, Any]:
    """The public JSON contract of ``vifpk solve``::

        {"scene": {...}, "solver": ..., "model": ..., "pdf": {"A": {"x", "p"[, "edges", "err"]},
         "x1": {...}, "x2": {...}[, "E", "joint"]}, "info": {..., "provenance": {...}}}

    ``provenance``: the run's block (harness/provenance.py), stored as ``info.provenance``.
    """
    pdf = {k: v for k, v in result.data.items() if k in ("A", "E", "x1", "x2")
           or (joint and k == "joint")}
    rec: dict[str, Any] = {"scene": scene.to_dict(), "solver": solver}
    if model is not None:
        rec["model"] = model
    rec["pdf"] = pdf
    rec["info"] = result.info if provenance is None else dict(result.info, provenance=provenance)
    return rec
