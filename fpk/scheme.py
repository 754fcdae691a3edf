"""Finite-volume discretisation of the 1-D FPK in conservative flux form.

    dp/dt = -dJ/dA,    J = m p - d(D p)/dA,    D = sigma^2 / 2,    J = 0 at both walls.

Cell-centred grid on [lo, hi] with N cells (centres A_i = lo + (i + 1/2) h), so the singular
drift at A = 0 is never evaluated on a node. With u = D p and v = m / D, J = v u - u'. The
Scharfetter-Gummel flux (exact for constant J and v on a cell pair) is

    J_{i+1/2} = (1/h) [ B(-b) u_i - B(b) u_{i+1} ],   B(x) = x / (e^x - 1),
    b_{i+1/2} = int_{A_i}^{A_{i+1}} v dA     (3-point Gauss-Legendre between the two centres)

Properties: conservative (sum_i p_i h is exactly invariant), positivity preserving (the
operator is an M-matrix), and its discrete stationary state (J = 0 on every face) is
u_{i+1} = u_i e^{b}: the closed form p = C / D exp(int 2 m / sigma^2) at the centres, up to
the 6th-order quadrature error of b. What remains is the normalisation sum p_i h = 1, a
midpoint rule: the scheme is second order in h (declared ``ORDER``; the slope is measured in
tests/test_fpk.py). The face-value choice b = h v(A_{i+1/2}) is also second order, but with the
1/A drift it errs by ln 3 - 1 on the first face and its L1 error is 10x larger.

Absorbing right wall (``right="absorbing"``, first passage out of [lo, hi)): p = 0 at A = hi.
The last face's flux is the same SG flux over the half cell from the last centre to the wall,
with u = 0 there: J_N = (2/h) B(-b_w) u_{N-1}, b_w = int_{A_{N-1}}^{hi} v dA. The operator loses
mass through that face only; ``with_sink`` appends a sink cell that collects it, so the stepped
system conserves mass exactly (mass inside + mass absorbed = 1, checked by the stepper).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.linalg import eigh_tridiagonal

Array = NDArray[np.float64]
ORDER = 2


def bernoulli(x: Array) -> Array:
    """B(x) = x / (e^x - 1), with B(0) = 1, stable for all x (expm1; series near 0)."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 1e-8
    safe = np.where(small, 1.0, x)
    with np.errstate(over="ignore"):  # x / inf = 0 is the right limit for large x
        return np.where(small, 1.0 - 0.5 * x, safe / np.expm1(safe))


@dataclass(frozen=True)
class Discretisation:
    """Grid and the tridiagonal SG operator M (dp/dt = M p)."""

    lo: float
    hi: float
    centres: Array
    faces: Array
    h: float
    D: Array  # D at the centres
    b: Array  # b at the N-1 interior faces
    lower: Array  # M[i+1, i]
    diag: Array
    upper: Array  # M[i, i+1]
    absorbing: bool = False  # p = 0 at hi (the right wall); else zero flux there
    wall_rate: float = 0.0  # J_N = wall_rate * h * p_{N-1} (absorbing only)

    @property
    def cells(self) -> int:
        return self.centres.size

    def matrix(self) -> sp.csr_matrix:
        return sp.diags([self.lower, self.diag, self.upper], [-1, 0, 1], format="csr")

    def rate(self, p: Array) -> Array:
        """dp/dt = M p (numpy)."""
        out = self.diag * p
        out[1:] += self.lower * p[:-1]
        out[:-1] += self.upper * p[1:]
        return out

    def face_flux(self, p: Array) -> Array:
        """J at all N+1 faces (zero at the two walls by construction)."""
        u = self.D * p
        J = np.zeros(self.cells + 1)
        J[1:-1] = (bernoulli(-self.b) * u[:-1] - bernoulli(self.b) * u[1:]) / self.h
        if self.absorbing:
            J[-1] = self.wall_rate * self.h * p[-1]
        return J

    def with_sink(self) -> Discretisation:
        """The absorbing operator with one more cell, a sink at [hi, hi + h] that collects the
        wall flux and gives nothing back: a closed system whose total mass sum p h is exactly
        invariant (what the stepper's mass check needs). Only the stepper uses it."""
        if not self.absorbing:
            raise ValueError("with_sink needs an absorbing right wall")
        h = self.h
        return Discretisation(
            lo=self.lo, hi=self.hi + h, centres=np.append(self.centres, self.hi + 0.5 * h),
            faces=np.append(self.faces, self.hi + h), h=h, D=np.append(self.D, self.D[-1]),
            b=np.append(self.b, 0.0), lower=np.append(self.lower, self.wall_rate),
            diag=np.append(self.diag, 0.0), upper=np.append(self.upper, 0.0))

    def solve_absorbing(self, b: Array) -> Array:
        """x = (-M)^{-1} b for the absorbing operator, without cancellation.

        -M has zero column sums except the last (the wall), so Gaussian elimination from the
        top has the pivots lower[i] (the rate from cell i into i+1) and wall_rate, the
        multipliers are all -1, and the two sweeps are sums of non-negative terms:
        y = cumsum(b), x_i = (y_i + upper[i] x_{i+1}) / lower[i], x_{N-1} = y_{N-1} / wall_rate.
        For b >= 0 every x_i carries full relative precision however slow the decay (a
        banded LU would subtract nearly equal numbers once lambda_1 / ||M|| nears 1e-16)."""
        if not self.absorbing:
            raise ValueError("solve_absorbing needs an absorbing right wall")
        y = np.cumsum(np.asarray(b, dtype=float))
        x = np.empty_like(y)
        x[-1] = y[-1] / self.wall_rate
        for i in range(self.cells - 2, -1, -1):
            x[i] = (y[i] + self.upper[i] * x[i + 1]) / self.lower[i]
        return x

    def decay_rate(self, *, rtol: float = 1e-13, max_iter: int = 500) -> float:
        """lambda_1 > 0, the slowest decay rate of the absorbing operator (R(t) ~ e^{-lambda_1
        t} at late times), by inverse iteration with ``solve_absorbing``: v <- (-M)^{-1} v
        from v = 1 (positive throughout: Perron-Frobenius), lambda = sum v / sum (-M)^{-1} v,
        until it changes by less than rtol. Each step gains the factor lambda_1 / lambda_2
        (small for a high threshold: 2-3 steps; about 20 for a threshold in the bulk). The
        symmetrised tridiagonal eigenvalue (as ``relaxation_time``) has an absolute error of
        ~1e-16 ||M||, so it is no use once lambda_1 / ||M|| nears that (measured on the
        Rayleigh amplitude at Ac = 3: it returned -3e-14, this 2.5e-19 = 1 / T to 7e-5)."""
        if not self.absorbing:
            raise ValueError("decay_rate needs an absorbing right wall (else it is 0)")
        v = np.ones(self.cells)
        lam = math.inf
        for _ in range(max_iter):
            w = self.solve_absorbing(v)
            new = float(np.sum(v) / np.sum(w))
            v = w / np.max(w)
            if abs(new - lam) <= rtol * new:
                return new
            lam = new
        return lam

    def stationary_log(self) -> Array:
        """log p of the discrete stationary state (J = 0 on every face), normalised so that
        sum p h = 1. This is the exact null vector of M, built in log space (no overflow)."""
        log_u = np.concatenate([[0.0], np.cumsum(self.b)])
        log_p = log_u - np.log(self.D)
        top = np.max(log_p)
        return log_p - top - math.log(np.sum(np.exp(log_p - top)) * self.h)

    def relaxation_time(self) -> float:
        """1 / |lambda_1|, lambda_1 the slowest non-zero eigenvalue of M.

        M satisfies detailed balance, so it is similar to the symmetric tridiagonal matrix
        with off-diagonal sqrt(M[i, i+1] M[i+1, i]); its two largest eigenvalues are 0 and
        lambda_1."""
        off = np.sqrt(self.upper * self.lower)
        n = self.cells
        vals = eigh_tridiagonal(self.diag, off, eigvals_only=True, select="i",
                                select_range=(n - 2, n - 1))
        lam = float(np.min(vals))
        return math.inf if lam >= 0 else 1.0 / abs(lam)


#: the time steppers of ``stepper.run`` (py-pde; named here, so that naming them imports no py-pde)
STEPPERS = ("bdf", "explicit")


class FPKFailure(RuntimeError):
    """A time-stepping run lost mass or positivity, or failed to converge (``stepper.py``), or
    a quadrature overflowed (``passage.py``)."""


class CoefficientError(ArithmeticError):
    """m or sigma^2 not finite (or sigma^2 not positive) on the grid: a numerical failure of
    the coefficients, not a bad argument (stepper.FPKFailure is raised for it)."""


def discretise(drift: Callable[[Array], Array], diffusion: Callable[[Array], Array], *,
               lo: float, hi: float, cells: int, right: str = "reflecting") -> Discretisation:
    """Build the SG operator for m = drift(A), sigma^2 = diffusion(A) on [lo, hi]; zero flux
    at lo, and at hi zero flux (``right="reflecting"``) or p = 0 (``"absorbing"``)."""
    if not (hi > lo >= 0.0) or cells < 4:
        raise ValueError(f"need 0 <= lo < hi and cells >= 4, got [{lo}, {hi}], {cells}")
    if right not in ("reflecting", "absorbing"):
        raise ValueError(f"right must be 'reflecting' or 'absorbing', not {right!r}")
    h = (hi - lo) / cells
    faces = lo + h * np.arange(cells + 1)
    centres = 0.5 * (faces[1:] + faces[:-1])
    D = 0.5 * np.asarray(diffusion(centres), dtype=float)
    gx, gw = np.polynomial.legendre.leggauss(3)
    nodes = (faces[1:-1, None] + 0.5 * h * gx[None, :]).ravel()
    v = 2.0 * np.asarray(drift(nodes), dtype=float) / np.asarray(diffusion(nodes), dtype=float)
    b = 0.5 * h * (v.reshape(-1, 3) @ gw)
    if not (np.all(np.isfinite(D)) and np.all(D > 0) and np.all(np.isfinite(b))):
        raise CoefficientError("drift or diffusion is not finite and positive on the grid")
    Bm, Bp = bernoulli(-b), bernoulli(b)
    # dp_i/dt = -(J_{i+1/2} - J_{i-1/2}) / h
    s = 1.0 / h**2
    diag = np.zeros(cells)
    diag[:-1] -= s * Bm * D[:-1]  # outflow through the right face
    diag[1:] -= s * Bp * D[1:]  # outflow through the left face
    upper = s * Bp * D[1:]  # from cell i+1 into i
    lower = s * Bm * D[:-1]  # from cell i into i+1
    wall_rate = 0.0
    if right == "absorbing":  # the half cell [A_{N-1}, hi], u = 0 at the wall
        wx = (0.5 * (centres[-1] + hi) + 0.25 * h * gx)
        bw = 0.25 * h * float(2.0 * np.asarray(drift(wx), dtype=float)
                              / np.asarray(diffusion(wx), dtype=float) @ gw)
        if not math.isfinite(bw):
            raise CoefficientError("drift or diffusion is not finite next to the wall")
        wall_rate = 2.0 * s * float(bernoulli(np.array(-bw))) * D[-1]
        diag[-1] -= wall_rate
    return Discretisation(lo=lo, hi=hi, centres=centres, faces=faces, h=h, D=D, b=b,
                          lower=lower, diag=diag, upper=upper, absorbing=right == "absorbing",
                          wall_rate=wall_rate)
