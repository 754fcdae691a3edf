"""Stationary amplitude density of a 1-D averaged model, normalised in log space.

A model supplies ``log_stationary_parts(A) -> (q, log_pre, log_phase_pre)`` with

    log p_A(A) = log_pre(A) + Psi(A) - log Z,    Psi(A) = int_{A_lo}^A q(u) du,

q regular on (0, inf) (the 1/A singularity of 2m/sigma^2 is moved into log_pre). Psi is
accumulated with 3-point Gauss-Legendre per grid interval (order 6), so q is never evaluated
at A = 0. log Z is taken from the shifted exponentials (max subtracted), so nothing
overflows for small D. Densities are normalised to trapezoid mass 1 on their grid.

The support [A_lo, A_max] is found by scanning: A_max doubles until log p has fallen 60 below
its maximum, then the grid is cut where the mass outside is below ``tail`` (default 1e-10,
so that the grid holds at least 1 - 1e-8 of the mass); one zoom re-scan resolves narrow peaks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from .geometry import Array

GL3_X, GL3_W = np.polynomial.legendre.leggauss(3)
A_LIMIT = 1e4


class NoStationaryDensity(RuntimeError):
    """The averaged FPK has no normalisable stationary solution for this scene."""


class DensityDoesNotDecay(NoStationaryDensity):
    """No stationary density because the density does not decay up to A_LIMIT (energy input
    exceeds dissipation at large amplitude); callers tell it by type, not by its words."""


class StationaryModel(Protocol):
    def log_stationary_parts(self, A: Array) -> tuple[Array, Array, Array]: ...
    def period(self, A: Array) -> Array: ...


@dataclass(frozen=True)
class AmplitudeDensity:
    """p_A on a uniform grid, with h = log p(y, y') = log(p_E / T) on the same grid."""

    A: Array
    p: Array
    log_p: Array
    log_h: Array
    tail_mass: float
    scans: int


def _cumulative(model: StationaryModel, edges: Array) -> tuple[Array, Array, Array]:
    """Psi at the edges (Psi[0] = 0), log_pre and log_phase_pre at the edges."""
    a, b = edges[:-1], edges[1:]
    mid, half = 0.5 * (a + b), 0.5 * (b - a)
    nodes = mid[:, None] + half[:, None] * GL3_X[None, :]
    q, _, _ = model.log_stationary_parts(nodes.ravel())
    q = q.reshape(nodes.shape)
    if not np.all(np.isfinite(q)):
        bad = nodes[~np.isfinite(q)][0]
        raise NoStationaryDensity(f"the drift/diffusion ratio is not finite at A = {bad:.4g}")
    psi = np.concatenate([[0.0], np.cumsum(half * (q @ GL3_W))])
    _, log_pre, log_phase = model.log_stationary_parts(edges)
    return psi, log_pre, log_phase


def _support(A: Array, lp: Array, tail: float) -> tuple[float, float, float]:
    """Cut [A_lo, A_hi] with at most tail/2 of the (trapezoid) mass on either side."""
    w = np.exp(lp - np.max(lp))
    cell = 0.5 * (w[1:] + w[:-1]) * np.diff(A)
    cdf = np.concatenate([[0.0], np.cumsum(cell)])
    cdf /= cdf[-1]
    lo_idx = max(int(np.searchsorted(cdf, 0.5 * tail, side="right")) - 1, 0)
    hi_idx = min(int(np.searchsorted(cdf, 1.0 - 0.5 * tail, side="left")) + 1, len(A) - 1)
    outside = cdf[lo_idx] + (1.0 - cdf[hi_idx])
    return float(A[lo_idx]), float(A[hi_idx]), float(outside)


FALL = 60.0  # the scan stops where log p has fallen this far below its maximum


@dataclass(frozen=True)
class Reach:
    """The closed form's scan of log p_A (unnormalised) on [0, hi], hi doubling from A_start:
    ``held`` when log p fell by FALL below its maximum before hi passed A_LIMIT, ``fall`` the
    largest fall seen on the last scan (max log p - log p(hi)), ``edges``/``log_p`` the last
    scan, ``scans`` how many."""

    held: bool
    fall: float
    edges: Array
    log_p: Array
    scans: int


def reach(model: StationaryModel, *, scan: int = 512, A_start: float = 2.0) -> Reach:
    """Does the model's law fall by e^FALL before A = A_LIMIT (the grid the closed form and the
    FPK can hold)? The scan of :func:`amplitude_density`, written once: hi doubles until
    log p(hi) < max log p - FALL, or past A_LIMIT (``held`` False; the request asks it before
    any work, harness/door/reach.py ``law_reach``)."""
    hi, scans, best = A_start, 0, -math.inf
    while True:
        edges = np.linspace(0.0, hi, scan + 1)
        psi, log_pre, _ = _cumulative(model, edges)
        lp = log_pre + psi
        scans += 1
        top = np.max(lp[np.isfinite(lp)])
        best = max(best, float(top - lp[-1]))
        if lp[-1] < top - FALL:
            return Reach(True, best, edges, lp, scans)
        hi *= 2.0
        if hi > A_LIMIT:
            return Reach(False, best, edges, lp, scans)


def amplitude_density(model: StationaryModel, *, points: int = 801, tail: float = 1e-10,
                      scan: int = 512, A_start: float = 2.0, tail_mass: bool = True
                      ) -> AmplitudeDensity:
    """Normalised stationary p_A on a grid of ``points`` nodes holding all but ~tail.

    ``tail_mass=False`` skips the measurement of the mass outside the grid (a scan of 4 x
    ``scan`` intervals over three times the support, about half the cost; the field is then
    NaN): the grid is the same either way."""
    found = reach(model, scan=scan, A_start=A_start)
    if not found.held:
        raise DensityDoesNotDecay(
            f"the amplitude density does not decay up to A = {A_LIMIT:g}: energy input "
            "exceeds dissipation at large amplitude, so there is no stationary density")
    edges, lp, scans = found.edges, found.log_p, found.scans
    lo, hi, _ = _support(edges, lp, tail)
    # zoom once on the support so that narrow peaks (small D) are resolved by the scan
    if hi - lo < 0.25 * edges[-1]:
        pad = 0.5 * (hi - lo)
        edges = np.linspace(max(lo - pad, 0.0), hi + pad, scan + 1)
        psi, log_pre, _ = _cumulative(model, edges)
        lp = log_pre + psi
        scans += 1
        lo2, hi, _ = _support(edges, lp, tail)
        lo = lo2 if lo > 0.0 else 0.0
    grid = np.linspace(lo, hi, points)
    psi, log_pre, log_phase = _cumulative(model, grid)
    log_p = log_pre + psi
    top = np.max(log_p)
    mass = np.trapezoid(np.exp(log_p - top), grid)
    log_z = top + math.log(mass)
    log_p = log_p - log_z
    if not tail_mass:
        return AmplitudeDensity(A=grid, p=np.exp(log_p), log_p=log_p,
                                log_h=log_phase + psi - log_z, tail_mass=math.nan, scans=scans)
    # mass outside the grid: from a scan that extends both sides beyond it
    wide = np.linspace(max(lo - (hi - lo), 0.0), hi + (hi - lo), 4 * scan + 1)
    wpsi, wpre, _ = _cumulative(model, wide)
    wlp = wpre + wpsi
    wp = np.exp(wlp - np.max(wlp))
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (wp[1:] + wp[:-1]) * np.diff(wide))])
    cdf /= cdf[-1]
    tail_mass = float(np.interp(lo, wide, cdf) + 1.0 - np.interp(hi, wide, cdf))
    return AmplitudeDensity(A=grid, p=np.exp(log_p), log_p=log_p, log_h=log_phase + psi - log_z,
                            tail_mass=tail_mass, scans=scans)


def describe(A: Array, p: Array) -> dict[str, Any]:
    """Mass, mean, mode and standard deviation of a density on a grid (trapezoid)."""
    mass = float(np.trapezoid(p, A))
    mean = float(np.trapezoid(A * p, A) / mass)
    var = float(np.trapezoid((A - mean) ** 2 * p, A) / mass)
    return {"mass": mass, "mean": mean, "mode": float(A[int(np.argmax(p))]),
            "std": math.sqrt(max(var, 0.0)), "min": float(np.min(p))}
