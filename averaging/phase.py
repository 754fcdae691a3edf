"""From an amplitude density to phase space: p(E), p(x1, x2), p(x1), p(x2).

Used for the closed-form densities and, by the harness, for an FPK's p(A) (paper eq. 15-16):

    p(E) = p_A / g(A),      p(y, y') = p(E) / T(E),      E = y'^2 / 2 + U(y)
    p(x1, x2) = 2 p(y, y')  on x1 > 0 with a barrier (x = |y| folds the line), else p(y, y')
    p(x1) = int p(x1, x2) dx2 = 4 int_0^inf exp h dv   (2 int_0^inf without a barrier)
    p(x2) = int p(x1, x2) dx1 = 2 int_0^inf exp h dx   (either way)

with h = log p(y, y') interpolated in A by a cubic spline (A = U^{-1}(E) is smooth in (x, v)
away from the origin). The marginals are Gauss-Legendre integrals over the part of each line
where A lies in the support [A_lo, A_max], not sums over the joint grid, so the joint and the
marginals are independent computations that a test can compare.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from vifpk.physics.spring import amplitude_of_energy, potential

from .geometry import Array


@dataclass(frozen=True)
class PhaseDensities:
    E: Array
    p_E: Array
    x1: Array
    p_x1: Array
    x2: Array
    p_x2: Array
    joint: Array  # joint[i, j] = p(x1[i], x2[j])
    raw_mass: dict[str, float]


def phase_densities(A: Array, log_h: Array, log_T: Array, *,
                    restoring: tuple[float, ...] | None = None, omega0: float | None = None,
                    alpha: float | None = None, barrier: bool, points: int = 201,
                    nodes: int = 128, lower: float = -math.inf, upper: float = math.inf
                    ) -> PhaseDensities:
    """Map h(A) = log p(y, y') (given on the A grid, with log T(A)) to phase space.

    ``barrier``: the paper's wall (x = |y|, folded); otherwise walls at ``lower`` <= 0 and
    ``upper`` >= 0 (issue 37): h is then log p(x, x') itself (T the truncated orbit's period,
    p(x, x') = p_E / T on the region the orbits fill), which lives on [lower, upper]; p(x2)
    integrates the two sides x > 0 and x < 0 separately (each cut at its wall).

    The spring: ``restoring`` = (k1, k3, k5, ...), or the paper's ``omega0``, ``alpha``."""
    if restoring is None:
        if omega0 is None or alpha is None:
            raise TypeError("give restoring=(k1, k3, ...) or omega0= and alpha=")
        restoring = (omega0**2, alpha)
    k = tuple(restoring)

    A = np.asarray(A, dtype=float)
    spline = CubicSpline(A, log_h)
    lo, hi = float(A[0]), float(A[-1])
    E_lo = float(potential(np.asarray(lo, dtype=float), k))
    E_hi = float(potential(np.asarray(hi, dtype=float), k))

    def dens(x: Array, v: Array) -> Array:
        a = amplitude_of_energy(0.5 * v**2 + potential(x, k), k)
        inside = (a >= lo) & (a <= hi)
        return np.where(inside, np.exp(spline(np.clip(a, lo, hi))), 0.0)

    fold = 2.0 if barrier else 1.0
    gx, gw = np.polynomial.legendre.leggauss(nodes)
    # p(x1): integrate over v >= 0 where E in [E_lo, E_hi]
    walls = not barrier and (lower > -hi or upper < hi)
    x1 = np.linspace(0.0 if barrier else max(lower, -hi), min(upper, hi), points)
    Ux = potential(x1, k)
    v_lo = np.sqrt(2.0 * np.maximum(E_lo - Ux, 0.0))
    v_hi = np.sqrt(2.0 * np.maximum(E_hi - Ux, 0.0))
    vm, vh = 0.5 * (v_hi + v_lo), 0.5 * (v_hi - v_lo)
    v = vm[:, None] + vh[:, None] * gx[None, :]
    p_x1 = fold * 2.0 * vh * (dens(x1[:, None], v) @ gw)
    # p(x2): integrate over x >= 0 where E in [E_lo, E_hi]
    vmax = float(np.sqrt(2.0 * E_hi))
    x2 = np.linspace(-vmax, vmax, points)
    K = 0.5 * x2**2
    x_lo = amplitude_of_energy(np.maximum(E_lo - K, 0.0), k)
    x_hi = amplitude_of_energy(np.maximum(E_hi - K, 0.0), k)
    xm, xh = 0.5 * (x_hi + x_lo), 0.5 * (x_hi - x_lo)
    x = xm[:, None] + xh[:, None] * gx[None, :]
    if walls:  # each side cut at its wall: |x| in [x_lo, min(x_hi, wall)]
        p_x2 = np.zeros_like(x2)
        for sign, end in ((1.0, upper), (-1.0, -lower)):
            top = np.minimum(x_hi, end)
            xm, xh = 0.5 * (top + x_lo), 0.5 * np.maximum(top - x_lo, 0.0)
            x = xm[:, None] + xh[:, None] * gx[None, :]
            p_x2 = p_x2 + xh * (dens(sign * x, x2[:, None]) @ gw)
    else:
        p_x2 = 2.0 * xh * (dens(x, x2[:, None]) @ gw)
    joint = fold * dens(x1[:, None], x2[None, :])
    # p(E) = p(y, y') T(E) = p_A / g on the energy grid E_k = U(A_k): exact pointwise; its
    # trapezoid mass differs from 1 by the quadrature error on this uneven grid (~1e-5)
    E = potential(A, k)
    p_E = np.exp(log_h + log_T)
    # no linear spring (k1 = 0): T = inf at A = 0, where p_E ~ T has an integrable
    # singularity; the E record starts at the first grid point with a finite period
    finite = np.isfinite(log_T)
    E, p_E = E[finite], p_E[finite]
    raw = {
        "E": float(np.trapezoid(p_E, E)),
        "x1": float(np.trapezoid(p_x1, x1)),
        "x2": float(np.trapezoid(p_x2, x2)),
        "joint": float(np.trapezoid(np.trapezoid(joint, x2, axis=1), x1)),
    }
    return PhaseDensities(E=E, p_E=p_E / raw["E"], x1=x1, p_x1=p_x1 / raw["x1"], x2=x2,
                          p_x2=p_x2 / raw["x2"], joint=joint / raw["joint"], raw_mass=raw)
