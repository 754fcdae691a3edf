"""The stationary law of the original system, its domain from the tail and its resolution
from the accuracy asked, with the discretisation error estimated by refinement.

- **Domain** (:func:`choose_energy`): the box [max(a, -X), min(b, X)] x [-V, V] holding every
  energy up to E_max (U(X) = V^2 / 2 = E_max; walls a, b inside it are walls, beyond it they
  are never reached). E_max is grown or shrunk on a coarse grid (CUT_CELLS^2) until the mass
  of the energies above E_max / 2 is at most sqrt(tail): for a tail falling at least as fast
  as exp(-lambda E) that leaves at most ``tail`` above E_max (mass(E > E/2)^2 >=
  mass(E > E) there). The cut edges carry zero flux.
- **Resolution** (:func:`stationary`): n x n cells. Given ``cells``, that n, and the error
  estimated against n / 2; else n = 64 and 128, then the n that the estimate at 128 says
  reaches ``accuracy`` (order ORDER), at most ``max_cells``. The estimate is Richardson's:
  L1(p_n - p_m) / ((n / m)^q - 1), q = ORDER (tests/test_fpk2d.py fits q on the closed form).
- **Null vector**: one sparse LU (SuperLU, COLAMD) of the operator with one row replaced by
  p_pin = 1 (the operator's null space is one-dimensional; a pinned cell keeps the matrix
  sparse, unlike a row of ones), then normalised to mass 1 in log-free double precision
  (the pin is the coarse solve's densest cell, so no value under- or overflows).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from vifpk.core.result import Result, Status

from .observables import marginals, power_balance, wall_fluxes
from .physics import SOLVER, Coefficients, coefficients
from .scheme import ORDER, Grid, make_grid, operator

#: cells per axis of the coarse solves that choose the energy cut-off
CUT_CELLS = 64
#: the first pair of resolutions of an automatic run
START_CELLS = (64, 128)
#: amplitudes at which p(A) is given (on [0, A_max])
A_POINTS = 801


class FPK2DFailure(RuntimeError):
    """The original system's FPK could not give a trustworthy law; one line."""


@dataclass(frozen=True)
class Solution:
    grid: Grid
    p: np.ndarray          # cell averages, mass 1
    coeffs: Coefficients
    walls: list            # the operator's wall stencils
    seconds: float
    negative_mass: float


def box(c: Coefficients, E_max: float) -> tuple[float, float, float, tuple]:
    """(x_lo, x_hi, V, walls inside) of the box holding the energies up to E_max."""
    X = float(c.amplitude(np.array([E_max]))[0])
    lo, hi = -X, X
    inside = []
    for w in c.walls:
        if w.side < 0 and w.at > -X:
            lo = w.at
            inside.append(w)
        elif w.side > 0 and w.at < X:
            hi = w.at
            inside.append(w)
    return lo, hi, math.sqrt(2.0 * E_max), tuple(sorted(inside, key=lambda w: w.side))


def solve_grid(c: Coefficients, E_max: float, n: int, pin: tuple[float, float] | None = None
               ) -> Solution:
    """The stationary law on n x n cells of the box of E_max. ``pin``: the (x, v) of the cell
    whose value is fixed before normalisation (default: the centre of the box)."""
    t0 = time.process_time()
    lo, hi, V, walls = box(c, E_max)
    grid = make_grid(lo, hi, V, n, n, walls)
    M, extra = operator(c, grid)
    nx, nv = grid.shape
    px, pv = pin if pin is not None else (0.5 * (lo + hi), 0.0)
    i = int(np.clip(np.searchsorted(grid.xe, px) - 1, 0, nx - 1))
    j = int(np.clip(np.searchsorted(grid.ve, pv) - 1, 0, nv - 1))
    k = i * nv + j
    keep = np.ones(nx * nv)
    keep[k] = 0.0
    A = (sp.diags(keep) @ M.tocsr() + sp.csr_matrix(([1.0], ([k], [k])), shape=M.shape))
    rhs = np.zeros(nx * nv)
    rhs[k] = 1.0
    sol = splu(A.tocsc(), permc_spec="COLAMD").solve(rhs)
    if not np.all(np.isfinite(sol)):
        raise FPK2DFailure(f"the {SOLVER} solve on {nx} x {nv} cells is not finite")
    cell = grid.hx * grid.hv
    mass = float(np.sum(sol) * cell)
    if not mass > 0.0:
        raise FPK2DFailure(f"the {SOLVER} null vector on {nx} x {nv} cells has no positive "
                           "mass")
    p = (sol / mass).reshape(nx, nv)
    neg = float(-np.sum(np.minimum(p, 0.0)) * cell)
    return Solution(grid=grid, p=p, coeffs=c, walls=extra["walls"],
                    seconds=time.process_time() - t0, negative_mass=neg)


def energy_mass_above(sol: Solution, E: float) -> float:
    """The mass of the cells whose centre energy exceeds E."""
    g = sol.grid
    X, V = np.meshgrid(g.x, g.v, indexing="ij")
    En = 0.5 * V * V + sol.coeffs.U(X)
    return float(np.sum(np.maximum(sol.p, 0.0)[En > E]) * g.hx * g.hv)


def choose_energy(c: Coefficients, tail: float, E0: float = 1.0, cells: int = CUT_CELLS
                  ) -> tuple[float, list[dict[str, float]]]:
    """(E_max, the search's steps): module docstring."""
    target = math.sqrt(tail)
    E = E0
    steps = []
    for _ in range(40):
        sol = solve_grid(c, E, cells)
        m = energy_mass_above(sol, 0.5 * E)
        steps.append({"E_max": E, "mass_above_half": m})
        if target * 1e-3 <= m <= target:
            return E, steps
        if m > target:  # grow: exponential tail m ~ exp(-lambda E / 2)
            f = math.log(target) / math.log(min(m, 0.5)) if m < 0.5 else 4.0
            E *= min(max(f, 1.5), 8.0)
        else:
            f = math.log(target) / math.log(max(m, 1e-300))
            E *= min(max(f, 0.25), 0.8)
        if not 1e-12 < E < 1e12:
            break
    raise FPK2DFailure(f"no energy cut-off holds the law to a tail of {tail:g} (search "
                       f"ended at E_max = {E:.3g}): the tail is too heavy or the law does "
                       "not exist")


def _l1_between(x: np.ndarray, p: np.ndarray, xq: np.ndarray, q: np.ndarray) -> float:
    """int |p - q| on the union of the two grids, both linear between their points."""
    u = np.union1d(x, xq)
    return float(np.trapezoid(np.abs(np.interp(u, x, p, 0, 0) - np.interp(u, xq, q, 0, 0)), u))


def stationary(system: Any, noise: Any, parametric: Any = None, *, accuracy: float = 1e-3,
               cells: int | None = None, tail: float | None = None, max_cells: int = 640
               ) -> Result:
    """The stationary law of the original system (module docstring): data ``A``, ``x1``,
    ``x2`` (smooth records, trapezoid mass 1) and ``joint`` (cell averages); info: the grid,
    the discretisation error estimated by refinement (L1 of each density), the impact rate and
    loss per wall, the power balance, mass and positivity, seconds (CPU)."""
    t0 = time.process_time()
    c = coefficients(system, noise, parametric)
    tail = accuracy * 1e-2 if tail is None else float(tail)
    E_max, search = choose_energy(c, tail)
    pin = None
    coarse = solve_grid(c, E_max, CUT_CELLS)
    ii, jj = np.unravel_index(int(np.argmax(coarse.p)), coarse.p.shape)
    pin = (float(coarse.grid.x[ii]), float(coarse.grid.v[jj]))
    A = np.linspace(0.0, float(c.amplitude(np.array([E_max]))[0]), A_POINTS)
    if cells is not None:
        n2 = int(cells) + int(cells) % 2
        n1 = max(4, n2 // 2 + (n2 // 2) % 2)
        pair = [solve_grid(c, E_max, n1, pin), solve_grid(c, E_max, n2, pin)]
    else:
        pair = [solve_grid(c, E_max, n, pin) for n in START_CELLS]
        est = _estimate(c, pair, A)
        if est["A"] > accuracy and START_CELLS[1] < max_cells:
            need = START_CELLS[1] * (est["A"] / accuracy) ** (1.0 / ORDER)
            n = int(min(max_cells, 32 * math.ceil(need / 32)))
            pair = [pair[1], solve_grid(c, E_max, n, pin)]
    est = _estimate(c, pair, A)
    fine = pair[1]
    dens = marginals(c, fine.grid, fine.p, A)
    walls = wall_fluxes(fine.grid, fine.p, fine.walls)
    balance = power_balance(c, fine.grid, fine.p, walls)
    nx, nv = fine.grid.shape
    reached = est["A"] <= accuracy
    info: dict[str, Any] = {
        "solver": SOLVER,
        "method": "conservative finite volumes in (x, v), third-order face values, central "
                  "diffusion in v, friction's jump on a face, impact map at the walls; one "
                  "sparse LU (docs/fpk2d.md)",
        "order": ORDER,
        "grid": {"cells": [nx, nv], "x": [float(fine.grid.xe[0]), float(fine.grid.xe[-1])],
                 "v": [float(fine.grid.ve[0]), float(fine.grid.ve[-1])], "E_max": E_max,
                 "walls_inside": [w.at for w in fine.grid.walls]},
        "discretisation_error": {
            **{f"L1_{k}": v for k, v in est.items()},
            "cells": [pair[0].grid.shape[0], nx], "order": ORDER, "accuracy": accuracy,
            "reached": reached,
            "method": "Richardson: L1(p_n - p_m) / ((n/m)^order - 1) between the last two "
                      "grids"},
        "tail": {"allowed": tail, "search": search},
        "walls": walls,
        "impacts_per_time": float(sum(w["impacts_per_time"] for w in walls)),
        "energy": balance,
        "diagnostics": {"negative_mass": fine.negative_mass,
                        "min_over_max": float(fine.p.min() / fine.p.max()),
                        "raw_mass": dens["raw_mass"]},
        "summary": _summary(dens["data"]["A"]),
        "seconds": {"total": time.process_time() - t0, "last_solve": fine.seconds},
        "status": Status.DENSITY.record(),
    }
    if not reached:
        info["warnings"] = [f"the discretisation error of p(A) is estimated at "
                            f"{est['A']:.2g}, above the accuracy asked ({accuracy:g}), at "
                            f"the most cells allowed ({nx} x {nv}; max_cells)"]
    return Result(data=dens["data"], info=info)


def _summary(rec: dict[str, Any]) -> dict[str, float]:
    x, p = rec["x"], rec["p"]
    mean = float(np.trapezoid(x * p, x))
    return {"mean": mean, "mode": float(x[int(np.argmax(p))]),
            "std": float(np.sqrt(max(np.trapezoid((x - mean) ** 2 * p, x), 0.0)))}


def _estimate(c: Coefficients, pair: list[Solution], A: np.ndarray) -> dict[str, float]:
    """Richardson's estimate of the finer solution's L1 error of each density."""
    n1, n2 = pair[0].grid.shape[0], pair[1].grid.shape[0]
    den = (n2 / n1) ** ORDER - 1.0
    d1 = marginals(c, pair[0].grid, pair[0].p, A)["data"]
    d2 = marginals(c, pair[1].grid, pair[1].p, A)["data"]
    return {k: _l1_between(d2[k]["x"], d2[k]["p"], d1[k]["x"], d1[k]["p"]) / den
            for k in ("A", "x1", "x2")}
