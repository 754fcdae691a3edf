"""Entry point: solve(scene, model=...) -> Result(data, info) (vifpk.core.result).

``data`` maps an observable name to a density record ``{"x": grid, "p": density}``
(``"joint"`` holds ``{"x1", "x2", "p"}``); ``info`` holds timings, grid sizes, diagnostics,
versions and a status (``Status.record()``).

The model is any registered averaged model (vifpk.core.registry: vifpk's own in
pyproject.toml, and every ``vifpk.models`` plugin) that has a closed form: a
``log_stationary_parts(A)`` and a ``period(A)`` (averaging/stationary.py).
"""

from __future__ import annotations

import math
import platform
import time
from typing import Any

import numpy as np
import scipy

from vifpk.core import registry
from vifpk.core.result import Result, Status
from vifpk.core.scene import no_noise

from .corrected import observed_density, observed_log_h
from .phase import phase_densities
from .stationary import NoStationaryDensity, amplitude_density, describe
from .walls import phase_walls


class NoClosedForm(ValueError):
    """The model gives no ``log_stationary_parts`` or no ``period``: no closed form here."""


def build_model(scene: Any, model: str = "paper", **options: Any) -> Any:
    """The registered averaged model named ``model`` for the scene (options: see each
    model); an unknown name raises ValueError listing the registered ones."""
    return registry.build_model(scene, model, **options)


def has_closed_form(m: Any) -> bool:
    """Whether a model object gives what the closed form needs (averaging/stationary.py)."""
    return all(callable(getattr(m, k, None)) for k in ("log_stationary_parts", "period"))


def solve(scene: Any, *, model: Any = "paper", tail_mass: bool = True, **options: Any
          ) -> Result:
    """Stationary densities of the averaged model (a registered name, or a model object with
    a closed form) for a (duck-typed) scene.

    ``tail_mass=False``: no measurement of the mass beyond the grid (diagnostics.tail_mass is
    None; stationary.amplitude_density). Raises NoStationaryDensity when the averaged FPK has
    none (e.g. f = 0).
    """
    t0 = time.perf_counter()
    sys_ = scene.system
    settings = scene.averaging
    if no_noise(sys_):
        raise NoStationaryDensity(no_noise(sys_))
    m = build_model(scene, model, **options) if isinstance(model, str) else model
    if not has_closed_form(m):
        raise NoClosedForm(f"model {model!r} gives no log_stationary_parts(A) and period(A): "
                           "it has no closed form (its p(A) comes from the FPK)")
    amp = amplitude_density(m, points=settings.points, tail=settings.tail, tail_mass=tail_mass)
    A_obs, p_obs, log_h = amp.A, amp.p, amp.log_h
    if getattr(m, "observes", False):  # the observed (not the slow) energy: section 10.3 (b)
        A_obs, p_obs = observed_density(m, amp.A, amp.p)
        log_h = observed_log_h(m, A_obs, p_obs)
    t1 = time.perf_counter()
    log_T = np.log(m.period(A_obs))
    ph = phase_densities(A_obs, log_h, log_T, restoring=tuple(sys_.restoring_law),
                         **phase_walls(sys_), points=settings.phase_points)
    t2 = time.perf_counter()
    data = {
        "A": {"x": A_obs, "p": p_obs},
        "E": {"x": ph.E, "p": ph.p_E},
        "x1": {"x": ph.x1, "p": ph.p_x1},
        "x2": {"x": ph.x2, "p": ph.p_x2},
        "joint": {"x1": ph.x1, "x2": ph.x2, "p": ph.joint},
    }
    summary = describe(A_obs, p_obs)
    ok = all(np.all(np.isfinite(d["p"])) and np.min(d["p"]) >= 0.0 for d in data.values())
    info = {
        "solver": "averaging",
        "model": model if isinstance(model, str) else type(model).__name__,
        "options": {k: v for k, v in m.__dict__.items()
                    if k in ("b6", "noise", "impact", "theta_nodes", "harmonics")},
        "grid": {"points": int(A_obs.size), "A_min": float(A_obs[0]), "A_max": float(A_obs[-1]),
                 "phase_points": int(settings.phase_points)},
        "diagnostics": {
            "mass": summary["mass"], "min": summary["min"],
            "tail_mass": amp.tail_mass if tail_mass else None,
            "phase_mass_before_normalisation": ph.raw_mass, "scans": amp.scans,
        },
        "summary": {k: summary[k] for k in ("mean", "mode", "std")},
        "seconds": {"amplitude": t1 - t0, "phase": t2 - t1, "total": t2 - t0},
        "versions": versions(),
        "status": (Status.DENSITY if ok and math.isfinite(summary["mean"])
                   else Status.NOT_FINITE).record(),
    }
    return Result(data=data, info=info)


def versions() -> dict[str, str]:
    from importlib import metadata

    try:
        own = metadata.version("vifpk")
    except metadata.PackageNotFoundError:
        own = "unknown"
    return {"vifpk": own, "python": platform.python_version(), "numpy": np.__version__,
            "scipy": scipy.__version__}
