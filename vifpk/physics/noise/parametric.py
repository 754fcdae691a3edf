"""Parametric (multiplicative) white noise on the restoring force and on the damping, in the
Stratonovich sense (the white limit of a physical noise, Wong-Zakai):

    x'' + d(x) x' (1 + xi_c) + g(x) (1 + xi_k) + ... = f xi(t),
    E[xi_k(t) xi_k(t+s)] = 2 D_k delta(s),  E[xi_c(t) xi_c(t+s)] = 2 D_c delta(s),

independent of xi and of each other (scene table [parametric]: stiffness = D_k, damping = D_c).

Averaged models (derivation: docs/averaging.md section 12). With H = v^2/2 + U(x), the
Stratonovich equation dH = -d v^2 dt - d v^2 o dW_c - g v o dW_k + f v o dW has the Ito drift
-d v^2 + 2 D_c d^2 v^2 + D_k g^2 + D f^2 and the squared diffusion
2 D f^2 v^2 + 2 D_k g^2 v^2 + 2 D_c d^2 v^4. Averaged over the orbit of energy E, the
parametric noises add to the energy equation, in terms of the orbit averages
``g2`` <g^2>, ``g2v2`` <g^2 v^2>, ``d2v2`` <d^2 v^2>, ``d2v4`` <d^2 v^4>:
"""

from __future__ import annotations

from typing import Any


def energy_drift(*, D_k: float, D_c: float, avg: dict[str, Any]) -> Any:
    """Ito drift of E: D_k <g^2> + 2 D_c <d^2 v^2> (the Wong-Zakai term of the damping noise,
    D_c <d^2 v^2>, is half of the last term; the other half is Ito's (dv)^2 / 2)."""
    return D_k * avg["g2"] + 2.0 * D_c * avg["d2v2"]


def energy_diffusion(*, D_k: float, D_c: float, avg: dict[str, Any]) -> Any:
    """sigma_E^2: 2 D_k <g^2 v^2> + 2 D_c <d^2 v^4>."""
    return 2.0 * D_k * avg["g2v2"] + 2.0 * D_c * avg["d2v4"]


def drift_beyond_symmetric(*, D_k: float, D_c: float, avg: dict[str, Any]) -> Any:
    """The part of :func:`energy_drift` that is not (1/(2T)) d(T sigma_E^2)/dE of
    :func:`energy_diffusion`: -D_c <d^2 v^2>. The stiffness noise's field (0, -g(x)) is
    divergence free (d(T <g^2 v^2>)/dE = T <g^2>, so its drift is all of that form); the
    damping noise's field (0, -d(x) v) has divergence -d(x), and
    (1/(2T)) d(T 2 D_c <d^2 v^4>)/dE = 3 D_c <d^2 v^2> exceeds its drift by D_c <d^2 v^2>."""
    return -D_c * avg["d2v2"]
