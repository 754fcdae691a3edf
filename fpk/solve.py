"""Public entry points of ``fpk``: stationary and transient solutions of the 1-D FPK.

    dp/dt = -d(m p)/dA + 1/2 d^2(sigma^2 p)/dA^2   on [lo, hi], zero probability flux at both

Generic in m and sigma^2 (callables, or tables ``(A, values)`` interpolated by cubic splines).
Knows nothing of vibro-impact: the harness hands it the coefficients.
Results are ``Result(data, info)``; ``data["A"]`` holds the density at the cell centres plus
the two walls (p there extrapolated linearly, clipped at 0), normalised to trapezoid mass 1;
``data["A_cells"]`` the finite-volume cell averages (sum p h = 1).
"""

from __future__ import annotations

import math
import platform
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import scipy
from scipy.interpolate import CubicSpline

from vifpk.core.defaults import FPK_CELLS
from vifpk.core.result import Result, Status

from .scheme import ORDER, Array, Discretisation, FPKFailure, discretise

Coefficient = Callable[[Array], Array] | tuple[Array, Array]
A_LIMIT = 1e4


def as_function(c: Coefficient, name: str) -> Callable[[Array], Array]:
    """A callable from a callable or an (A, values) table (cubic spline, no extrapolation)."""
    if callable(c):
        return c
    x, y = (np.asarray(v, dtype=float) for v in c)
    spline = CubicSpline(x, y)

    def f(a: Array) -> Array:
        a = np.asarray(a, dtype=float)
        if np.any(a < x[0]) or np.any(a > x[-1]):
            raise ValueError(f"{name} table covers [{x[0]:g}, {x[-1]:g}], not the grid "
                             f"[{a.min():g}, {a.max():g}]")
        return spline(a)

    return f


def choose_domain(drift: Callable, diffusion: Callable, *, tail: float = 1e-10,
                  start: float = 2.0, scan: int = 512) -> tuple[float, float, float]:
    """[lo, hi] holding all but ~tail of the stationary mass (from coarse discrete solves),
    and the mass estimated outside it.

    hi doubles until the last tenth of [0, hi] holds less than tail; then both ends are cut
    where at most tail/2 of the mass lies beyond. A cut lo > 0 puts a zero-flux wall where
    the density is negligible (the solution on the cut domain is the restricted density).
    """
    hi = start
    while True:
        disc = discretise(drift, diffusion, lo=0.0, hi=hi, cells=scan)
        p = np.exp(disc.stationary_log())
        if np.sum(p[int(0.9 * scan):]) * disc.h < tail:
            break
        hi *= 2.0
        if hi > A_LIMIT:
            raise FPKFailure(f"the stationary density does not decay up to A = {A_LIMIT:g}")
    cdf = np.cumsum(p) * disc.h
    i_lo = max(int(np.searchsorted(cdf, 0.5 * tail)) - 1, 0)
    i_hi = min(int(np.searchsorted(cdf, 1.0 - 0.5 * tail)) + 2, scan)
    lo = float(disc.faces[i_lo]) if i_lo > 0 else 0.0
    outside = (float(cdf[i_lo - 1]) if i_lo > 0 else 0.0) + 1.0 - float(cdf[i_hi - 1])
    return lo, float(disc.faces[i_hi]), max(outside, 0.0)


def _with_walls(disc: Discretisation, p: Array) -> tuple[Array, Array, float]:
    """Cell values plus linearly extrapolated wall values, trapezoid-normalised."""
    left = max(1.5 * p[0] - 0.5 * p[1], 0.0)
    right = max(1.5 * p[-1] - 0.5 * p[-2], 0.0)
    x = np.concatenate([[disc.lo], disc.centres, [disc.hi]])
    y = np.concatenate([[left], p, [right]])
    mass = float(np.trapezoid(y, x))
    return x, y / mass, mass


def _versions(*, stepping: bool) -> dict[str, str]:
    """The versions of what computed the result (py-pde where it time-stepped)."""
    out = {"numpy": np.__version__, "scipy": scipy.__version__,
           "python": platform.python_version()}
    if stepping:
        import pde

        out = {"py-pde": pde.__version__, **out}
    return out


def _data(disc: Discretisation, p: Array) -> tuple[dict[str, Any], float]:
    x, y, mass = _with_walls(disc, p)
    return {"A": {"x": x, "p": y}, "A_cells": {"x": disc.centres, "p": p}}, mass


def stationary(drift: Coefficient, diffusion: Coefficient, *, cells: int = FPK_CELLS,
               method: str = "direct", stepper: str = "bdf", lo: float | None = None,
               hi: float | None = None, tail: float = 1e-10, steady: float = 1e-9,
               rtol: float = 1e-9) -> Result:
    """Stationary density: the direct solve of the flux-form discretisation (``method="direct"``,
    the default: its exact null vector by the zero-flux recursion in log space, O(cells);
    diagnostics: the residual max|M p| / max p, the mass, the least value, the wall fluxes), or
    the same discretisation time-stepped to steady state with py-pde (``method="stepping"``,
    on request: 100-400x the cost for the same density within ``steady``; its diagnostics add
    the steps, the worst mass drift and ``L1_to_direct``, its distance to the direct solve).

    steady (stepping): the run stops when the estimated L1 distance to the steady state,
    max|dp/dt| * tau * (hi - lo) with tau the relaxation time, falls below it.
    """
    t0 = time.perf_counter()
    m, s2 = as_function(drift, "drift"), as_function(diffusion, "diffusion")
    outside = float("nan")
    if lo is None or hi is None:
        dlo, dhi, outside = choose_domain(m, s2, tail=tail)
        lo = dlo if lo is None else lo
        hi = dhi if hi is None else hi
    disc = discretise(m, s2, lo=lo, hi=hi, cells=cells)
    tau = disc.relaxation_time()
    p_direct = np.exp(disc.stationary_log())
    t_direct = time.perf_counter() - t0
    info: dict[str, Any] = {
        "solver": "fpk", "method": method, "scheme": "Scharfetter-Gummel finite volume",
        "order": ORDER,
        "grid": {"cells": cells, "A_min": lo, "A_max": hi, "h": disc.h},
        "relaxation_time": tau, "versions": _versions(stepping=method == "stepping"),
    }
    if method == "direct":
        p = p_direct
        resid = float(np.max(np.abs(disc.rate(p))) / np.max(p))
        info["diagnostics"] = {"residual": resid}
        info["seconds"] = {"total": time.perf_counter() - t0, "compile": 0.0}
    elif method == "stepping":
        x = (disc.centres - lo) / (hi - lo)
        p0 = np.sin(math.pi * x) ** 2
        p0 /= np.sum(p0) * disc.h
        from .stepper import run  # py-pde, imported where it steps

        t_end = 60.0 * tau if math.isfinite(tau) else 1e6
        steady_tol = steady / (tau * (hi - lo))
        # checks (mass, positivity, steady state) once per relaxation time: each is a restart
        # of the BDF run, so tau / 4 cost 2.5x the steps for the same stationary state
        # (L1 to the direct solve 2-3e-10 either way on paper-base; docs/fpk.md)
        out = run(disc, p0, t_end=t_end, stepper=stepper, rtol=rtol, steady_tol=steady_tol,
                  check_every=tau)
        p = out["p"]
        info["diagnostics"] = {
            "t_final": out["t_final"], "steps": out["steps"], "stop_reason": out["stop_reason"],
            "worst_mass_drift": out["worst_mass_drift"], "checks": out["checks"],
            "L1_to_direct": float(np.sum(np.abs(p - p_direct)) * disc.h),
        }
        info["seconds"] = {"total": time.perf_counter() - t0, "stepping": out["seconds"],
                           "direct": t_direct}
    else:
        raise ValueError(f"method must be 'stepping' or 'direct', not {method!r}")
    J = disc.face_flux(p)
    data, mass_walls = _data(disc, p)
    info["diagnostics"].update({
        "mass": float(np.sum(p) * disc.h), "min": float(np.min(p)),
        "wall_flux": [float(J[0]), float(J[-1])], "max_face_flux": float(np.max(np.abs(J))),
        "mass_with_walls_before_normalisation": mass_walls, "tail_mass": outside,
    })
    ok = bool(np.all(np.isfinite(p)) and np.min(p) >= 0)
    info["status"] = (Status.DENSITY if ok else Status.NOT_FINITE).record()
    return Result(data=data, info=info)


def transient(drift: Coefficient, diffusion: Coefficient, *, p0: Callable[[Array], Array],
              times: Sequence[float], cells: int = FPK_CELLS, lo: float = 0.0, hi: float,
              stepper: str = "bdf", rtol: float = 1e-9) -> Result:
    """Snapshots p(A, t) at ``times`` from the initial density p0(A) (normalised here)."""
    t0 = time.perf_counter()
    m, s2 = as_function(drift, "drift"), as_function(diffusion, "diffusion")
    disc = discretise(m, s2, lo=lo, hi=hi, cells=cells)
    start = np.maximum(np.asarray(p0(disc.centres), dtype=float), 0.0)
    start /= np.sum(start) * disc.h
    times = sorted(float(t) for t in times)
    from .stepper import run  # py-pde, imported where it steps

    out = run(disc, start, t_end=times[-1], stepper=stepper, rtol=rtol, snapshots=times,
              check_every=times[-1] / 100.0)
    snaps = out["snapshots"]
    got = sorted(snaps)
    P = np.array([snaps[t] for t in got])
    data = {"snapshots": {"t": np.array(got), "x": disc.centres, "p": P},
            "A_cells": {"x": disc.centres, "p": out["p"]}}
    info = {
        "solver": "fpk", "method": "transient", "order": ORDER,
        "grid": {"cells": cells, "A_min": lo, "A_max": hi, "h": disc.h},
        "relaxation_time": disc.relaxation_time(),
        "diagnostics": {"steps": out["steps"], "worst_mass_drift": out["worst_mass_drift"],
                        "min": out["min_value"], "checks": out["checks"]},
        "seconds": {"total": time.perf_counter() - t0, "stepping": out["seconds"]},
        "versions": _versions(stepping=True),
        "status": (Status.SNAPSHOTS if np.all(np.isfinite(P)) else Status.NOT_FINITE
                   ).record(f"{len(got)} snapshots"),
    }
    return Result(data=data, info=info)
