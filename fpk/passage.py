"""First passage of a 1-D diffusion out of [lo, Ac): the MFPT by quadrature, R(t) by stepping.

    dA = m(A) dt + sigma(A) dW,   zero flux (reflecting) at lo,   absorbing at Ac

Generic in m and sigma^2 (callables or (A, values) tables), nothing of vibro-impact.

``mfpt``: the Pontryagin equation (Gardiner, Handbook of Stochastic Methods, sec. 5.2.7;
docs/passage.md), m T' + (sigma^2/2) T'' = -1, T'(lo) = 0, T(Ac) = 0, solved by two
quadratures: with Phi(A) = int 2 m / sigma^2 (so s = e^-Phi is the scale density),

    T(A0) = int_{A0}^{Ac} G(y) dy,   G(y) = int_lo^y (2 / sigma^2(z)) e^{Phi(z) - Phi(y)} dz,

and a start density p0 gives int T(A0) p0(A0) dA0 = int_lo^Ac P0(y) G(y) dy (P0 its CDF).
Log space: Phi is built by integrating 2m/sigma^2 (never exponentiated alone), the inner
integral is accumulated as log F(y) = log int_lo^y (2/sigma^2) e^Phi, and G = e^{log F - Phi}.
Composite Gauss-Legendre: ``nodes`` points per interval; the partial integrals up to each node
use the spectral integration matrix of the interval's interpolating polynomial (the Gauss
collocation method), so the error is O(h^QUAD_ORDER), QUAD_ORDER = 2 nodes (measured in
tests/test_passage_fpk.py). With lo = 0, [0, Ac/8] is cut geometrically down to delta =
1e-12 Ac (octaves [a, 2a] split into intervals/8 intervals), because 2m/sigma^2 ~ k/A there
(the noise-induced drift of an amplitude) makes e^Phi ~ A^k and the error of an interval
[a, b] near 0 depends only on b/a. Below delta the inner integral is done analytically with
the local power law measured on the first interval (F(delta) = e^Phi (2/sigma^2) delta /
(kappa + 1)); it needs kappa > -1 (a normalisable stationary density at 0), else the wall at
0 is not reflecting and CoefficientError is raised. The result is computed on ``intervals``
and 2 x ``intervals`` intervals: ``value`` is the finer one, ``error_estimate``
|T_fine - T_coarse| (for an O(h^p) rule the finer one's error is that / (2^p - 1): an
upper bound with margin).

``reliability``: R(t) = P(no passage by t) by py-pde time stepping of the flux-form FPK
(scheme.discretise with ``right="absorbing"``), FPT density f = -dR/dt = the wall flux (exact
for the semi-discrete system), int_0^inf R dt by the two-point Hermite rule (R' = -f and
R'' = -f' known at every output time from the state) plus the tail R(t_end) / lambda_1
(lambda_1 the slowest decay rate of the absorbing operator, by inverse iteration with a
cancellation-free solve: scheme.Discretisation.decay_rate).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.polynomial import legendre

from vifpk.core.defaults import FPK_CELLS
from vifpk.core.result import Result, Status

from .scheme import ORDER, Array, CoefficientError, FPKFailure, discretise
from .solve import Coefficient, _versions, as_function

QUAD_NODES = 8  # Gauss-Legendre points per interval
DELTA = 1e-12  # the geometric cut near A = 0 goes down to DELTA * Ac
Start = float | str | Callable[[Array], Array]


def run(*args: Any, **kwargs: Any) -> dict[str, Any]:
    """``stepper.run``, py-pde imported on first use (importing ``vifpk.fpk`` imports none)."""
    from .stepper import run as step

    return step(*args, **kwargs)


def quad_order(nodes: int) -> int:
    """The declared order of the quadrature with ``nodes`` points per interval: 2 nodes.

    The nested rule is the Gauss (Gauss-Legendre collocation) Runge-Kutta method with
    coefficients S/2 applied to the triangular system Phi' = 2m/sigma^2, F' = (2/sigma^2)
    e^Phi, T' = -e^-Phi F, whose order at the interval ends is 2 nodes (Hairer, Norsett &
    Wanner, Solving ODEs I, sec. II.7); measured 2 nodes for nodes = 2, 3 on the Rayleigh
    amplitude and on an Ornstein-Uhlenbeck process (tests/test_passage_fpk.py)."""
    return 2 * nodes


QUAD_ORDER = quad_order(QUAD_NODES)


def _rule(n: int) -> tuple[Array, Array, Array]:
    """Gauss-Legendre nodes xi and weights w on [-1, 1], and the spectral integration matrix
    S[i, l] = int_{-1}^{xi_i} ell_l (ell_l the Lagrange basis of the nodes)."""
    xi, w = legendre.leggauss(n)
    V = legendre.legvander(xi, n - 1)
    Q = np.empty((n, n))
    for k in range(n):
        Q[:, k] = legendre.legval(xi, legendre.legint(np.eye(n)[k], lbnd=-1))
    return xi, w, Q @ np.linalg.inv(V)


def _per_octave(intervals: int) -> int:
    """Intervals per octave [a, 2a] of the geometric layer near 0 (one per 8 intervals)."""
    return max(1, -(-intervals // 8))


def _grid(lo: float, hi: float, intervals: int, a0: float | None) -> Array:
    """``intervals`` equal intervals on [lo, hi]; with lo = 0 they cover [hi/8, hi] and
    [delta, hi/8] is cut geometrically. Near a 1/A drift the error of an interval [a, b]
    depends on b/a only, so equal intervals next to 0 would leave an error ~ F(h) ~ h^(k+1)
    (measured: order 2 for the Rayleigh amplitude instead of the rule's); octaves split into
    a number of intervals growing with ``intervals`` keep the rule's order."""
    if lo > 0.0:
        x = lo + (hi - lo) / intervals * np.arange(intervals + 1)
    else:
        top = hi / 8.0
        x = top + (hi - top) / intervals * np.arange(intervals + 1)
        delta = DELTA * hi if a0 is None or a0 <= 0.0 else min(DELTA * hi, 0.5 * a0)
        j = _per_octave(intervals)
        k = math.ceil(math.log2(top / delta)) * j
        x = np.concatenate([top * 2.0 ** (-np.arange(k, 0, -1) / j), x])
    h = (hi - lo) / intervals
    if a0 is not None and x[0] < a0 < hi:
        i = int(np.argmin(np.abs(x - a0)))
        if abs(x[i] - a0) <= 1e-9 * h:
            x[i] = a0
        else:
            x = np.sort(np.append(x, a0))
    x[-1] = hi
    return x


def _pontryagin(m: Callable, s2: Callable, *, lo: float, hi: float, start: Start,
                intervals: int, nodes: int) -> dict[str, Any]:
    xi, w, S = _rule(nodes)
    a0 = float(start) if isinstance(start, (int, float)) else None
    x = _grid(lo, hi, intervals, a0)
    hw = 0.5 * np.diff(x)
    g = x[:-1, None] + hw[:, None] * (1.0 + xi[None, :])
    mv = np.asarray(m(g.ravel()), dtype=float).reshape(g.shape)
    sv = np.asarray(s2(g.ravel()), dtype=float).reshape(g.shape)
    if not (np.all(np.isfinite(mv)) and np.all(np.isfinite(sv)) and np.all(sv > 0)):
        raise CoefficientError("drift or diffusion is not finite and positive on "
                               f"[{x[0]:.3g}, {hi:.3g}]")
    v, lw = 2.0 * mv / sv, np.log(2.0 / sv)
    dphi = hw * (v @ w)
    phi_x = np.concatenate([[0.0], np.cumsum(dphi)])  # Phi(x_0) = 0
    phi_g = phi_x[:-1, None] + hw[:, None] * (v @ S.T)
    ell = phi_g + lw  # log of the inner integrand (2/sigma^2) e^Phi
    ref = np.max(ell, axis=1)
    e = np.exp(ell - ref[:, None])
    log_full = ref + np.log(hw * (e @ w))
    part = hw[:, None] * (e @ S.T)
    log_part = ref[:, None] + np.log(np.maximum(part, 1e-300))
    extra = 0
    head = 0.0  # int_0^delta G (lo = 0 only)
    if lo == 0.0:  # the analytic piece on [0, delta]: local power laws measured on [d, 2d]
        d = x[0]
        s_end = np.asarray(s2(np.array([d, x[1]])), dtype=float)
        extra = 2
        slope_w = math.log(s_end[0] / s_end[1]) / math.log(x[1] / d)
        kappa = dphi[0] / math.log(x[1] / d) + slope_w
        if not kappa > -1.0:
            raise CoefficientError(
                f"the stationary density is not integrable at A = 0 (local power {kappa:.3g}"
                " <= -1): a reflecting wall at 0 does not apply")
        log_f0 = math.log(2.0 / s_end[0]) + math.log(d / (kappa + 1.0))
        lam = 1.0 + slope_w  # G ~ y^lam near 0
        if isinstance(start, (int, float)) and start == 0.0:
            if not lam > -1.0:
                raise CoefficientError("the MFPT from A = 0 is infinite (A = 0 is not "
                                       "reached from inside: an entrance boundary)")
            head = d * math.exp(log_f0) / (lam + 1.0)
    else:
        log_f0 = -np.inf
    log_fx = np.logaddexp.accumulate(np.concatenate([[log_f0], log_full]))
    log_fg = np.logaddexp(log_fx[:-1, None], log_part)
    with np.errstate(over="ignore"):  # T beyond 1e308: reported by mfpt as a failure
        G = np.exp(log_fg - phi_g)
    t_int = hw * (G @ w)
    T_x = np.concatenate([np.cumsum(t_int[::-1])[::-1], [0.0]])
    if callable(start) or start == "stationary":
        if callable(start):
            pv = np.maximum(np.asarray(start(g.ravel()), dtype=float).reshape(g.shape), 0.0)
            P_x = np.concatenate([[0.0], np.cumsum(hw * (pv @ w))])
            total = P_x[-1]
            if not (math.isfinite(total) and total > 0):
                raise ValueError("the start density has no positive finite mass on "
                                 f"[{lo:g}, {hi:g}]")
            P_g = (P_x[:-1, None] + hw[:, None] * (pv @ S.T)) / total
        else:
            P_g = np.exp(log_fg - log_fx[-1])
        value = float(np.sum(hw * ((P_g * G) @ w)))
    elif isinstance(start, str):
        raise ValueError(f"start must be an amplitude, 'stationary' or a density, not {start!r}")
    else:
        value = float(T_x[int(np.searchsorted(x, a0))]) + head
    return {"value": value, "A": x, "T": T_x,
            "evaluations": 2 * g.size + extra + (g.size if callable(start) else 0)}


def _check_range(lo: float, threshold: float, start: Any) -> None:
    if not (math.isfinite(threshold) and threshold > lo >= 0.0):
        raise ValueError(f"threshold must be finite and above lo = {lo:g}, got {threshold!r}")
    if isinstance(start, (int, float)) and not lo <= start < threshold:
        raise ValueError(f"start amplitude must lie in [{lo:g}, {threshold:g}), got {start!r}")


def mfpt(drift: Coefficient, diffusion: Coefficient, *, threshold: float, start: Start,
         lo: float = 0.0, intervals: int = 16, nodes: int = QUAD_NODES, rtol: float = 1e-7,
         max_intervals: int = 512) -> dict[str, Any]:
    """Mean first-passage time from ``start`` (an amplitude in [lo, threshold), a density
    callable on [lo, threshold] normalised there, or "stationary": the diffusion's own
    stationary density restricted to [lo, threshold)) to ``threshold``, reflecting at lo.

    The grid doubles (from ``intervals``) until the two-grid estimate is below ``rtol`` T or
    the finer grid reaches ``max_intervals`` (``converged`` says which): a high threshold,
    where Phi changes by many units across an interval, needs more intervals. rtol = 1e-7 is
    100x below the time-stepped route's O(h^2) error at 400 cells (1e-5 on paper-base);
    tabulated coefficients (piecewise-linear interpolation, as the ``corrected`` model's)
    have kinks that cut the order to about 2, and asking 1e-9 of them cost 3-6 s for nothing
    (benchmarks/results/passage_averaged.json).

    Returns {"value", "error_estimate" (|T(2 intervals) - T(intervals)|), "value_coarse",
    "converged", "order" (declared), "intervals", "nodes", "curve": {"A", "T"} (T(A0) at the
    fine grid's nodes), "evaluations" (of drift/diffusion), "seconds", "method"}.
    """
    t0 = time.perf_counter()
    _check_range(lo, threshold, start)
    if intervals < 2 or nodes < 2:
        raise ValueError(f"need intervals >= 2 and nodes >= 2, got {intervals}, {nodes}")
    m, s2 = as_function(drift, "drift"), as_function(diffusion, "diffusion")
    kw = {"lo": float(lo), "hi": float(threshold), "start": start, "nodes": nodes}
    coarse = _pontryagin(m, s2, intervals=intervals, **kw)
    while True:
        fine = _pontryagin(m, s2, intervals=2 * intervals, **kw)
        value = fine["value"]
        if not math.isfinite(value):
            raise FPKFailure(f"the MFPT overflows (> 1e308 time units) at threshold "
                             f"{threshold:g}: far beyond reach")
        err = max(abs(value - coarse["value"]), 1e-14 * abs(value))
        if err <= rtol * abs(value) or 2 * intervals >= max_intervals:
            break
        intervals, coarse = 2 * intervals, fine
    return {"value": value, "error_estimate": err, "value_coarse": coarse["value"],
            "converged": bool(err <= rtol * abs(value)),
            "order": quad_order(nodes), "intervals": 2 * intervals, "nodes": nodes,
            "curve": {"A": fine["A"], "T": fine["T"]},
            "evaluations": coarse["evaluations"] + fine["evaluations"],
            "seconds": time.perf_counter() - t0,
            "method": "Pontryagin double quadrature in log space (composite Gauss-Legendre)"}


def _start_density(disc: Any, start: Start) -> tuple[Array, float]:
    """The cell densities of the start (mass inside) and the mass on the wall at t = 0.

    An amplitude A0 is the discrete delta: unit mass split linearly between the two cells
    whose centres bracket A0 (the hat function), so any smooth functional of the solution
    (R(t), its integral) errs by O(h^2) like the scheme; between the last centre and the wall
    the share of the wall (where p = 0) is absorbed at t = 0."""
    c, h, n = disc.centres, disc.h, disc.cells
    p = np.zeros(n)
    if callable(start):
        p = np.maximum(np.asarray(start(c), dtype=float), 0.0)
        mass = float(np.sum(p) * h)
        if not (math.isfinite(mass) and mass > 0):
            raise ValueError("the start density has no positive finite mass on the grid")
        return p / mass, 0.0
    if start == "stationary":
        return np.exp(disc.stationary_log()), 0.0
    if isinstance(start, str):
        raise ValueError(f"start must be an amplitude, 'stationary' or a density, not {start!r}")
    a0 = float(start)
    if a0 <= c[0]:
        p[0] = 1.0 / h
        return p, 0.0
    if a0 >= c[-1]:
        theta = (a0 - c[-1]) / (disc.hi - c[-1])
        p[-1] = (1.0 - theta) / h
        return p, theta
    i = int(np.searchsorted(c, a0)) - 1
    theta = (a0 - c[i]) / h
    p[i], p[i + 1] = (1.0 - theta) / h, theta / h
    return p, 0.0


def _hermite(dt: Array, y: Array, d1: Array, d2: Array) -> float:
    """int y dt over the output times by the two-point Hermite (Obreschkoff) rule with first
    and second derivatives: dt/2 (y0 + y1) + dt^2/10 (y0' - y1') + dt^3/120 (y0'' + y1''),
    exact for quintics, error O(dt^7) per step (Hildebrand, Introduction to Numerical
    Analysis, sec. 8.6)."""
    return float(np.sum(0.5 * dt * (y[1:] + y[:-1]) + dt**2 / 10.0 * (d1[:-1] - d1[1:])
                        + dt**3 / 120.0 * (d2[:-1] + d2[1:])))


def _output_times(tau: float, t_end: float, per_decay: int) -> Array:
    """0, a geometric run from 1e-6 tau to tau / per_decay (the quick early losses of a start
    near the wall), then steps of tau / per_decay; t_end is always the last time."""
    step = tau / per_decay
    first = min(step, t_end)
    early = np.geomspace(min(1e-6 * tau, 1e-3 * first), first, 25)
    late = np.arange(step, t_end, step)
    return np.unique(np.concatenate([[0.0], early, late, [t_end]]))


def reliability(drift: Coefficient, diffusion: Coefficient, *, threshold: float,
                start: Start | None = None, p0: Callable[[Array], Array] | None = None,
                t_end: float | None = None, times: Sequence[float] | None = None,
                cells: int = FPK_CELLS, lo: float = 0.0, stepper: str = "bdf",
                rtol: float = 1e-9, tail: float = 1e-10, per_decay: int = 4,
                dense: int = 8) -> Result:
    """R(t), the FPT density and int_0^inf R dt by time stepping the FPK with p = 0 at
    ``threshold`` and zero flux at lo, from ``start`` (an amplitude, "stationary" or a density;
    ``p0`` is the same as a density start).

    Times: ``times`` if given (plus 0), else 0, a geometric early run and steps of
    tau / per_decay (tau = 1 / lambda_1) up to ``t_end`` (default tau ln(1 / tail), where a
    single-mode R has fallen to ``tail``). data["R"] = {"t", "R", "knots"},
    data["fpt_density"] = {"t", "p"}: at the stepped times ("knots") and, without ``times``,
    ``dense`` points per step between them by quintic Hermite interpolation;
    info["mfpt_integral"] = int_0^t_end R dt (two-point Hermite rule, R' = -f, R'' = -f') +
    R(t_end) / lambda_1; info["mfpt_discrete"] = h 1^T (-M)^{-1} p0, the same integral for the
    semi-discrete system without time stepping (their gap is the time-integration error);
    info["decay_rate"] = lambda_1; the mass balance inside + absorbed = 1 is checked by the
    stepper at every interrupt (FPKFailure beyond 1e-10, or the solves' round-off bound
    eps t ||M||_1 on very long runs: stepper._Guard) and its worst value reported.
    """
    t0 = time.perf_counter()
    if p0 is not None:
        if start is not None:
            raise ValueError("give start or p0, not both")
        start = p0
    if start is None:
        raise ValueError("reliability needs a start (an amplitude, 'stationary' or a density)")
    _check_range(lo, threshold, start)
    m, s2 = as_function(drift, "drift"), as_function(diffusion, "diffusion")
    disc = discretise(m, s2, lo=lo, hi=threshold, cells=cells, right="absorbing")
    lam = disc.decay_rate()
    tau = 1.0 / lam
    p_start, absorbed0 = _start_density(disc, start)
    if times is not None:
        ts = np.array(sorted(float(t) for t in times), dtype=float)
        if ts.size == 0 or ts[0] < 0 or not np.all(np.isfinite(ts)):
            raise ValueError("times must be finite and >= 0")
        ts = np.unique(np.concatenate([[0.0], ts]))
    else:
        end = tau * math.log(1.0 / tail) if t_end is None else float(t_end)
        if not (math.isfinite(end) and end > 0):
            raise ValueError(f"t_end must be positive and finite, got {t_end!r}")
        ts = _output_times(tau, end, per_decay)
    out = run(disc, p_start, t_end=float(ts[-1]), stepper=stepper, rtol=rtol,
              snapshots=list(ts[1:]), check_every=float(ts[-1]) / 20.0)
    snaps, sink = out["snapshots"], out["absorbed_snapshots"]
    keys = sorted(snaps)
    if not keys:  # issue 39 X14: R(t) at t = 0 alone (R[-2] was an IndexError)
        raise FPKFailure(
            f"the FPK time stepping recorded R(t) at none of its {ts.size - 1} output times "
            f"(t_end = {ts[-1]:.3g}, 1 / lambda_1 = {tau:.3g}; stopped at t = "
            f"{out['t_final']:.3g}: {out['stop_reason'] or 'no reason given'}); the time "
            "range is too extreme for the integrator")
    t = np.concatenate([[0.0], np.array(keys)])
    P = np.vstack([p_start] + [snaps[k] for k in keys])
    R = P.sum(axis=1) * disc.h
    f = disc.wall_rate * disc.h * P[:, -1]  # J at the wall = -dR/dt
    absorbed = np.concatenate([[absorbed0], absorbed0 + np.array([sink[k] for k in keys])])
    dt = np.diff(t)
    # derivatives at every output time from the state: R' = -f, f' and f'' from (M p)_{N-1}
    # and (M^2 p)_{N-1} (the wall flux is wall_rate h p_{N-1})
    Mp = np.array([disc.rate(row.copy()) for row in P])
    MMp = np.array([disc.rate(row) for row in Mp])
    df, ddf = disc.wall_rate * disc.h * Mp[:, -1], disc.wall_rate * disc.h * MMp[:, -1]
    body = _hermite(dt, R, -f, -df)
    flux_int = _hermite(dt, f, df, ddf)
    tail_part = float(R[-1]) / lam
    discrete = float(np.sum(disc.solve_absorbing(p_start)) * disc.h)
    rate_end = (float(math.log(R[-2] / R[-1]) / dt[-1])
                if R[-1] > 0 and R[-2] > 0 and dt[-1] > 0 else float("nan"))
    ok = bool(np.all(np.isfinite(R)) and out["min_value"] >= -1e-12 * float(np.max(P)))
    info = {
        "solver": "fpk", "method": "reliability", "order": ORDER,
        "scheme": "Scharfetter-Gummel finite volume, absorbing right wall",
        "grid": {"cells": cells, "A_min": lo, "A_max": threshold, "h": disc.h},
        "threshold": threshold, "start": start if not callable(start) else "density",
        "decay_rate": lam, "mfpt_integral": body + tail_part, "mfpt_tail": tail_part,
        "mfpt_discrete": discrete, "t_end": float(t[-1]),
        "diagnostics": {
            "steps": out["steps"], "checks": out["checks"], "min": out["min_value"],
            "worst_mass_drift": out["worst_mass_drift"],
            "mass_balance": float(np.max(np.abs(R + absorbed - 1.0))),
            "wall_flux_integral_gap": abs(flux_int - (absorbed[-1] - absorbed0)),
            "time_integration_gap": abs(body + tail_part - discrete),
            "tail_rate_measured": rate_end, "R_end": float(R[-1]),
        },
        "seconds": {"total": time.perf_counter() - t0, "stepping": out["seconds"]},
        "versions": _versions(stepping=True),
        "status": (Status.PASSAGE if ok else Status.NOT_FINITE).record(f"{t.size} times"),
        "warnings": [],
    }
    # the tail R(t_end) / lambda_1 assumes one mode is left; when the tail matters (> 1e-4 of
    # the integral) the measured late rate must agree with lambda_1 (within 1%)
    if tail_part > 1e-4 * (body + tail_part) and not abs(rate_end / lam - 1.0) <= 0.01:
        info["warnings"].append(
            f"the tail beyond t_end = {t[-1]:.4g} ({tail_part / (body + tail_part):.1%} of int R"
            f" dt) assumes R ~ e^(-lambda_1 t), but R decays there at {rate_end:.4g}, not "
            f"lambda_1 = {lam:.4g}: step further (t_end) for an accurate mfpt_integral")
    if times is None and dense > 1:
        td, Rd, fd = _dense(t, R, f, df, ddf, dense)
        info["curves"] = (f"quintic Hermite between the {t.size} stepped times (R, R', R'' "
                          f"and f, f', f'' known there), {dense} points per step")
    else:
        td, Rd, fd = t, R, f
        info["curves"] = "the stepped times"
    data = {"R": {"t": td, "R": Rd, "knots": t}, "fpt_density": {"t": td, "p": fd},
            "absorbed": {"t": t, "mass": absorbed}, "A_cells": {"x": disc.centres, "p": P[-1]}}
    return Result(data=data, info=info)


def _dense(t: Array, R: Array, f: Array, df: Array, ddf: Array,
           per_step: int) -> tuple[Array, Array, Array]:
    """R and f on ``per_step`` points per output step by quintic Hermite interpolation (their
    first two derivatives are known at the output times): a curve that linear interpolation
    reads to ~1e-5 (steps of 1 / (4 lambda_1) read linearly would err by ~1% of R)."""
    from scipy.interpolate import BPoly

    frac = np.arange(per_step) / per_step
    td = np.append((t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel(), t[-1])
    Rp = BPoly.from_derivatives(t, np.column_stack([R, -f, -df]))
    fp = BPoly.from_derivatives(t, np.column_stack([f, df, ddf]))
    return td, np.clip(Rp(td), 0.0, 1.0), np.maximum(fp(td), 0.0)
