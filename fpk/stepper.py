"""py-pde time stepping of the flux-form FPK (the SG operator of ``scheme.py``).

``AmplitudeFPK`` is a py-pde ``PDEBase`` whose right-hand side is dp/dt = M p. Two steppers:

- ``"bdf"`` (default): py-pde's ``scipy`` solver with ``method="BDF"`` and the exact constant
  sparse Jacobian M (the equation is linear); numpy backend, nothing to compile.
- ``"explicit"``: py-pde's adaptive explicit Runge-Kutta with the numba backend (compiled on
  first use in each process; the first run's ``seconds`` include that compile time).

py-pde's ``implicit`` and ``crank-nicolson`` solvers iterate to a fixed point rather than
solving with Newton and fail on stiff fine grids, so they are not offered.
Every run checks mass and positivity at each interrupt and stops with ``FPKFailure`` if the
mass drifts beyond ``mass_tol`` (or, on very long runs, the solves' round-off bound eps t
||M||_1: ``_Guard``) or the density goes below ``-neg_tol``. With an absorbing
right wall (``Discretisation.absorbing``) the stepped system is the operator plus its sink cell
(``Discretisation.with_sink``), so the mass checked is the mass inside plus the mass absorbed,
which must stay 1; ``p`` and the snapshots hold the inside, ``absorbed`` the sink's mass.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from pde import CartesianGrid, PDEBase, ScalarField
from pde.trackers import CallbackTracker, ConsistencyTracker, SteadyStateTracker

from vifpk.core.registry import one_of

from .scheme import STEPPERS, Array, Discretisation, FPKFailure

__all__ = ["STEPPERS", "FPKFailure", "run"]


class AmplitudeFPK(PDEBase):
    """dp/dt = -dJ/dA with the Scharfetter-Gummel flux and zero flux at both walls."""

    check_implementation = False  # the numba and numpy paths share the coefficients

    def __init__(self, disc: Discretisation):
        super().__init__()
        self.disc = disc

    def evolution_rate(self, state: ScalarField, t: float = 0) -> ScalarField:
        return ScalarField(state.grid, self.disc.rate(state.data))

    def make_evolution_rate(self, state: ScalarField, backend: Any) -> Callable:
        lower, diag, upper = self.disc.lower, self.disc.diag, self.disc.upper
        n = diag.size

        def rhs(p, t=0.0):
            out = np.empty_like(p)
            for i in range(n):
                out[i] = diag[i] * p[i]
            for i in range(n - 1):
                out[i + 1] += lower[i] * p[i]
                out[i] += upper[i] * p[i + 1]
            return out

        return rhs


def grid_of(disc: Discretisation) -> CartesianGrid:
    return CartesianGrid([[disc.lo, disc.hi]], [disc.cells])


def _solver_args(disc: Discretisation, stepper: str, rtol: float) -> dict[str, Any]:
    if stepper == "bdf":
        return {"solver": "scipy", "backend": "numpy", "method": "BDF", "jac": disc.matrix(),
                "rtol": rtol, "atol": rtol * 1e-3}
    if stepper == "explicit":
        return {"solver": "runge-kutta", "backend": "numba", "adaptive": True,
                "tolerance": rtol}
    one_of("stepper", stepper, STEPPERS)
    raise AssertionError("unreachable: every stepper of STEPPERS has a branch")


def _norm1(disc: Discretisation) -> float:
    """||M||_1 of the tridiagonal operator: its largest column sum of magnitudes (column j
    holds diag[j], lower[j] below it and upper[j - 1] above it)."""
    col = np.abs(disc.diag).astype(float)
    col[:-1] += np.abs(disc.lower)
    col[1:] += np.abs(disc.upper)
    return float(np.max(col))


class _Guard:
    """Mass and positivity check at each interrupt; records the worst values seen.

    The operator conserves mass exactly (its columns sum to 0; tests/test_fpk.py), so in
    exact arithmetic every BDF step does too; what drifts is round-off. Each step solves
    (I - gamma h M) y = b with a backward error of order eps ||I - gamma h M||_1 ||y||_1
    <= eps (1 + h ||M||_1) (gamma <= 1, mass 1), so over a run to time t the drift is bounded
    by about eps (n_steps + t ||M||_1). The allowance at time t is therefore
    max(mass_tol, eps t ||M||_1): mass_tol (1e-10) on every run of ordinary length, and the
    round-off bound on runs to 1e5..1e7 time units, where BDF's late steps are long and
    (I - gamma h M) ill-conditioned (an averaged FPK of the telegraph example to t = 4e5
    drifted by 5.7e-10 against 1e-10, a round-off drift the bound allows: 2.2e-16 x 4e5 x
    ||M||_1). A leak in the operator (a wall flux that does not vanish) loses mass of order
    one per relaxation time, far above either."""

    def __init__(self, disc: Discretisation, mass0: float, mass_tol: float, neg_tol: float):
        self.disc, self.mass0 = disc, mass0
        self.mass_tol, self.neg_tol = mass_tol, neg_tol
        self.roundoff_rate = float(np.finfo(float).eps) * _norm1(disc) * max(abs(mass0), 1.0)
        self.worst_mass = 0.0
        self.min_value = np.inf
        self.checks = 0

    def __call__(self, field: ScalarField, t: float) -> None:
        p = field.data
        self.checks += 1
        if not np.all(np.isfinite(p)):
            raise FPKFailure(f"the density became non-finite at t = {t:.4g}")
        dm = abs(float(np.sum(p)) * self.disc.h - self.mass0)
        self.worst_mass = max(self.worst_mass, dm)
        self.min_value = min(self.min_value, float(np.min(p)))
        allowed = max(self.mass_tol, self.roundoff_rate * t)
        if dm > allowed:
            raise FPKFailure(f"mass drifted by {dm:.2e} (> {allowed:.1e}, the larger of "
                             f"{self.mass_tol:.0e} and the solves' round-off bound eps t "
                             f"||M||_1) at t = {t:.4g}")
        if self.min_value < -self.neg_tol * float(np.max(p)):
            raise FPKFailure(f"the density went negative ({self.min_value:.2e}) at t = {t:.4g}")


def run(disc: Discretisation, p0: Array, *, t_end: float, stepper: str = "bdf",
        rtol: float = 1e-8, steady_tol: float | None = None, check_every: float | None = None,
        snapshots: Sequence[float] = (), mass_tol: float = 1e-10,
        neg_tol: float = 1e-12) -> dict[str, Any]:
    """Step p0 forward to t_end (or until steady), returning the state and diagnostics.

    steady_tol: stop once max |dp/dt| <= steady_tol (SteadyStateTracker, given the exact
    rate function). snapshots: times at which to store copies of p.
    """
    inside = disc.cells
    if disc.absorbing:
        disc = disc.with_sink()
        p0 = np.append(np.asarray(p0, dtype=float), 0.0)
    eq = AmplitudeFPK(disc)
    state = ScalarField(grid_of(disc), np.array(p0, dtype=float))
    mass0 = float(np.sum(p0)) * disc.h
    guard = _Guard(disc, mass0, mass_tol, neg_tol)
    every = check_every if check_every is not None else t_end / 50.0
    # every interrupt in simulated time: py-pde's "consistency" tracker defaults to wall-clock
    # interrupts (one a second), which cut the BDF run into restarts at moments that depend on
    # the machine's speed, so the step sequence and the result changed from run to run at
    # 1e-11..2e-8 (issue 11). With interrupts in simulated time the step sequence is fixed.
    trackers: list[Any] = [ConsistencyTracker(interrupts=every),
                           CallbackTracker(guard, interrupts=every)]
    store: dict[float, Array] = {}
    if snapshots:
        times = sorted(float(s) for s in snapshots)

        def keep(field: ScalarField, t: float) -> None:
            store[round(t, 12)] = field.data.copy()

        trackers.append(CallbackTracker(keep, interrupts=times))
    if steady_tol is not None:
        trackers.append(SteadyStateTracker(interrupts=every, atol=steady_tol, rtol=0.0,
                                           evolution_rate=lambda d, t: disc.rate(d)))
    args = _solver_args(disc, stepper, rtol)
    t0 = time.perf_counter()
    # scipy's BDF may form inf - inf in its difference table on a trial step it then rejects
    # (seen under numpy errors raised: bdf.py "D[order + 2] = d - D[order + 1]"); that is its
    # own business, and every state it hands back is checked for finiteness by the guard
    with np.errstate(invalid="ignore", over="ignore"):
        try:
            final, info = eq.solve(state, t_range=t_end, tracker=trackers, ret_info=True,
                                   **args)
        except FPKFailure:
            raise
        except (AttributeError, RuntimeError, ValueError, ArithmeticError) as exc:
            # the integrator gave up (scipy's solve_ivp failing: py-pde then reads its
            # solution list as an array, AttributeError); say so in one line, the solver's
            # failure, not an internal error
            raise FPKFailure(
                f"the FPK time stepping ({stepper}, {disc.centres.size} cells, t_end = "
                f"{t_end:.3g}) stopped: {type(exc).__name__}: {str(exc).splitlines()[0][:160]}"
                "; the time range or the coefficients' range is too extreme for the "
                "integrator") from None
    seconds = time.perf_counter() - t0
    p = final.data.copy()
    guard(final, float(info["controller"].get("t_final", t_end)))
    ctrl = info.get("controller", {})
    absorbed = {t: float(v[inside:].sum()) * disc.h for t, v in store.items()}
    return {
        "p": p[:inside],
        "absorbed": float(p[inside:].sum()) * disc.h,
        "absorbed_snapshots": absorbed,
        "t_final": float(ctrl.get("t_final", t_end)),
        "steps": int(info.get("solver", {}).get("steps", 0)),
        "seconds": seconds,
        "stop_reason": str(ctrl.get("stop_reason", "")),
        "worst_mass_drift": guard.worst_mass,
        "min_value": guard.min_value,
        "checks": guard.checks,
        "snapshots": {t: v[:inside] for t, v in store.items()},
    }
