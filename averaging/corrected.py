"""The exact model with the impacts treated as discrete: first-order averaging of an energy
that is continuous across the impacts (derivation in docs/averaging.md, section 10).

Between two impacts (a flight of duration tau = T/2, phase s = time since the impact / tau in
[0, 1)) the energy H changes by O(eps) per period; at an impact it jumps, H -> r^2 H. The
exact model averages H itself, charging the jump as a smooth loss (2/T)(1 - r^2) E: it treats
a jump of relative size 1 - r^2 = O(eps) as if it were infinitesimal. The variable

    Q = H exp(lambda (1 - s)),        lambda = -ln r^2 = -2 ln r,

is continuous across an impact (just before it s -> 1 and Q = H; just after, s = 0 and
Q = r^2 H e^lambda = H), so Q has no jumps: between impacts dQ/dt = e^{lambda(1-s)} dH/dt
- lambda Q / tau. First-order averaging of Q on the exact orbit of energy E(s) = Q e^{-lambda
(1-s)} gives a drift (Q-frame) with the impact loss lambda Q / tau, smooth terms and noise
weighted by e^{lambda(1-s)} and e^{2 lambda(1-s)}; the observed energy is H = Q e^{-lambda u}
with u uniform on [0, 1) (time-uniform phase). To first order in lambda the weights and the
back-transform cancel for every term linear in E, and what remains is the exact model with the
per-impact loss replaced by its compounded form::

    impact loss rate = (2/T) lambda E = -(2/T) ln(r^2) E          ("compounded" law)

(1 - r^2 = lambda - lambda^2/2 + ..., so the two laws differ at O(eps^2) in the drift, i.e. at
O(eps) relative to it, which is the order at which p(A) is sensitive where gain and loss
nearly cancel.) ``q_frame_density`` evaluates the un-simplified Q-frame model by quadrature
over s; the tests check that it agrees with the closed form to O(lambda^2).

Order: this is first-order stochastic averaging of Q. It keeps every O(eps) correction that
comes from the jumps being discrete, and none of the other O(eps^2) drift terms (the noise
acting across an impact, the fast energy fluctuation of correlated noise): see docs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .exact import ExactModel
from .geometry import (
    Array,
    amplitude_of_energy_k,
    period_k,
    potential_k,
    restoring_k,
    restoring_slope_k,
)
from .noise import Spectrum, problem
from .walls import is_paper_wall, walls_of


@dataclass(frozen=True, kw_only=True)
class CompoundedModel(ExactModel):
    """ExactModel with the compounded per-impact loss -ln(r^2) E (discrete impacts): the model
    of issue 15, named ``compounded`` (``corrected`` adds the section-10.3 terms to it)."""

    impact: str = "compounded"
    name: str = "compounded"

    @classmethod
    def from_scene(cls, scene: Any, *, noise: str = "sgn", theta_nodes: int | None = None,
                   harmonics: int | None = None) -> CompoundedModel:
        base = ExactModel.from_scene(scene, noise=noise, theta_nodes=theta_nodes,
                                     harmonics=harmonics)
        fields = {k: v for k, v in base.__dict__.items() if k not in ("impact", "name")}
        return cls(**fields)

    @property
    def lam(self) -> float:
        """lambda = -ln r^2: the jump of ln H at an impact (0 without a barrier)."""
        return -2.0 * float(np.log(self.r)) if self.barrier else 0.0

    def energy_terms(self, A: Array) -> dict[str, Array]:
        """As ExactModel.energy_terms, with the impact loss rate -(2/T) lambda E."""
        et = super().energy_terms(A)
        if self.barrier:
            et["impact"] = -(2.0 / et["T"]) * self.lam * et["E"]
        return et


def q_frame_density(model: CompoundedModel, A: Array, *, nodes: int = 8) -> Array:
    """p(A) of the un-simplified Q-frame model on the grid A (uniform, A[0] > 0), by quadrature.

    Q-frame averages at Q = U(A), with E(s) = Q e^{-lambda(1-s)} and Gauss-Legendre in s::

        m_Q  = int_0^1 e^{lambda(1-s)} m_s(E(s)) ds - lambda Q / tau_Q,
        tau_Q = int_0^1 T(E(s)) / 2 ds,
        sigma_Q^2 = int_0^1 e^{2 lambda(1-s)} sigma_E^2(E(s)) ds,
        p_Q(Q) = C 2 tau_Q exp int 2 m_Q / sigma_Q^2 dQ,
        p_E(E) = int_0^1 p_Q(E e^{lambda u}) e^{lambda u} du,    p_A = p_E g(A),

    m_s the smooth deterministic drift (damping, friction) of the exact model.
    Normalised to trapezoid mass 1 on A (whose range must hold the mass).
    """
    A = np.asarray(A, dtype=float)
    k, lam = model.restoring, model.lam
    x, w = np.polynomial.legendre.leggauss(nodes)
    s, w = 0.5 * (x + 1.0), 0.5 * w
    fac = np.exp(-lam * (1.0 - s))
    Q = potential_k(A, k)
    As = amplitude_of_energy_k(Q[:, None] * fac[None, :], k)
    et = ExactModel.energy_terms(model, As)
    m_s = ((et["damping"] + et["friction"] + et["parametric"]) / fac) @ w
    s2 = (et["sigma2"] / fac**2) @ w
    tau = (0.5 * et["T"]) @ w
    q = 2.0 * (m_s - lam * Q / tau) / s2
    log_pq = np.log(2.0 * tau) + np.concatenate(
        [[0.0], np.cumsum(0.5 * (q[1:] + q[:-1]) * np.diff(Q))])
    logQ = np.log(Q)
    parts = [np.log(wj) + lam * (1 - sj)
             + np.interp(logQ + lam * (1 - sj), logQ, log_pq, right=-np.inf)
             for sj, wj in zip(s, w, strict=True)]
    stack = np.array(parts)
    top = np.max(stack[:, :], axis=0)
    top = np.where(np.isfinite(top), top, -np.inf)
    with np.errstate(invalid="ignore"):
        log_pe = top + np.log(np.sum(np.exp(stack - top[None, :]), axis=0))
    log_pa = np.where(np.isfinite(log_pe), log_pe, -np.inf) + np.log(restoring_k(A, k))
    p = np.exp(log_pa - np.max(log_pa))
    return p / np.trapezoid(p, A)


# --------------------------------------------------------------------------------------
# section 10.3 of docs/averaging.md: the energy at the wall and the fast energy fluctuation
WALL_TABLE_A = (1e-3, 10.0)  # amplitudes of the delta(E) table (log-spaced; clamped beyond)
WALL_TABLE_POINTS = 48
WALL_FLIGHT_STEPS = 120  # RK4 steps per flight (error ~ (pi / steps)^4 ~ 5e-8 relative)
# the trapezoid rule must resolve the OU covariance's cusp e^{-alpha1 |s|}: alpha1 h <= 0.1
# (relative error ~ (alpha1 h)^2 / 12 ~ 1e-3 of the cusp's part); at 120 steps a wide band
# (alpha1 tau >~ 20) gave delta of the wrong sign and a blown-up corrected model
WALL_STEPS_PER_CORRELATION_TIME = 10
# beyond this many steps a flight is many correlation times long (alpha1 tau > 200): the
# noise is white on the flight's scale and delta is at its white-noise limit, 0 (measured on
# the linear oscillator omega0 = 1.3 with S(0) fixed, D = 0.01 alpha1^2: delta = 9.7e-4,
# 5.3e-5, 1.2e-5, 2.5e-6 at alpha1 tau = 4.8, 24, 48, 97, falling like 1/alpha1^2; the wall
# term vanishes for white noise). Without the cap
# a spring with k1 = 0 (tau -> infinity as A -> 0) asked for unbounded flights.
WALL_STEPS_MAX = 2000


def _flight(E: Array, k: tuple[float, ...], tau: Array, n: int) -> tuple[Array, Array]:
    """RK4 over one flight [0, tau] from the wall (x = 0, v = sqrt(2E)) of x, v and the
    fundamental matrix [[dx/dx0, dx/dv0], [dv/dx0, dv/dv0]] of the variational equation
    x'' = -g(x), g(x) = k1 x + k3 x^3 + ... Returns the states (m, n + 1, 6) and the steps
    h (m,)."""
    h = tau / n
    y = np.zeros((E.size, 6))
    y[:, 1], y[:, 2], y[:, 5] = np.sqrt(2 * E), 1.0, 1.0

    def f(y: Array) -> Array:
        x, v, m00, m01, m10, m11 = y.T
        gp = restoring_slope_k(x, k)
        return np.stack([v, -restoring_k(x, k), m10, m11, -gp * m00, -gp * m01], axis=1)

    out, H = [y], h[:, None]
    for _ in range(n):
        k1 = f(y)
        k2 = f(y + 0.5 * H * k1)
        k3 = f(y + 0.5 * H * k2)
        k4 = f(y + H * k3)
        y = y + H / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(y)
    return np.stack(out, axis=1), h


def wall_offset(omega0: float, alpha: float, f: float, D: float, alpha1: float, A: Array,
                *, steps: int = WALL_FLIGHT_STEPS,
                restoring: tuple[float, ...] | None = None) -> Array:
    """delta(E(A)): how far correlated noise holds the energy at the wall below the flight
    average (docs/averaging.md section 10.3 (a)), by linear response along one flight.

    With W(t) = int_0^t f xi x' the noise work since the impact, Phi_{x,v}(t, t'') the response
    of x, x' at t to a unit force impulse at t'' (variational equation from the wall) and
    R(s) = (D / alpha1) e^{-alpha1 |s|} the OU covariance, to second order in xi::

        E W(t)         = f^2 int_0^t dt' int_0^t' R(t' - t'') Phi_v(t', t'') dt''
        E[dtau W(tau)] = -(f^2 / x'(tau)) int_0^tau dt x'(t) int_0^tau Phi_x(tau, t'')
                                                                    R(t - t'') dt''
        E W(tau')      = E W(tau) - f^2 int_0^tau Phi_x(tau, t'') R(tau - t'') dt''
        delta = (int_0^tau E W dt + E[dtau W(tau)]) / tau - E W(tau') / 2

    (tau = T/2 the flight; the mean noise gain E W(tau') is already spread over the flight by
    the averaged model, hence -1/2). Trapezoid rule on the RK4 nodes. Quasi-static limit
    (alpha = 0, alpha1 -> 0): delta -> f^2 D / (alpha1 omega0^2) (tests/test_corrected.py).
    """
    A = np.atleast_1d(np.asarray(A, dtype=float))
    k = tuple(restoring) if restoring is not None else (omega0**2, alpha)  # issue 21: any spring
    E = potential_k(A, k)
    tau = 0.5 * period_k(A, k)
    # enough steps to resolve the covariance's cusp (WALL_STEPS_PER_CORRELATION_TIME per
    # 1/alpha1): amplitudes that need more than ``steps`` are done one by one (the kernel is
    # (n + 1)^2 numbers an amplitude)
    need = np.ceil(WALL_STEPS_PER_CORRELATION_TIME * np.minimum(alpha1 * tau, 1e12))
    if np.any(need > steps):
        return np.array([0.0 if need[i] > WALL_STEPS_MAX else
                         _wall_offset_flight(f, D, alpha1, E[i:i + 1], tau[i:i + 1], k,
                                             max(steps, int(need[i])))[0]
                         for i in range(A.size)])
    return _wall_offset_flight(f, D, alpha1, E, tau, k, steps)


def _wall_offset_flight(f: float, D: float, alpha1: float, E: Array, tau: Array,
                        k: tuple[float, ...], n: int) -> Array:
    """wall_offset for energies E with flights tau, n RK4 / trapezoid steps each."""
    Y, h = _flight(E, k, tau, n)
    t = np.arange(n + 1)[None, :] * h[:, None]
    xd = Y[:, :, 1]
    m00, m01, m10, m11 = (Y[:, :, k] for k in (2, 3, 4, 5))
    # Phi(t, t'') = M(t) M(t'')^{-1}, det M = 1: response to a velocity kick at t''
    phi_v = m10[:, :, None] * (-m01[:, None, :]) + m11[:, :, None] * m00[:, None, :]
    phi_x_end = m00[:, -1, None] * (-m01) + m01[:, -1, None] * m00
    R = (D / alpha1) * np.exp(-alpha1 * np.abs(t[:, :, None] - t[:, None, :]))
    w = np.ones(n + 1)
    w[0] = w[-1] = 0.5
    K = R * phi_v * np.tril(np.ones((n + 1, n + 1)))[None]
    inner = (K.sum(axis=2) - 0.5 * K[:, :, 0] - 0.5 * np.einsum("nii->ni", K)) * h[:, None]
    inner[:, 0] = 0.0
    f2 = f**2
    EW = f2 * np.concatenate([np.zeros((E.size, 1)), np.cumsum(
        0.5 * (inner[:, 1:] + inner[:, :-1]), axis=1) * h[:, None]], axis=1)
    part = np.einsum("nij,nj,j->ni", R, phi_x_end, w) * h[:, None]
    cross = -(f2 / xd[:, -1]) * np.einsum("ni,ni,i->n", part, xd, w) * h
    total = EW[:, -1] - f2 * np.einsum("nj,nj,j->n", phi_x_end, R[:, -1, :], w) * h
    return (np.einsum("ni,i->n", EW, w) * h + cross) / tau - 0.5 * total


_WALL_TABLES: dict[tuple[float, ...], tuple[Array, Array]] = {}


def _wall_table(k: tuple[float, ...], f: float, D: float, alpha1: float
                ) -> tuple[Array, Array]:
    """(log A, delta) on WALL_TABLE_POINTS log-spaced amplitudes (cached per parameter set;
    k the spring's coefficients)."""
    key = (*k, f, D, alpha1)
    if key not in _WALL_TABLES:
        A = np.geomspace(*WALL_TABLE_A, WALL_TABLE_POINTS)
        _WALL_TABLES[key] = (np.log(A), wall_offset(0.0, 0.0, f, D, alpha1, A, restoring=k))
    return _WALL_TABLES[key]


def _normal_cdf(z: Array) -> Array:
    from scipy.special import ndtr

    return ndtr(z)


@dataclass(frozen=True, kw_only=True)
class CorrectedModel(CompoundedModel):
    """``corrected``: the compounded impact loss charged on the energy at the wall
    (docs/averaging.md section 10.3 (a); issue 23); with ``fast=True`` also the fast energy
    fluctuation of correlated noise as an observation map (10.3 (b)). OFF by default: on the
    exactly solvable linear oscillator under OU noise the map moves the first-order density
    AWAY from the exact Gaussian law (L1 0.004 -> 0.033, tests/test_corrected.py), so the
    term as derived is incomplete (docs/averaging.md 10.5). Both terms vanish for white noise
    and, the first, without a wall.

    Drift: impact loss rate -(2/T) lambda E_wall, E_wall = E e^{-delta/E} (= E - delta to the
    derived order; positive where delta is not small against E: :meth:`wall_energy`), delta
    from :func:`wall_offset` (tabulated in A, log-spaced, linear in log A; clamped beyond).
    Observation: the model's drift and diffusion give the density of the SLOW energy E; the
    simulated energy is H = E - psi with psi = xi a(phase) the first-order corrector of the
    averaging, of variance V(E) = sigma_E^2 / (2 alpha1). :meth:`observe` maps a slow density
    to the observed one with the kernel N(E, V(E)) restricted to H >= 0 (renormalised for each
    E, so that it is a Markov kernel and the same map can be applied to samples by rejection:
    :meth:`observation_sd`). ``averaging.solve``, the FPK and the averaged-SDE Monte Carlo all
    apply it, so check's decomposition compares like with like.
    """

    name: str = "corrected"
    fast: bool = False

    @staticmethod
    def applies(scene: Any) -> str | None:
        """None unless a wall meets a correlated (OU) noise with walls other than the paper's
        or with parametric noise: the energy at the wall (section 10.3) is derived for one
        wall at 0 and the external noise only (for white noise it vanishes and the model is
        the compounded one on any walls, parametric noise included)."""
        why = problem(scene)  # the kind's and laws' averaging pieces (averaging.noise)
        if why is not None:
            return why
        walls = walls_of(scene.system)
        if not (walls and Spectrum.from_scene(scene).rational):
            return None
        if not is_paper_wall(walls):
            return ("the wall offset of correlated noise (docs/averaging.md 10.3) is derived "
                    "for one lower wall at x = 0 with Newton's law only")
        if scene.parametric.on:
            return ("the wall offset of correlated noise (docs/averaging.md 10.3) is derived "
                    "without parametric noise")
        return None

    @classmethod
    def from_scene(cls, scene: Any, *, noise: str = "sgn", theta_nodes: int | None = None,
                   harmonics: int | None = None, fast: bool = False) -> CorrectedModel:
        problem = cls.applies(scene)
        if problem is not None:
            raise ValueError(f"model 'corrected' does not apply: {problem}")
        base = CompoundedModel.from_scene(scene, noise=noise, theta_nodes=theta_nodes,
                                          harmonics=harmonics)
        fields = {k: v for k, v in base.__dict__.items() if k not in ("name",)}
        return cls(**fields, fast=fast)

    @property
    def correlated(self) -> bool:
        """Coloured noise with the rational (OU) spectrum the wall table is derived for."""
        return self.spectrum.rational

    @property
    def observes(self) -> bool:
        """True when the observation map is on (``fast=True`` and correlated noise)."""
        return self.fast and self.correlated

    def wall_offset(self, A: Array) -> Array:
        """delta(E(A)) (0 without a wall or for white noise)."""
        A = np.asarray(A, dtype=float)
        if not (self.barrier and self.correlated and self.lam > 0):
            return np.zeros_like(A)
        s = self.spectrum
        la, d = _wall_table(tuple(self.restoring), self.f, *s.ou_parameters())
        return np.interp(np.log(np.maximum(A, 1e-300)), la, d)

    def energy_terms(self, A: Array) -> dict[str, Array]:
        et = super().energy_terms(A)
        if self.barrier and self.lam > 0 and self.correlated:
            et["impact"] = -(2.0 / et["T"]) * self.lam * self.wall_energy(A)
        return et

    def wall_energy(self, A: Array) -> Array:
        """The mean energy at the wall: E - delta to the order derived (the linear response
        holds for |delta| << E), kept within (0, 2E) where it does not hold: E e^{-delta/E}
        for delta >= 0 (at small E the noise work over a flight is not small against E) and
        E (2 - e^{delta/E}) for delta < 0 (a slow orbit, e.g. k1 = 0 at small A, where the
        flight outlasts the correlation time and delta grows like the flight: E e^{-delta/E}
        was e^{1e17}, an infinite loss). Both differ from E - delta by delta^2 / 2E, below
        0.5% of E wherever |delta| < 0.1 E."""
        A = np.asarray(A, dtype=float)
        E = potential_k(A, self.restoring)
        d = self.wall_offset(A)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            x = -np.abs(d) / E  # <= 0: the exponentials stay in (0, 1]
            out = np.where(d >= 0, E * np.exp(x), E * (2.0 - np.exp(x)))
        return np.where(E > 0, out, 0.0)

    # ---------------------------------------------------------------- observation map
    def observation_sd(self, A: Array) -> Array:
        """sqrt(V(E(A))), V = sigma_E^2 / (2 alpha1): the rms fast energy fluctuation."""
        A = np.asarray(A, dtype=float)
        if not self.observes:
            return np.zeros_like(A)
        return np.sqrt(self.sigma2_external(np.maximum(A, 1e-12))
                       / (2.0 * self.spectrum.ou_parameters()[1]))

    def observation_matrix(self, A_src: Array, edges_dst: Array) -> Array:
        """M[i, j] = P(H in cell i of edges_dst (amplitudes) | slow energy at A_src[j]): the
        truncated normal N(E_j, V_j) on H >= 0, integrated over each target cell in energy."""
        A_src = np.asarray(A_src, dtype=float)
        e_dst = potential_k(np.asarray(edges_dst, dtype=float), self.restoring)
        E = potential_k(A_src, self.restoring)
        sd = np.maximum(self.observation_sd(A_src), 1e-300)
        cdf = _normal_cdf((e_dst[:, None] - E[None, :]) / sd[None, :])
        kept = 1.0 - _normal_cdf(-E / sd)
        return np.diff(cdf, axis=0) / np.maximum(kept, 1e-300)[None, :]

    def observe(self, A: Array, p: Array) -> Array:
        """The observed p(A) on the (increasing) grid A from the slow density p on it:
        node masses (trapezoid weights) moved by :meth:`observation_matrix` into the cells
        around the nodes (edges at the midpoints, the end cells closed at the grid's ends),
        divided by the cell widths and renormalised to trapezoid mass 1 on A."""
        A, p = np.asarray(A, dtype=float), np.asarray(p, dtype=float)
        if not self.observes:
            return p
        mid = 0.5 * (A[1:] + A[:-1])
        edges = np.concatenate([[A[0]], mid, [A[-1]]])
        w = np.diff(edges)
        q = self.observation_matrix(A, edges) @ (p * w) / w
        return q / np.trapezoid(q, A)


OBSERVE_REACH = 6.0  # the observed grid reaches 6 rms fast fluctuations beyond the slow one


def observed_density(model: Any, A: Array, p: Array) -> tuple[Array, Array]:
    """(A', p') the observed amplitude density of a model with an observation map
    (CorrectedModel.observe) from a slow density p on the uniform grid A; identity (A, p) for
    a model without one. The grid keeps its spacing and is extended (with p = 0) to reach
    OBSERVE_REACH rms fast fluctuations of energy beyond the slow grid's ends (at most 4x its
    points; never below 0: a grid of cell centres keeps its half cell), so that the map loses
    no mass."""
    A, p = np.asarray(A, dtype=float), np.asarray(p, dtype=float)
    if not getattr(model, "observes", False):
        return A, p
    k = model.restoring
    sd = model.observation_sd(A[[0, -1]])
    E = potential_k(A[[0, -1]], k)
    lo = float(amplitude_of_energy_k(max(E[0] - OBSERVE_REACH * sd[0], 0.0), k))
    hi = float(amplitude_of_energy_k(E[1] + OBSERVE_REACH * sd[1], k))
    step = (A[-1] - A[0]) / (A.size - 1)
    down = min(np.ceil((A[0] - lo) / step), np.floor(A[0] / step + 1e-9), A.size)
    up = min(np.ceil((hi - A[-1]) / step), 2 * A.size)
    grid = A[0] + step * np.arange(-int(down), A.size + int(up))
    slow = np.interp(grid, A, p, left=0.0, right=0.0)
    return grid, model.observe(grid, slow)


def observed_log_h(model: Any, A: Array, p: Array) -> Array:
    """log p(y, y') = log(p_A / (g T)) of an observed amplitude density (the microcanonical
    split of section 7 applied to the observed energy); at A = 0, where p_A / g is 0 / 0,
    extrapolated linearly from the next two nodes."""
    with np.errstate(divide="ignore", invalid="ignore"):
        lh = np.log(np.maximum(p, 1e-300)) - np.log(restoring_k(A, model.restoring)) - np.log(
            model.period(A))
    if A[0] <= 0.0:
        lh[0] = 2 * lh[1] - lh[2]
    return lh
