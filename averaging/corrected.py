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
from .geometry import Array, amplitude_of_energy_k, potential_k, restoring_k


@dataclass(frozen=True, kw_only=True)
class CorrectedModel(ExactModel):
    """ExactModel with the compounded per-impact loss -ln(r^2) E (discrete impacts)."""

    impact: str = "compounded"
    name: str = "corrected"

    @classmethod
    def from_scene(cls, scene: Any, *, noise: str = "sgn", theta_nodes: int | None = None,
                   harmonics: int | None = None) -> CorrectedModel:
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


def q_frame_density(model: CorrectedModel, A: Array, *, nodes: int = 8) -> Array:
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
    m_s = ((et["damping"] + et["friction"]) / fac) @ w
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
