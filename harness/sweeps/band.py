"""Where a band sweep spends its next Monte Carlo: a new point, or more samples at a point it
has, whichever is expected to shrink the tolerance band most per path-step (issue 29, item 3;
the derivation in docs/maps.md, "The band refiner").

**The band.** The error surface (surface.py) gives at x the latent log error g(x) ~
N(mu(x), sd(x)^2); x is in the band when |a(x)| < z sd(x), a = log T - mu, z = Phi^-1(0.95):
P(inside) is between 5% and 95% there. Its area is the share of the map where the tolerance
verdict is not yet known at 90%.

**One more observation.** An observation of g at c with noise variance n_c (the linearised
noise of surface.py, tau^2, plus the fitted nugget) changes the posterior at x to

    sd'(x)^2 = sd(x)^2 - cov(x, c)^2 / (sd(c)^2 + n_c)        (R&W 2006, eq. 2.24, rank one)

and its mean to mu'(x), which before the observation is normal about mu(x) with variance
v(x)^2 = sd(x)^2 - sd'(x)^2 (the preposterior: the law of total variance). So x stays in the
band with probability

    P(|a'| < z sd') = Phi((z sd' - a) / v) - Phi((-z sd' - a) / v),     a' ~ N(a, v^2),

and the expected area of the band after the observation is the mean of that over an EVAL x
EVAL grid of the map. The same holds for a set S of observations chosen together (a batch):
sd_S by successive rank-one updates of the covariance (which does not depend on the values
observed), v_S^2 = sd^2 - sd_S^2.

**A new point or more samples.** A new point at c is an observation with the noise of a new
point: tau = s / exp(max(mu(c), log s)) with s the median standard error of the first
points' estimates (surface.py's linearisation), plus the nugget. Extending point i's Monte
Carlo to half its variance (its floor / sqrt 2, about its sampled windows again) turns its
noise variance from A = tau_i^2 + nugget into B = tau_i^2 / 2 + nugget (the nugget, scatter
that more samples do not remove, stays): the same posterior as a second observation at x_i
with noise variance A B / (A - B) (precisions add).

**Per second.** Each candidate's gain (area now minus expected area after) is divided by its
cost in the Monte Carlo's path-steps, seconds at the kernel's rate: a new point costs what the
first points did (the median of their path-steps, burn-in included), an extension its point's
sampled path-steps so far. Path-steps, not measured seconds, so that the choice is the same on
every executor, at any load and after a resume. A batch is chosen greedily: the best ratio, the
covariance updated as if it were observed, the next best, ... (a point is extended at most
once a batch and at most MAX_STAGE times in all). Ties go to the first candidate (new points
in lattice order, then the points in the order they were added): the choice is a pure function
of the surface.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from vifpk.harness.sweeps.surface import Surface

EVAL = {1: 401, 2: 41}  # the grid (per axis) on which the band's expected area is averaged
MAX_STAGE = 4  # extensions of one point at most: floor / 4, 16 x its first sampled windows
EXTEND_VARIANCE = 0.5  # an extension aims at this fraction of the estimate's variance
Z = 1.6448536269514729  # Phi^-1(0.95): the band is BAND = (0.05, 0.95) (tests check the two agree)


@dataclass(frozen=True, kw_only=True)
class Candidate:
    """A new point (``key`` None) at ``unit``, or more samples at the point ``key``."""

    unit: tuple[float, ...]
    cost: float  # path-steps
    key: str | None = None
    noise_sd: float | None = None  # an existing point's linearised noise sd (tau_i)


@dataclass(frozen=True, kw_only=True)
class Choice:
    """A chosen action, with what it was expected to do."""

    unit: tuple[float, ...]
    key: str | None
    gain: float  # expected reduction of the band's area (share of the map)
    cost: float  # path-steps

    @property
    def kind(self) -> str:
        return "new" if self.key is None else "extend"


def eval_grid(dims: int) -> np.ndarray:
    """The unit grid on which the band's area is averaged (EVAL points per axis)."""
    g = np.linspace(0.0, 1.0, EVAL[dims])
    if dims == 1:
        return g[:, None]
    gu, gv = np.meshgrid(g, g, indexing="ij")
    return np.column_stack([gu.ravel(), gv.ravel()])


def lattice(dims: int, resolution: int) -> list[tuple[float, ...]]:
    """Candidate places of new points: the resolution^dims lattice of the unit cube."""
    from vifpk.harness.sweeps.adaptive import _quantise

    axis = [_quantise(i / (resolution - 1)) for i in range(resolution)]
    if dims == 1:
        return [(u,) for u in axis]
    return [(a, b) for a in axis for b in axis]


def _cov(model: Any, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The latent GP's posterior covariance between unit points ``a`` and ``b``:
    k(a, b) - v_a^T v_b, v = L^-1 k(X, .) with the fitted regressor's Cholesky factor L."""
    from scipy.linalg import solve_triangular

    k = model.kernel_
    va = solve_triangular(model.L_, k(model.X_train_, a), lower=True, check_finite=False)
    vb = solve_triangular(model.L_, k(model.X_train_, b), lower=True, check_finite=False)
    return k(a, b) - va.T @ vb


def expected_area(a: np.ndarray, sd0_sq: np.ndarray, sd_sq: np.ndarray) -> np.ndarray:
    """Mean over the grid (axis 0) of P(|a'| < Z sd'), a' ~ N(a, sd0^2 - sd'^2) (module
    docstring); columns of ``sd_sq`` are alternatives."""
    from scipy.special import ndtr

    shape = (a.shape[0], *([1] * (sd_sq.ndim - 1)))
    a, sd0_sq = a.reshape(shape), sd0_sq.reshape(shape)
    sd = np.sqrt(np.maximum(sd_sq, 0.0))
    v = np.sqrt(np.maximum(sd0_sq - sd_sq, 1e-24))
    return np.mean(ndtr((Z * sd - a) / v) - ndtr((-Z * sd - a) / v), axis=0)


def choose(surface: Surface, candidates: Sequence[Candidate], size: int, *,
           new_noise_sd: float, budget: float = math.inf) -> list[Choice]:
    """Up to ``size`` actions (module docstring), whose costs add up to at most ``budget``
    path-steps (the first is taken whatever its cost); none when no candidate shrinks the band.

    ``new_noise_sd``: s, the standard error a new point's estimate is expected to have."""
    if not candidates or size <= 0:
        return []
    from vifpk.harness.door.boundary import one_blas_thread

    model, mean = surface._model, surface._mean
    nugget = float(surface.hyperparameters["nugget"])
    dims = len(surface.axes)
    e = eval_grid(dims)
    c = np.array([cand.unit for cand in candidates], float)
    with one_blas_thread():
        mu_e, sd_e = model.predict(e, return_std=True)
        mu_c = model.predict(c) + mean
        cov_ec = _cov(model, e, c)
        cov_cc = _cov(model, c, c)
    a = math.log(surface.tolerance) - (mu_e + mean)
    sd0_sq = np.asarray(sd_e, float) ** 2
    noise = np.empty(len(candidates))
    for j, cand in enumerate(candidates):
        if cand.key is None:  # a new point: surface.py's linearisation at the surface
            tau = new_noise_sd / math.exp(max(mu_c[j], math.log(max(new_noise_sd, 1e-300))))
            noise[j] = tau**2 + nugget
        else:  # its noise from A = tau^2 + nugget to B: a second observation, A B / (A - B)
            big = cand.noise_sd**2 + nugget
            small = EXTEND_VARIANCE * cand.noise_sd**2 + nugget
            noise[j] = big * small / (big - small) if big > small else math.inf
    cost = np.array([cand.cost for cand in candidates], float)
    sd_sq = sd0_sq.copy()
    area = float(expected_area(a, sd0_sq, sd_sq[:, None])[0])
    open_ = np.isfinite(noise) & (cost > 0)
    out: list[Choice] = []
    spent = 0.0
    for _ in range(size):
        if not open_.any():
            break
        var_c = np.maximum(np.diag(cov_cc), 0.0) + noise
        with np.errstate(invalid="ignore", divide="ignore"):
            after = sd_sq[:, None] - np.where(open_, cov_ec**2 / var_c, 0.0)
        areas = expected_area(a, sd0_sq, after)
        gain = np.where(open_, area - areas, -np.inf)
        fits = open_ & ((spent + cost <= budget) | (not out))
        score = np.where(fits, gain / cost, -np.inf)
        j = int(np.argmax(score))
        if not (np.isfinite(score[j]) and gain[j] > 0):
            break
        out.append(Choice(unit=candidates[j].unit, key=candidates[j].key,
                          gain=float(gain[j]), cost=float(cost[j])))
        spent += cost[j]
        area = float(areas[j])
        col = cov_cc[:, j].copy()
        ec = cov_ec[:, j].copy()
        sd_sq = sd_sq - ec**2 / var_c[j]
        cov_ec = cov_ec - np.outer(ec, col) / var_c[j]
        cov_cc = cov_cc - np.outer(col, col) / var_c[j]
        open_[j] = False
    return out
