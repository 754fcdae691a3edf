"""Stochastic averaging done numerically on the exact Duffing orbit (energy envelope).

Energy H = v^2/2 + U(x) of the original system obeys, between impacts,
``dH/dt = -(d(x) + e(v)) v^2 - mu |v| + f xi(t) v``, and loses a fraction at each impact
(d(x) = d0 + d2 x^2 + ... and e(v) = e2 v^2 + ... the damping laws, paper: d = -c1 + c2 x^2,
e = 0; U the potential of the general odd spring, averaging/geometry.py).
In the transformed coordinate y (x = |y|) the noise term is G xi with G = f s(y) y',
s = sgn ("sgn", the excitation as it is) or s = 1 ("additive", the paper's assumption).
Write G = f dY/dt with Y = s(y) y. Averaging over the exact orbit of energy E (period T,
Omega = 2 pi / T), the Stratonovich-Khasminskii limit gives the Ito equation
dE = m_E dt + sigma_E dB with (derivation in docs/averaging.md)::

    sigma_E^2 = 2 pi sum_{n in Z} |G_n|^2 S(n Omega)
              = 4 pi f^2 sum_{n>=1} n^2 Omega^2 Y_n^2 S(n Omega)
    m_E = m_d + (1 / (2 T)) d(T sigma_E^2)/dE            (noise-induced drift)
    m_d = -<(d(x) + e(v)) v^2> - mu <|v|> - impact loss rate   (paper: c1 <v^2> - c2 <x^2 v^2>)
    impact loss rate = (2/T) (1 - r^2) E   ("exact" law)   or   (2/T) 2 (1 - r) E   ("transformed")
                       or (2/T) (-ln r^2) E   ("compounded": the corrected model, corrected.py)

where Y_n = (1/T) int_0^T Y cos(n Omega t) dt (Y is even in t). Y = y has odd harmonics only;
Y = |y| has period T/2: even harmonics only. The noise-induced drift follows because the noise
field (0, f s(y)) is divergence free, so the averaged generator is symmetric with respect to
the microcanonical measure T(E) dE. Hence, with no derivative::

    p(E) = C T(E) exp( int_0^E 2 m_d / sigma_E^2 dE' )

S(w) comes from averaging.noise, which reads the kind's module (vifpk/physics/noise/).
For the OU spectrum, whose identity
w^2 S(w) = c - a2 S(w) (c = D / pi, a2 = alpha1^2) is ``Spectrum.rational_parts``, the series
is summed with Parseval, sum_{n>=1} Y_n^2 = (<Y^2> - Y_0^2) / 2, so that the truncated
remainder decays as n^-6:
sigma_E^2 = 4 pi f^2 [ c (<Y^2> - Y_0^2)/2 - a2 sum_n Y_n^2 S(n Omega) ],
or, for a slow orbit (Omega << alpha1, where those two terms cancel), with Parseval on dY/dt:
sigma_E^2 = 4 pi f^2 [ (c/a2) <v^2>/2 - (1/a2) sum_n (n Omega)^4 Y_n^2 S(n Omega) ].
White noise (S constant): by Parseval sum_n n^2 Omega^2 Y_n^2 = <v^2>/2, so
sigma_E^2 = 2 pi f^2 S <v^2> = 2 D f^2 <v^2> whatever s is.
The amplitude form follows by Ito's rule with A = U^{-1}(E), dA/dE = 1/g(A):
m_A = m_E / g - g' sigma_E^2 / (2 g^3), sigma_A^2 = sigma_E^2 / g^2.

Walls other than the paper's (issue 37): the orbit of energy E truncated at the walls it
reaches, one impact per wall per period (averaging/truncated.py, averaging/walls.py;
docs/averaging.md section 11). Parametric white noises on the stiffness and the damping
(Stratonovich): their Ito drift and diffusion on the orbit, with the part of the drift that is
not (1/(2T)) d(T sigma_E^2)/dE kept in m_d as "parametric" (vifpk/physics/noise/parametric.py,
averaging/parametric.py; docs/averaging.md section 12).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from vifpk.core.registry import IMPACT_TREATMENTS, one_of

from . import memo, parametric, truncated
from .geometry import (
    Array,
    amplitudes,
    gauss_quarter,
    nu_k,
    potential_k,
    restoring_k,
    restoring_slope_k,
    time_of_theta_k,
)
from .noise import Spectrum, problem
from .spectral_sum import sigma2_harmonic, sigma2_harmonic_truncated, sigma2_rational
from .walls import WallSpec, is_paper_wall, loss_rate, reached, span, walls_of

NOISE_FORMS = ("sgn", "additive")


@dataclass(frozen=True, kw_only=True)
class ExactModel:
    """Exact orbit averages. Options: ``noise`` in NOISE_FORMS, ``impact`` in IMPACT_TREATMENTS.

    The system's laws as coefficient tuples (issue 21): ``restoring`` k = (k1, k3, ...) for
    g(x) = k1 x + k3 x^3 + ...; ``damping`` d = (d0, d2, ...) for the force
    (d0 + d2 x^2 + ...) x'; ``velocity_damping`` e = (e2, e4, ...) for (e2 x'^2 + ...) x'.
    The paper's c1, c2, omega0, alpha are d0 = -c1, d2 = c2, k1 = omega0^2, k3 = alpha.

    Walls: ``barrier`` with ``r`` is the paper's wall (a lower wall at 0, Newton's law), done
    in the transformed coordinate y (x = |y|); any other walls are ``walls``
    (averaging.walls.WallSpec), done on the truncated orbit (averaging/truncated.py,
    docs/averaging.md "Walls anywhere"); the two are never given together.

    Parametric white noises (Stratonovich; vifpk/physics/noise/parametric.py, docs/averaging.md
    section 12): ``D_k`` on the restoring force, ``D_c`` on the damping force d(x) x'."""

    restoring: tuple[float, ...]
    damping: tuple[float, ...]
    velocity_damping: tuple[float, ...] = ()
    mu: float
    r: float
    f: float
    barrier: bool
    spectrum: Spectrum
    walls: tuple[WallSpec, ...] = ()
    D_k: float = 0.0
    D_c: float = 0.0
    noise: str = "sgn"
    impact: str = "exact"
    theta_nodes: int = 64
    harmonics: int = 24
    name: str = "exact"

    def __post_init__(self) -> None:
        one_of("noise", self.noise, NOISE_FORMS)
        one_of("impact", self.impact, IMPACT_TREATMENTS)
        if self.walls and self.barrier:
            raise ValueError("ExactModel: give the paper's wall (barrier, r) or walls, not both")

    @staticmethod
    def applies(scene: Any) -> str | None:
        """None when the scene's noise kind and walls' laws have the averaging pieces
        (averaging.noise.problem), else that one line (vifpk.core.protocols)."""
        return problem(scene)

    @classmethod
    def from_scene(cls, scene: Any, *, noise: str = "sgn", impact: str = "exact",
                   theta_nodes: int | None = None, harmonics: int | None = None) -> ExactModel:
        one_of("noise", noise, NOISE_FORMS)
        one_of("impact", impact, IMPACT_TREATMENTS)
        s = scene.system
        st = getattr(scene, "averaging", None)
        walls = walls_of(s)
        paper = is_paper_wall(walls)
        par = scene.parametric  # the [parametric] table (issue 37)
        return cls(restoring=tuple(s.restoring_law), damping=tuple(s.damping_law),
                   velocity_damping=tuple(s.velocity_law), mu=s.mu,
                   r=walls[0].r if paper else 1.0, f=s.f, barrier=paper,
                   walls=() if paper else walls, spectrum=Spectrum.from_scene(scene),
                   D_k=float(par.stiffness), D_c=float(par.damping),
                   noise=noise if paper else "additive", impact=impact,
                   theta_nodes=theta_nodes or getattr(st, "theta_nodes", 64),
                   harmonics=harmonics or getattr(st, "harmonics", 24))

    # ------------------------------------------------------------------ the paper's names
    @property
    def omega0(self) -> float:
        """sqrt(k1) (the paper's name; k1 >= 0)."""
        return float(np.sqrt(self.restoring[0]))

    @property
    def alpha(self) -> float:
        """k3 (the paper's name; 0 when the spring has no cubic term)."""
        return float(self.restoring[1]) if len(self.restoring) > 1 else 0.0

    @property
    def c1(self) -> float:
        """-d0 (the paper's name)."""
        return -float(self.damping[0]) if self.damping else 0.0

    @property
    def c2(self) -> float:
        """d2 (the paper's name)."""
        return float(self.damping[1]) if len(self.damping) > 1 else 0.0

    # ------------------------------------------------------------------ orbit averages
    def _memo_params(self, *methods: str) -> tuple[Any, ...]:
        """What the orbit averages and sigma_E^2 depend on, for averaging.memo: the methods
        that compute them (so a subclass overriding one is kept apart) and the spring, damping
        laws, walls, noise and quadrature; not the impact law or the name, which is why the
        exact, compounded and corrected models share them."""
        cls = type(self)
        return (tuple(getattr(cls, m) for m in methods), self.restoring, self.damping,
                self.velocity_damping, self.walls, self.barrier, self.spectrum, self.f,
                self.noise, self.theta_nodes, self.harmonics)

    def orbit(self, A: Array) -> dict[str, Array]:
        """Period and time averages along the orbit of amplitude A (any shape): the free orbit
        (:meth:`free_orbit`), truncated by ``walls`` where A reaches one (truncated.orbit;
        the keys of the free orbit, the same numbers where no wall is reached). Computed once
        per grid inside averaging.memo.shared (the same arrays, read-only)."""
        A = np.asarray(A, dtype=float)
        return memo.recall("orbit", self._memo_params("orbit", "free_orbit", "reached"), A,
                           lambda: self._orbit(A))

    def _orbit(self, A: Array) -> dict[str, Array]:
        o = self.free_orbit(A)
        hit = self.reached(A)
        if not np.any(hit):
            return o
        a, b = span(self.walls)
        t = truncated.orbit(np.where(hit, A, 1.0), self.restoring, a, b,
                            n_damping=len(self.damping),
                            n_velocity=len(self.velocity_damping),
                            nodes=2 * self.theta_nodes)
        for key in ("T", "v2", "x2v2", "y2", "absv", "E"):
            o[key] = np.where(hit, t[key], o[key])
        o["x2jv2"] = [np.where(hit, u, f) for u, f in zip(t["x2jv2"], o["x2jv2"], strict=True)]
        o["v2jv2"] = [np.where(hit, u, f) for u, f in zip(t["v2jv2"], o["v2jv2"], strict=True)]
        return o

    def reached(self, A: Array) -> Array:
        """Whether the orbit of amplitude A reaches one of ``walls`` (False without them)."""
        A = np.asarray(A, dtype=float)
        hit = np.zeros(A.shape, dtype=bool)
        for w in self.walls:
            hit |= reached(A, w)
        return hit

    def free_orbit(self, A: Array) -> dict[str, Array]:
        """Period and time averages along the exact orbit of amplitude A (any shape).

        ``x2jv2`` [j] = <x^{2j} v^2> for each damping term d_{2j}, ``v2jv2`` [j] =
        <v^{2j+2}> for each velocity-damping term e_{2j+2} (j >= 1); ``v2`` and ``x2v2``
        as before. With y = A cos(theta), y' = -A nu sin(theta): <h>_t = int h / nu / T."""
        A = np.asarray(A, dtype=float)
        k = self.restoring
        m = 2 * self.theta_nodes
        th = np.arange(m) * (np.pi / m)  # trapezoid on one period of pi-periodic integrands
        nu = nu_k(A[..., None], th, k)
        s2, c2 = np.sin(th) ** 2, np.cos(th) ** 2
        rest = A == 0.0
        if k[0] == 0.0 and np.any(rest):  # no linear spring: nu = 0, T = inf at A = 0
            nu = np.where(rest[..., None], 1.0, nu)
        T = 2 * np.pi * np.mean(1.0 / nu, axis=-1)
        avg = {
            "T": T,
            "v2": A**2 * 2 * np.pi * np.mean(nu * s2, axis=-1) / T,
            "x2v2": A**4 * 2 * np.pi * np.mean(nu * s2 * c2, axis=-1) / T,
            "y2": A**2 * 2 * np.pi * np.mean(c2 / nu, axis=-1) / T,
            "absv": 4.0 * A / T,
            "E": potential_k(A, k),
        }
        if k[0] == 0.0 and np.any(rest):  # every average at the rest point is 0
            avg["T"] = np.where(rest, np.inf, T)
        avg["x2jv2"] = [avg["v2"], avg["x2v2"]] + [
            A ** (2 * j + 2) * 2 * np.pi * np.mean(nu * s2 * c2**j, axis=-1) / T
            for j in range(2, len(self.damping))]
        avg["v2jv2"] = [A ** (2 * j + 2) * 2 * np.pi * np.mean(nu ** (2 * j + 1) * s2 ** (j + 1),
                                                               axis=-1) / T
                        for j in range(1, len(self.velocity_damping) + 1)]
        return avg

    def damping_rate(self, o: dict[str, Array]) -> Array:
        """-<(d(x) + e(x')) x'^2> on the orbit: the energy drift of both damping laws.
        For the paper's laws this is c1 <v^2> - c2 <x^2 v^2> (same operations, same bits)."""
        d = self.damping
        out = -d[0] * o["x2jv2"][0] if d else np.zeros_like(o["T"])
        for j in range(1, len(d)):
            out = out - d[j] * o["x2jv2"][j]
        for j, e in enumerate(self.velocity_damping):
            out = out - e * o["v2jv2"][j]
        return out

    def harmonics_of_Y(self, A: Array, T: Array) -> tuple[Array, Array, Array]:
        """Y_0 and (n, Y_n) for the harmonics that Y = s(y) y carries (quarter-orbit GL)."""
        A = np.asarray(A, dtype=float)
        th, w = gauss_quarter(self.theta_nodes)
        t = time_of_theta_k(A, th, self.restoring)  # (..., K)
        nu = nu_k(A[..., None], th, self.restoring)
        base = (4.0 / T)[..., None] * (w * np.cos(th))[None, :] * A[..., None] / nu
        # cos(n Omega t) at the nodes by the Chebyshev recurrence in n (one cosine per node
        # instead of one per harmonic: 5x faster, the same numbers to ~1e-14 relative):
        # even n: c_{k+1} = 2 cos(2 Omega t) c_k - c_{k-1}; odd n the same over steps of 2
        k = np.arange(1, self.harmonics + 1)
        sgn = self.noise == "sgn"
        n = 2 * k if sgn else 2 * k - 1
        Omega = 2 * np.pi / T
        x = np.cos((2.0 if sgn else 1.0) * Omega[..., None] * t)  # cos of the first harmonic
        two_c = 2.0 * x if sgn else 2.0 * (2.0 * x * x - 1.0)  # 2 cos of the harmonic step
        prev, cur = (np.ones_like(x), x) if sgn else (x, x)  # n = 0 (n = -1), n = 1st
        Yn = np.empty(A.shape + (self.harmonics,))
        for j in range(self.harmonics):
            if j:
                prev, cur = cur, two_c * cur - prev
            Yn[..., j] = np.einsum("...k,...k->...", base, cur)
        Y0 = base.sum(axis=-1) if sgn else np.zeros_like(A)
        return Y0, n.astype(float), Yn

    @property
    def parametric(self) -> bool:
        """Whether a parametric noise is on (D_k or D_c nonzero)."""
        return bool(self.D_k or self.D_c)

    def parametric_terms(self, A: Array) -> tuple[Array, Array]:
        """(drift beyond the symmetric part, sigma_E^2) of the parametric noises
        (averaging.parametric.terms; zeros when they are off)."""
        return parametric.terms(self, A)

    def sigma2_energy(self, A: Array, orbit: dict[str, Array] | None = None) -> Array:
        """sigma_E^2(E(A)): the external noise's (:meth:`sigma2_external`) plus the
        parametric noises' 2 D_k <g^2 v^2> + 2 D_c <d^2 v^4> when they are on."""
        s2 = self.sigma2_external(A, orbit)
        if self.parametric:
            s2 = s2 + self.parametric_terms(A)[1]
        return s2

    def sigma2_external(self, A: Array, orbit: dict[str, Array] | None = None) -> Array:
        """sigma_E^2(E(A)) of the averaged energy equation from the external noise f xi.

        White noise: 2 pi f^2 S <v^2>. OU noise: the harmonic sum 4 pi f^2 sum_n u_n^2 Y_n^2
        S(u_n), u_n = n Omega, is taken in one of two exact forms, both from the identity
        u^2 S(u) = c - a2 S(u) (docs/averaging.md):

        - (P) Parseval on Y:  c/2 (<y^2> - Y_0^2) - a2 sum_n Y_n^2 S(u_n);
        - (V) Parseval on dY/dt (<(dY/dt)^2> = <v^2>, the white-noise limit first):
          (c / a2) <v^2>/2 - (1/a2) sum_n u_n^4 Y_n^2 S(u_n).

        Each is a difference of two terms. (P) cancels when the orbit is slow against the
        noise (Omega << alpha1: a2 S(u_n) ~ c, e.g. k1 = 0 as A -> 0, where Omega -> 0), (V)
        when it is fast; each A takes the form whose subtracted fraction is smaller, so the
        relative rounding stays ~1e-16 / (1 - fraction) <= ~2e-16 * 2. The true value is >= 0
        (a spectral density): a negative result within spectral_sum.SIGMA2_ROUNDOFF of the
        terms' size is rounding and set to 0; a larger one means the harmonics are wrong (too
        few, or more than the quarter-orbit quadrature resolves): ArithmeticError naming A,
        never a clamp (spectral_sum.sigma2_rational).

        ``orbit``: :meth:`orbit` (A), when the caller has it. Computed once per grid inside
        averaging.memo.shared (the same array, read-only)."""
        A = np.asarray(A, dtype=float)
        return memo.recall("sigma2_external", self._memo_params(
            "orbit", "free_orbit", "reached", "harmonics_of_Y", "sigma2_external",
            "sigma2_general", "_sigma2_truncated"), A, lambda: self._sigma2_external(A, orbit))

    def _sigma2_external(self, A: Array, orbit: dict[str, Array] | None) -> Array:
        o = self.orbit(A) if orbit is None else orbit
        S = self.spectrum
        if S.flat:
            return 2.0 * np.pi * self.f**2 * S.level() * o["v2"]
        if not S.rational:
            return self.sigma2_general(A, o)
        hit = self.reached(A)
        if not np.any(hit):
            return sigma2_rational(self, A, o)
        free = sigma2_rational(self, A, self.free_orbit(A))
        return np.where(hit, self._sigma2_truncated(np.where(hit, A, 1.0)), free)

    def sigma2_general(self, A: Array, orbit: dict[str, Array] | None = None) -> Array:
        """sigma_E^2 of the external noise by the general harmonic sum, for ANY spectrum:
        4 pi f^2 sum_n u_n^2 Y_n^2 S(u_n) with S evaluated at the orbit's harmonics and the
        kinks' tails from their asymptotics (spectral_sum.sigma2_harmonic on the free orbit or
        the paper's wall, spectral_sum.sigma2_harmonic_truncated where walls are reached).
        The path of every kind that is neither flat nor rational; flat and OU keep their
        fast paths, which agree with this one (tests/test_bounded_averaging.py)."""
        A = np.asarray(A, dtype=float)
        hit = self.reached(A)
        if not np.any(hit):
            return sigma2_harmonic(self, A, self.orbit(A) if orbit is None else orbit)
        out = np.empty(A.shape)
        if not np.all(hit):
            free = A[~hit]
            out[~hit] = sigma2_harmonic(self, free, self.free_orbit(free))
        a, b = span(self.walls)
        out[hit] = sigma2_harmonic_truncated(
            A[hit], self.restoring, a, b, f=self.f, spectrum=self.spectrum,
            count=2 * self.harmonics, nodes=2 * self.theta_nodes)
        return out

    def _sigma2_truncated(self, A: Array) -> Array:
        """sigma_E^2 of a rational (OU) spectrum on the truncated orbit (truncated.sigma2)."""
        a, b = span(self.walls)
        return truncated.sigma2(A, self.restoring, a, b, f=self.f, spectrum=self.spectrum,
                                count=2 * self.harmonics, nodes=2 * self.theta_nodes)


    def energy_terms(self, A: Array) -> dict[str, Array]:
        """Deterministic energy drift m_d split by effect, sigma_E^2, T and E."""
        A = np.asarray(A, dtype=float)
        o = self.orbit(A)
        E, T = o["E"], o["T"]
        if self.walls:
            loss = self.wall_losses(A, E, T)
        elif not self.barrier:
            loss = np.zeros_like(A)
        elif self.impact == "exact":
            loss = -(2.0 / T) * (1.0 - self.r**2) * E
        elif self.impact == "transformed":
            loss = -(2.0 / T) * 2.0 * (1.0 - self.r) * E
        elif self.impact == "compounded":
            loss = -(2.0 / T) * (-2.0 * np.log(self.r)) * E
        else:
            one_of("impact", self.impact, IMPACT_TREATMENTS)  # raises: a law without a branch
        wz, s2p = self.parametric_terms(A)
        return {
            "damping": self.damping_rate(o),
            "impact": loss,
            "friction": -self.mu * o["absv"],
            "parametric": wz,
            "sigma2": self.sigma2_external(A, o) + s2p if self.parametric
            else self.sigma2_external(A, o),
            "T": T,
            "E": E,
        }

    def wall_losses(self, A: Array, E: Array, T: Array) -> Array:
        """The impact loss rate of ``walls`` (averaging.walls.loss_rate)."""
        return loss_rate(self.walls, A, E, T, self.restoring, self.impact)

    # ------------------------------------------------------------------ amplitude form
    def terms(self, A: Array) -> dict[str, Array]:
        """Amplitude-form drift terms and sigma_A^2 (A > 0), as PaperModel.terms.

        The noise-induced drift (1/(2T)) d(T sigma_E^2)/dE is differentiated with a
        4-point central stencil in A (relative step 1e-3, truncation ~1e-12 relative).
        """
        A = np.asarray(A, dtype=float)
        et = self.energy_terms(A)
        g, gp = restoring_k(A, self.restoring), restoring_slope_k(A, self.restoring)
        h = 1e-3 * A

        def TS(x: Array) -> Array:
            o = self.orbit(x)
            return o["T"] * self.sigma2_energy(x, o)

        dTS = (8 * (TS(A + h) - TS(A - h)) - (TS(A + 2 * h) - TS(A - 2 * h))) / (12 * h)
        m_noise_E = dTS / (2.0 * et["T"] * g)
        s2E = et["sigma2"]
        return {
            "damping": et["damping"] / g,
            "impact": et["impact"] / g,
            "friction": et["friction"] / g,
            "parametric": et["parametric"] / g,
            "noise": m_noise_E / g - gp * s2E / (2.0 * g**3),
            "sigma2": s2E / g**2,
        }

    @amplitudes
    def drift(self, A: Array) -> Array:
        t = self.terms(A)
        return t["damping"] + t["impact"] + t["friction"] + t["parametric"] + t["noise"]

    @amplitudes
    def diffusion(self, A: Array) -> Array:
        """sigma_A^2 = sigma_E^2 / g^2 (without the drift's derivative stencil)."""
        A = np.asarray(A, dtype=float)
        return self.sigma2_energy(A) / restoring_k(A, self.restoring) ** 2

    def period(self, A: Array) -> Array:
        return self.orbit(np.asarray(A, dtype=float))["T"]

    def log_stationary_parts(self, A: Array) -> tuple[Array, Array, Array]:
        """(q, log_pre, log_phase_pre): log p_A = log(T g) + int_0^A 2 m_d g / sigma_E^2."""
        A = np.asarray(A, dtype=float)
        et = self.energy_terms(A)
        g = restoring_k(A, self.restoring)
        md = et["damping"] + et["impact"] + et["friction"] + et["parametric"]
        with np.errstate(divide="ignore", invalid="ignore"):
            q = 2.0 * md * g / et["sigma2"]
            log_pre = np.log(et["T"]) + np.log(g)
        # k1 = 0 (no linear spring): T -> inf, g -> 0 at A = 0, where p_A vanishes
        log_pre = np.where(A > 0, log_pre, -np.inf)
        return q, log_pre, np.zeros_like(A)



def energy_rates(scene: Any, A: float) -> dict[str, float]:
    """Magnitudes of the energy rates of each effect on the exact orbit of amplitude ``A``
    (plain numbers, for the harness's assumption checks): period ``T``, energy ``E``,
    ``linear damping`` |d0| <v^2> (= |c1| <v^2>), ``cubic damping`` sum_j>=1 |d_2j| <x^2j v^2>
    (= c2 <x^2 v^2>), ``velocity damping`` sum_j |e_2j| <v^2j+2>, ``impacts`` and ``friction``
    (|m_d| terms of ExactModel.energy_terms) and the noise's ``sigma2_E``."""
    model = ExactModel.from_scene(scene)
    a = np.array([float(A)])
    et = model.energy_terms(a)
    o = model.orbit(a)
    return {"T": float(et["T"][0]), "E": float(et["E"][0]),
            "linear damping": abs(model.damping[0]) * float(o["v2"][0]) if model.damping
            else 0.0,
            "cubic damping": sum(abs(d) * float(o["x2jv2"][j][0])
                                 for j, d in enumerate(model.damping) if j >= 1),
            "velocity damping": sum(abs(e) * float(o["v2jv2"][j][0])
                                    for j, e in enumerate(model.velocity_damping)),
            "impacts": abs(float(et["impact"][0])),
            "friction": abs(float(et["friction"][0])),
            "sigma2_E": float(et["sigma2"][0])}
