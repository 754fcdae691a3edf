"""What the stationary law p(x, v) of the original system gives: p(A), p(x1), p(x2), the
joint law, the impact rate and loss per wall (Rice: the outflow int |v| p(a, v) dv through
the wall), and the power balance.

The observables are the Monte Carlo's (montecarlo/summary.py): x1 = x, x2 = v and the
amplitude A with U(A) = E = v^2/2 + U(x) (the free orbit's amplitude of the energy, walls or
not). p(A) is the coarea integral over the energy contour (p_A da = p_E dE, dE = g(A) dA)::

    p_A(A) = g(A) sum_(+-) int p(x, +-|v|) dx / |v|,   |v| = sqrt(2 (U(A) - U(x))),

in x = A sin(theta), where U(A) - U(A s) = cos^2(theta) W(A, s),
W = sum_j k_j A^(2j) (1 + s^2 + ... + s^(2j-2)) / (2j), so dx / |v| = A dtheta / sqrt(2 W):
no singularity at the turning points. A wall at a inside [-A, A] cuts theta at asin(a / A).
p(x, v) at a point is the bilinear interpolant of the cell averages at the centres (linear
extrapolation in the half cells at the edges): second order, as the scheme.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.interpolate import RegularGridInterpolator

from .physics import Coefficients
from .scheme import Grid

#: Gauss-Legendre nodes on each branch (v > 0, v < 0) of an energy contour, at least
THETA_NODES = 96


def amplitude_density(c: Coefficients, grid: Grid, p: np.ndarray, A: np.ndarray
                      ) -> np.ndarray:
    """p_A at the amplitudes ``A`` (module docstring)."""
    interp = RegularGridInterpolator((grid.x, grid.v), p, method="linear",
                                     bounds_error=False, fill_value=None)
    lo = max((w.at for w in grid.walls if w.side < 0), default=-np.inf)
    hi = min((w.at for w in grid.walls if w.side > 0), default=np.inf)
    n = max(THETA_NODES, max(grid.shape))
    t, wt = np.polynomial.legendre.leggauss(n)
    out = np.zeros_like(A, dtype=float)
    pos = A > 0
    a = A[pos][:, None]
    th0 = np.arcsin(np.clip(np.maximum(lo, -a) / a, -1.0, 1.0))
    th1 = np.arcsin(np.clip(np.minimum(hi, a) / a, -1.0, 1.0))
    half = 0.5 * (th1 - th0)
    th = th0 + half * (t[None, :] + 1.0)
    s = np.sin(th)
    W = np.zeros_like(s)
    s2 = s * s
    for j, kj in enumerate(c.k, start=1):
        S = np.zeros_like(s)
        term = np.ones_like(s)
        for _ in range(j):
            S = S + term
            term = term * s2
        W = W + kj * a ** (2 * j) * S / (2 * j)
    W = np.maximum(W, 1e-300)
    x = a * s
    speed = np.sqrt(2.0 * W) * np.cos(th)
    pts = np.stack([np.broadcast_to(x, speed.shape), speed], axis=-1)
    pp = np.maximum(interp(pts), 0.0) + np.maximum(interp(pts * [1.0, -1.0]), 0.0)
    pE = np.sum(pp * (a / np.sqrt(2.0 * W)) * wt[None, :], axis=1) * half[:, 0]
    out[pos] = c.g(A[pos]) * pE
    return out


def with_ends(centres: np.ndarray, p: np.ndarray, lo: float, hi: float
              ) -> tuple[np.ndarray, np.ndarray]:
    """Cell-centre values with the two ends added by linear extrapolation (clipped at 0)."""
    pl = max(p[0] + (p[0] - p[1]) * (centres[0] - lo) / (centres[1] - centres[0]), 0.0)
    ph = max(p[-1] + (p[-1] - p[-2]) * (hi - centres[-1]) / (centres[-1] - centres[-2]), 0.0)
    return np.concatenate([[lo], centres, [hi]]), np.concatenate([[pl], p, [ph]])


def marginals(c: Coefficients, grid: Grid, p: np.ndarray, A: np.ndarray) -> dict[str, Any]:
    """The densities the harness compares (smooth records {"x", "p"}, trapezoid mass 1; the
    mass before that normalisation in ``raw_mass``) and the joint law (cell averages)."""
    out: dict[str, Any] = {}
    raw = {}
    pa = amplitude_density(c, grid, p, A)
    raw["A"] = float(np.trapezoid(pa, A))
    out["A"] = {"x": A, "p": pa / raw["A"]}
    for name, centres, ends, marg in (
            ("x1", grid.x, grid.xe, p.sum(axis=1) * grid.hv),
            ("x2", grid.v, grid.ve, p.sum(axis=0) * grid.hx)):
        xs, ps = with_ends(centres, marg, float(ends[0]), float(ends[-1]))
        raw[name] = float(np.trapezoid(ps, xs))
        out[name] = {"x": xs, "p": ps / raw[name]}
    out["joint"] = {"x1": grid.x, "x2": grid.v, "p": p}
    return {"data": out, "raw_mass": raw}


def wall_fluxes(grid: Grid, p: np.ndarray, walls: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per wall: the impact rate (Rice: int |v| p(a, v) dv over the velocities moving into
    it, with the scheme's own face values, so the rate is the flux the scheme puts back) and
    the kinetic energy the impacts take per unit time, int |v| p(a, v) (1 - e^2) v^2 / 2 dv."""
    flat = p.ravel()
    out = []
    for w in walls:
        flux = sum(wt * flat[col] for col, wt in zip(w["cols"], w["weights"], strict=True))
        wall = w["wall"]
        out.append({"side": "lower" if wall.side < 0 else "upper", "at": wall.at,
                    "law": wall.law, "impacts_per_time": float(np.sum(flux) * grid.hv),
                    "impact_loss": float(np.sum(flux * wall.loss(w["speed"])) * grid.hv),
                    "trace_min": float(flux.min()) if flux.size else 0.0})
    return out


def power_balance(c: Coefficients, grid: Grid, p: np.ndarray, walls: list[dict[str, Any]]
                  ) -> dict[str, float]:
    """The stationary power balance (Ito): input = damping + friction + impacts, each the
    mean of its power with p constant in each cell (the power averaged over the cell by a
    4 x 4 Gauss-Legendre rule: exact for the polynomial laws up to degree 7 in each
    variable; |v| keeps its sign in a cell); ``residual`` = input - losses (0 for the exact
    law; the discrete law closes it to its discretisation error, order ORDER)."""
    t, w = np.polynomial.legendre.leggauss(4)
    xs = grid.x[:, None] + 0.5 * grid.hx * t[None, :]          # (nx, 4)
    vs = grid.v[:, None] + 0.5 * grid.hv * t[None, :]          # (nv, 4)
    X = xs[:, None, :, None]
    V = vs[None, :, None, :]
    W = (0.25 * w[:, None] * w[None, :])[None, None]

    def mean(f: Any) -> float:
        cell = np.sum(np.broadcast_to(f, (*p.shape, 4, 4)) * W, axis=(2, 3))
        return float(np.sum(cell * p) * grid.hx * grid.hv)

    inp = mean(c.input_power(X, V))
    damp = mean((c.damping(X) + c.velocity_damping(V)) * V * V)
    fric = mean(c.mu * np.abs(V))
    imp = float(sum(wl["impact_loss"] for wl in walls))
    return {"input": inp, "damping": damp, "friction": fric, "impacts": imp,
            "residual": inp - damp - fric - imp,
            "relative_residual": (inp - damp - fric - imp) / inp}
