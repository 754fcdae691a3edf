"""The averaging error as a surface over a sweep's parameters, with its uncertainty, and the
tolerance boundary with a band (issue 29, item 2; derivation in docs/maps.md, "The error
surface and its band").

**Model.** At each finished point i (parameters x_i, each axis mapped to [0, 1], through its
logarithm where the sweep's values are log-spaced) the tolerance verdict (harness/tolerance.py)
gives the model's error with the Monte Carlo's noise removed, L_i (``error_estimate``), and its
standard error s_i (``error_estimate_err``). The error surface is exp(g), with the log error g a
Gaussian process, and the estimates its noisy observations:

    L_i = exp(g(x_i)) + e_i,      e_i ~ N(0, s_i^2)        (tolerance.py's interval, too)
    g   ~ GP(m, b + c Matern_5/2(x, x'; l_1..l_d)),

the logarithm making relative changes of the error the smooth quantity and the surface
positive. exp(g) is linearised at the current estimate g0_i of g(x_i) (Gauss-Newton), which
turns each point into an observation of g with its own noise:

    y_i = g0_i + (L_i - exp(g0_i)) / exp(g0_i),       tau_i = s_i / exp(g0_i),

the GP posterior with a noise variance tau_i^2 per point (Rasmussen & Williams 2006, "Gaussian
Processes for Machine Learning", eq. 2.22-2.24; sklearn's GaussianProcessRegressor with
``alpha`` = tau_i^2 + nugget) gives new g0_i (its mean at the points), and this is repeated to
the fixed point (|change| < ITERATION_TOL, at most ITERATIONS): the Laplace approximation with
the Gauss-Newton Hessian (R&W section 3.4 for the idea). The obvious shortcut, y_i = log L_i
with tau_i = s_i / L_i, weights each point by its *own* noise (a point that came out high gets a
small tau, one that came out low a large one) and biases the surface up: on the synthetic test
(noise 0.3 x tolerance, 20 seeds) the surface stood 1.1 posterior sd too high on the true
boundary and the 5-95% band covered 68% of it instead of 90%; linearised at the surface,
0.2 sd too low and 93%.

**Below the noise.** Where exp(g0_i) < s_i the likelihood N(L_i; exp(g), s_i^2) is flat in g
(any error much below s_i fits): what the point knows is one-sided, "the error is about s_i or
less", and a linearisation at g0_i -> -inf would make it worthless (tau_i -> inf). So exp(g) is
linearised at max(g0_i, log s_i): tau_i <= 1, and an estimate of 0 (the debiasing returns 0
where the measured L1 is below its noise floor) reads y_i = log s_i - 1 +/- 1, "about s_i / e,
give or take a factor e". The price is a false lower bound (the surface cannot go much below
s_i / e^2 near such a point), on the side of "outside": it matters for the boundary only where
the tolerance is within a factor e^2 of s_i, where the point cannot decide anyway. Without it
a map whose estimates are all 0 +/- 1e-3 (tolerance 0.02) came out inside with P = 0.80 only.

**The floor.** g0 and the y_i are kept >= log(FLOOR_FRACTION x tolerance), the linearisation
point too where s_i = 0: an error a thousand times below the tolerance is inside it whatever
its exact value, and estimates of 0 +/- 0 would drive g to -inf. ``floored`` marks the points
whose y_i is at the floor.

The constant mean is integrated out: a constant kernel term of variance MEAN_VARIANCE = 100
(sd 10 in log units, vague: every L1 lies in (1e-4, 2), a log range of 10) about a centre m,
the median of the informative y_i (tau_i <= 1); far from the points the GP reverts to the
generalised-least-squares mean, with its uncertainty in sd. (The plain mean of the y_i as a
fixed centre failed on a real map: the corrected model of docs/data/maps-r-mu-adaptive.nc has
53 of 400 estimates at 0, whose uninformative y_i at the floor dragged the mean 6 log units
down and the amplitude to its bound.) The hyperparameters
(c, l_1..l_d, nugget) maximise the log marginal likelihood (R&W eq. 5.8) on the first
pseudo-observations (L-BFGS-B from fixed initial values and RESTARTS log-uniform restarts drawn
with a fixed seed, RANDOM_STATE) and again on the converged ones, from the first optimum
(then the iteration is repeated with them): the same points give the same surface. Their
bounds (BOUNDS) and why:

- c (variance of g about m): 1e-4 to 1e2, a 1% to a factor-e^10 (2e4) variation over the map;
  every L1 lies in (1e-4, 2), so no real surface needs more;
- l (length scale, unit axes): 0.05 to 20. Below 0.05 of the range the GP could bend between
  the neighbouring points of a refined map (a 40 x 40 grid's spacing is 0.026) to follow the
  Monte Carlo noise, which draws the islands issue 29 is about; averaging errors change on the
  scale of the parameter ranges (docs/maps.md). Above 20 the surface is linear over the map and
  longer scales cannot be told apart;
- nugget (scatter beyond the points' own error bars, log units^2): 1e-6 to 1, a 0.1% to a
  factor-e excess scatter; the lower bound keeps the solve well conditioned where s_i = 0.
  The fitted value is reported: a nugget well above 1e-6 says the error bars miss part of the
  point-to-point scatter (the seed-to-seed spread, or a rough surface).

**Posterior, probability, band.** The latent g at x has the normal posterior N(mu(x), sd(x)^2)
(R&W eq. 2.23-2.24 with K + diag(tau^2 + nugget)): the surface is exp(mu) (the posterior median
of L), and

    P(inside)(x) = P(L(x) <= T) = Phi((log T - mu(x)) / sd(x)).

The estimated boundary is the level set mu(x) = log T (P = 1/2), and the band is where
BAND[0] < P(inside) < BAND[1] (5% to 95%), i.e. |mu - log T| < 1.645 sd: a true boundary point
x_b (g(x_b) = log T) lies in the band exactly when the pointwise 90% credible interval of
g(x_b) covers its true value, so the band's nominal coverage of the true boundary is 90%.
Measured on a synthetic map with a known boundary and known heteroscedastic Gaussian noise
(tests/test_surface.py, 49 points, 40 seeds a level): 0.951, 0.935, 0.934 (standard errors
0.02) at noise 0.3, 0.1, 0.03 x tolerance, the misclassified area 0.025, 0.010, 0.003 of the
map (3 seeds). The hyperparameters'
own uncertainty is not propagated (type-II maximum likelihood), which narrows the band a little.

Points' own numbers travel beside the surface's: ``error_estimate``, ``error_estimate_err``,
``p_within_tolerance`` (the point's verdict alone), and ``surface_error_estimate``,
``surface_error_estimate_sd`` (of log L), ``surface_p_within_tolerance`` (the surface at the
point: every other point's evidence included).

Needs scikit-learn (the ``sweep`` extra).
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vifpk.core.result import BadInput

FLOOR_FRACTION = 1e-3  # g >= log(this x tolerance): an error this far below it is inside it
ITERATIONS = 30  # Gauss-Newton iterations at most (each a GP solve with fixed hyperparameters)
ITERATION_TOL = 1e-4  # ... until g0 changes by less than this at every point (log units)
BAND = (0.05, 0.95)  # P(inside) between these: the band (nominal coverage 90%)
MIN_POINTS = 3  # fewer points than this cannot fit a length scale and an amplitude
RESTARTS = 4  # restarts of the marginal-likelihood optimiser
RANDOM_STATE = 0  # their seed: the same points give the same surface
MEAN_VARIANCE = 1e2  # the constant mean's prior variance (log units^2; see the module docstring)
BOUNDS = {"amplitude": (1e-4, 1e2), "length_scale": (0.05, 20.0), "nugget": (1e-6, 1.0)}
RESOLUTION = {1: 400, 2: 101}  # fine-grid points per axis by dimension
LOG_SPACED_RTOL = 1e-6  # a list of values is log-spaced when its log steps agree to this


class SurfaceError(BadInput):
    """Input the surface cannot be fitted to (one line saying why; exit 2)."""


@dataclass(frozen=True, kw_only=True)
class Axis:
    """One varied parameter: its range and whether it is drawn and fitted on a log scale."""

    name: str
    lo: float
    hi: float
    log: bool = False

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lo) and math.isfinite(self.hi) and self.lo < self.hi):
            raise SurfaceError(f"surface: axis {self.name}: needs lo < hi (finite), not "
                               f"{self.lo!r}, {self.hi!r}")
        if self.log and self.lo <= 0:
            raise SurfaceError(f"surface: axis {self.name}: a log axis needs values > 0, "
                               f"not {self.lo!r}")

    def unit(self, v: Any) -> np.ndarray:
        """Values -> [0, 1] (through log10 on a log axis)."""
        v = np.asarray(v, float)
        if self.log:
            return (np.log10(v) - math.log10(self.lo)) / (math.log10(self.hi)
                                                          - math.log10(self.lo))
        return (v - self.lo) / (self.hi - self.lo)

    def value(self, u: Any) -> np.ndarray:
        """[0, 1] -> values (the inverse of :meth:`unit`)."""
        u = np.asarray(u, float)
        if self.log:
            return 10.0 ** (math.log10(self.lo) + u * (math.log10(self.hi)
                                                       - math.log10(self.lo)))
        return self.lo + u * (self.hi - self.lo)


def log_spaced(values: Sequence[float]) -> bool:
    """Whether a sweep's list of values is log-spaced: at least 3 distinct positive values
    whose sorted log steps agree (relative LOG_SPACED_RTOL) while their linear steps do not."""
    v = np.unique(np.asarray(values, float))
    if v.size < 3 or np.any(v <= 0):
        return False
    lg, lin = np.diff(np.log(v)), np.diff(v)
    return bool(np.ptp(lg) <= LOG_SPACED_RTOL * np.mean(lg)
                and np.ptp(lin) > LOG_SPACED_RTOL * np.mean(lin))


def axes_for(names: Sequence[str], values: Sequence[Sequence[float]], *,
             ranges: Sequence[tuple[float, float]] | None = None) -> tuple[Axis, ...]:
    """The axes of a sweep: each parameter's range (``ranges``, else the span of its values),
    on a log scale when its values are log-spaced (:func:`log_spaced`; an adaptive sweep's
    ranges are linear)."""
    out = []
    for i, name in enumerate(names):
        v = np.asarray(values[i], float)
        lo, hi = ranges[i] if ranges is not None else (float(np.min(v)), float(np.max(v)))
        out.append(Axis(name=name, lo=float(lo), hi=float(hi),
                        log=ranges is None and log_spaced(v)))
    return tuple(out)


@dataclass(frozen=True, kw_only=True)
class Surface:
    """A fitted error surface (module docstring). Grid arrays are indexed [i] in one dimension
    and [i, j] (axis 0, axis 1) in two; ``boundary`` is a list of polylines (k x dims arrays of
    parameter values) of the level set P(inside) = 1/2."""

    tolerance: float
    axes: tuple[Axis, ...]
    band_levels: tuple[float, float]
    grid: tuple[np.ndarray, ...]  # the fine grid's values on each axis
    log_error: np.ndarray  # mu: posterior mean of log L on the grid
    log_error_sd: np.ndarray  # sd: its posterior standard deviation
    p_inside: np.ndarray  # P(L <= tolerance) on the grid
    band: np.ndarray  # BAND[0] < p_inside < BAND[1]
    boundary: tuple[np.ndarray, ...]
    points: np.ndarray  # n x dims parameter values
    error_estimate: np.ndarray  # the points' own numbers, as given
    error_estimate_err: np.ndarray
    p_within_tolerance: np.ndarray
    floored: np.ndarray  # the point's log was taken of its floor f_i
    log_target: np.ndarray  # y_i
    log_noise_sd: np.ndarray  # tau_i
    surface_error_estimate: np.ndarray  # exp(mu) at the points
    surface_error_estimate_sd: np.ndarray  # sd (of log L) at the points
    surface_p_within_tolerance: np.ndarray  # P(inside) at the points
    hyperparameters: dict[str, Any]
    kernel: str
    log_marginal_likelihood: float
    _model: Any = field(repr=False, compare=False)
    _mean: float = field(repr=False, compare=False)

    @property
    def error(self) -> np.ndarray:
        """exp(mu): the surface of the error on the grid (the posterior median of L)."""
        return np.exp(self.log_error)

    @property
    def band_area(self) -> float:
        """The band's share of the map (grid cells, in the axes' unit coordinates)."""
        return float(np.mean(self.band))

    @property
    def inside_area(self) -> float:
        """The share of the map where the estimated error is within the tolerance (P > 1/2)."""
        return float(np.mean(self.p_inside > 0.5))

    def predict(self, params: Any) -> tuple[np.ndarray, np.ndarray]:
        """(mu, sd) of log L at parameter values ``params`` (n x dims)."""
        return _predict(self._model, self._mean, _units(self.axes, params))

    def probability(self, params: Any) -> np.ndarray:
        """P(L <= tolerance) at parameter values ``params`` (n x dims)."""
        mu, sd = self.predict(params)
        return _p_inside(mu, sd, self.tolerance)


def _units(axes: Sequence[Axis], params: Any) -> np.ndarray:
    p = np.atleast_2d(np.asarray(params, float))
    if p.shape[1] != len(axes):
        raise SurfaceError(f"surface: points have {p.shape[1]} coordinates, the axes "
                           f"{len(axes)}")
    return np.column_stack([a.unit(p[:, k]) for k, a in enumerate(axes)])


def _one_blas_thread() -> Any:
    """BLAS on one thread: the matrices are small (points x points), and a multithreaded BLAS
    on a shared machine made each marginal-likelihood evaluation 15x slower (measured: 7.7 s
    against 0.5 s a fit of 49 points at load 3.5 on 2 cores)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def _predict(model: Any, mean: float, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    with _one_blas_thread():
        mu, sd = model.predict(u, return_std=True)
    return mu + mean, np.maximum(sd, 1e-300)


def _p_inside(mu: np.ndarray, sd: np.ndarray, tolerance: float) -> np.ndarray:
    from scipy.special import ndtr

    return ndtr((math.log(tolerance) - mu) / sd)


def pseudo_observations(g0: np.ndarray, error_estimate: np.ndarray,
                        error_estimate_err: np.ndarray, log_floor: float
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(y, tau, floored): exp(g) linearised at max(g0, log s_i, ``log_floor``) (module
    docstring: tau_i <= 1), y floored at ``log_floor``."""
    g = np.maximum(g0, np.log(np.maximum(error_estimate_err, math.exp(log_floor))))
    e0 = np.exp(g)
    y = g + (error_estimate - e0) / e0
    floored = y <= log_floor
    return np.maximum(y, log_floor), error_estimate_err / e0, floored


def fit_surface(points: Any, error_estimate: Any, error_estimate_err: Any, *,
                tolerance: float, axes: Sequence[Axis],
                p_within_tolerance: Any = None, resolution: int | None = None,
                band: tuple[float, float] = BAND, restarts: int = RESTARTS,
                random_state: int = RANDOM_STATE, start: Any = None) -> Surface:
    """Fit the error surface to ``points`` (n x dims parameter values) with their error
    estimates and standard errors (tolerance.tolerance_verdict), evaluate it on a fine grid
    (``resolution`` per axis, default RESOLUTION) and return the :class:`Surface`.

    ``p_within_tolerance``: the points' own verdicts, stored as given; without them the normal
    approximation Phi((T - L_i) / s_i) is stored. ``start``: a fitted surface's kernel
    (``surface._model.kernel``) to start the hyperparameters from, without restarts (a band
    sweep refits after every batch of a few points). Bad input: :class:`SurfaceError` (one line).
    """
    if not (isinstance(tolerance, int | float) and math.isfinite(tolerance) and tolerance > 0):
        raise SurfaceError(f"surface: tolerance must be a number > 0, not {tolerance!r}")
    axes = tuple(axes)
    dims = len(axes)
    if dims not in (1, 2):
        raise SurfaceError(f"surface: one or two varied parameters, not {dims}")
    x = np.atleast_2d(np.asarray(points, float))
    if dims == 1 and x.shape[0] == 1 and x.shape[1] != 1:
        x = x.T
    L = np.asarray(error_estimate, float).ravel()
    s = np.asarray(error_estimate_err, float).ravel()
    if x.shape != (L.size, dims) or s.size != L.size:
        raise SurfaceError(f"surface: {x.shape[0]} points of {x.shape[1]} coordinates, "
                           f"{L.size} estimates and {s.size} errors: they must agree")
    keep = np.isfinite(L) & np.isfinite(s) & np.all(np.isfinite(x), axis=1)
    if np.any(L[keep] < 0) or np.any(s[keep] < 0):
        raise SurfaceError("surface: error estimates and their errors must be >= 0")
    if int(keep.sum()) < MIN_POINTS:
        raise SurfaceError(f"surface: {int(keep.sum())} points with an error estimate; at "
                           f"least {MIN_POINTS} are needed for a surface")
    if not (0 < band[0] < 0.5 < band[1] < 1):
        raise SurfaceError(f"surface: band must be (lo, hi) with 0 < lo < 1/2 < hi < 1, "
                           f"not {band!r}")
    u = _units(axes, x[keep])
    with _one_blas_thread():
        model, mean, hyper, kernel, lml, y, tau, floored_k = _fit_iterated(
            u, L[keep], s[keep], math.log(FLOOR_FRACTION * tolerance), restarts=restarts,
            random_state=random_state, start=start)

    n = resolution or RESOLUTION[dims]
    if n < 2:
        raise SurfaceError(f"surface: resolution must be >= 2, not {n}")
    g = np.linspace(0.0, 1.0, n)
    if dims == 1:
        ug = g[:, None]
    else:
        gu, gv = np.meshgrid(g, g, indexing="ij")
        ug = np.column_stack([gu.ravel(), gv.ravel()])
    mu, sd = _predict(model, mean, ug)
    shape = (n,) * dims
    mu, sd = mu.reshape(shape), sd.reshape(shape)
    p = _p_inside(mu, sd, tolerance)
    grid = tuple(a.value(g) for a in axes)

    mu_pts, sd_pts = _predict(model, mean, _units(axes, x))
    if p_within_tolerance is None:
        from scipy.special import ndtr

        with np.errstate(divide="ignore", invalid="ignore"):
            own = np.where(s > 0, ndtr((tolerance - L) / s), (L <= tolerance).astype(float))
    else:
        own = np.asarray(p_within_tolerance, float).ravel()
    floored = np.zeros(L.size, bool)
    floored[keep] = floored_k
    y_all = np.full(L.size, np.nan)
    y_all[keep] = y
    tau_all = np.full(L.size, np.nan)
    tau_all[keep] = tau
    return Surface(
        tolerance=float(tolerance), axes=axes, band_levels=band, grid=grid,
        log_error=mu, log_error_sd=sd, p_inside=p, band=(p > band[0]) & (p < band[1]),
        boundary=_level_set(g, mu, math.log(tolerance), axes),
        points=x, error_estimate=L, error_estimate_err=s, p_within_tolerance=own,
        floored=floored, log_target=y_all, log_noise_sd=tau_all,
        surface_error_estimate=np.exp(mu_pts), surface_error_estimate_sd=sd_pts,
        surface_p_within_tolerance=_p_inside(mu_pts, sd_pts, tolerance),
        hyperparameters=hyper, kernel=kernel, log_marginal_likelihood=lml,
        _model=model, _mean=mean)


def _fit_iterated(u: np.ndarray, L: np.ndarray, s: np.ndarray, log_floor: float, *,
                  restarts: int, random_state: int, start: Any = None) -> tuple[Any, ...]:
    """The Gauss-Newton fixed point (module docstring): pseudo-observations at g0, GP
    posterior mean at the points -> g0, to convergence; hyperparameters fitted on the first
    pseudo-observations and again on the converged ones, then iterated again."""
    g0 = np.log(np.maximum(L, np.maximum(s, math.exp(log_floor))))  # first guess
    kernel = start
    for rnd in range(1 if start is not None else 2):
        y, tau, floored = pseudo_observations(g0, L, s, log_floor)
        kernel, nugget, lml, at_bound = _hyperparameters(  # the second from the first's
            u, y, tau, kernel, restarts=restarts if rnd == 0 and start is None else 0,
            random_state=random_state)
        for _ in range(ITERATIONS):
            y, tau, floored = pseudo_observations(g0, L, s, log_floor)
            model, mean = _posterior(u, y, tau, kernel, nugget)
            g1 = np.maximum(_predict(model, mean, u)[0], log_floor)
            step = float(np.max(np.abs(g1 - g0)))
            g0 = g1
            if step < ITERATION_TOL:
                break
        y, tau, floored = pseudo_observations(g0, L, s, log_floor)
    model, mean = _posterior(u, y, tau, kernel, nugget)
    ls = np.atleast_1d(kernel.k2.k2.length_scale).astype(float)
    hyper = {"amplitude": float(kernel.k2.k1.constant_value),
             "length_scale": [float(v) for v in ls], "nugget": nugget, "mean": mean,
             "bounds": {k: list(v) for k, v in BOUNDS.items()}, "at_bound": at_bound,
             "restarts": restarts, "random_state": random_state,
             "last_step": step}
    return model, mean, hyper, str(kernel), lml, y, tau, floored


def _hyperparameters(u: np.ndarray, y: np.ndarray, tau: np.ndarray, start: Any, *,
                     restarts: int, random_state: int) -> tuple[Any, float, float, list[str]]:
    """Type-II maximum likelihood of (c, l, nugget) with alpha = tau^2 (module docstring):
    the fitted signal kernel c Matern, the nugget, the log marginal likelihood and the
    parameters that ended at a bound."""
    try:
        from sklearn.exceptions import ConvergenceWarning
        from sklearn.gaussian_process import GaussianProcessRegressor
        from sklearn.gaussian_process.kernels import ConstantKernel, Matern, WhiteKernel
    except ImportError:  # pragma: no cover - a dependency of vifpk
        raise SurfaceError("surface: needs scikit-learn (pip install scikit-learn)") from None
    yc = y - _centre(y, tau)
    if start is None:
        start = (ConstantKernel(MEAN_VARIANCE, "fixed")
                 + ConstantKernel(float(np.clip(np.var(yc), *BOUNDS["amplitude"])),
                                  BOUNDS["amplitude"])
                 * Matern(length_scale=np.full(u.shape[1], 0.3),
                          length_scale_bounds=BOUNDS["length_scale"], nu=2.5))
    kernel = start + WhiteKernel(1e-3, BOUNDS["nugget"])
    gp = GaussianProcessRegressor(kernel=kernel, alpha=tau**2, normalize_y=False,
                                  n_restarts_optimizer=restarts, random_state=random_state)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        gp.fit(u, yc)
    at_bound = sorted({m.group(1) for w in caught
                       if issubclass(w.category, ConvergenceWarning)
                       and (m := re.search(r"parameter (\S+)", str(w.message)))})
    fitted = gp.kernel_
    return (fitted.k1, float(fitted.k2.noise_level), float(gp.log_marginal_likelihood_value_),
            at_bound)


def _centre(y: np.ndarray, tau: np.ndarray) -> float:
    """The prior's centre m: the median of the informative y_i (tau_i <= 1), else of all."""
    good = y[tau <= 1.0]
    return float(np.median(good if good.size else y))


def _posterior(u: np.ndarray, y: np.ndarray, tau: np.ndarray, kernel: Any, nugget: float
               ) -> tuple[Any, float]:
    """The latent g's posterior with fixed hyperparameters: (regressor, mean m)."""
    from sklearn.gaussian_process import GaussianProcessRegressor

    mean = _centre(y, tau)
    model = GaussianProcessRegressor(kernel=kernel, alpha=tau**2 + nugget, normalize_y=False,
                                     optimizer=None)
    model.fit(u, y - mean)
    return model, mean


def _level_set(g: np.ndarray, mu: np.ndarray, level: float, axes: Sequence[Axis]
               ) -> tuple[np.ndarray, ...]:
    """The polylines (parameter values) where mu = level: linear interpolation between grid
    points (1-D: the crossings, each a 1 x 1 array; 2-D: contourpy's marching squares)."""
    if mu.ndim == 1:
        f = mu - level
        out = []
        for i in np.nonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0)[0]:
            t = f[i] / (f[i] - f[i + 1])
            out.append(axes[0].value(np.array([[g[i] + t * (g[i + 1] - g[i])]])))
        return tuple(out)
    import contourpy

    gen = contourpy.contour_generator(g, g, mu.T, line_type="Separate")
    lines = []
    for seg in gen.lines(level):
        seg = np.asarray(seg, float)
        lines.append(np.column_stack([axes[0].value(seg[:, 0]), axes[1].value(seg[:, 1])]))
    return tuple(lines)
