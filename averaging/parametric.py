"""Orbit averages for the parametric white noises (vifpk/physics/noise/parametric.py;
docs/averaging.md section 12): <g^2>, <g^2 v^2>, <d^2 v^2>, <d^2 v^4> on the orbit of
amplitude A, free (trapezoid over theta in [0, pi), the periodic rule of ExactModel.orbit) or
truncated by walls (Gauss-Legendre, averaging/truncated.py), with x = A cos(theta),
v^2 = A^2 nu^2 sin^2(theta), dt = d theta / nu."""

from __future__ import annotations

from typing import Any

import numpy as np

from vifpk.physics import spring
from vifpk.physics.noise import parametric as parametric_noise

from . import truncated
from .geometry import Array, nu_k
from .walls import span


def _damping(x2: Array, d: tuple[float, ...]) -> Array:
    """d(x) = d0 + d2 x^2 + ... (Horner in x^2)."""
    out = 0.0 * x2
    for c in reversed(d):
        out = out * x2 + c
    return out


def _averages(x: Array, v2: Array, wt: Array, k: tuple[float, ...], d: tuple[float, ...]
              ) -> dict[str, Array]:
    norm = wt.sum(axis=-1)

    def avg(h: Array) -> Array:
        return np.einsum("...k,...k->...", wt, h) / norm

    g2 = spring.restoring(x, k) ** 2
    dd = _damping(x * x, d) ** 2 if d else 0.0 * x
    return {"g2": avg(g2), "g2v2": avg(g2 * v2), "d2v2": avg(dd * v2), "d2v4": avg(dd * v2 * v2)}


def averages(model: Any, A: Array) -> dict[str, Array]:
    """The four averages for an ExactModel ``model`` at amplitudes A (any shape, A > 0)."""
    A = np.asarray(A, dtype=float)
    k, d = model.restoring, model.damping
    m = 2 * model.theta_nodes
    th = np.arange(m) * (np.pi / m)
    nu = nu_k(A[..., None], th, k)
    x = A[..., None] * np.cos(th)
    v2 = (A[..., None] * np.sin(th)) ** 2 * nu**2
    out = _averages(x, v2, 1.0 / nu, k, d)
    hit = model.reached(A)
    if np.any(hit):
        a, b = span(model.walls)
        At = np.where(hit, A, 1.0)
        th, w, _, _ = truncated.theta_nodes(At, a, b, m)
        nu = nu_k(At[..., None], th, k)
        x = At[..., None] * np.cos(th)
        v2 = (At[..., None] * np.sin(th)) ** 2 * nu**2
        tr = _averages(x, v2, w / nu, k, d)
        out = {key: np.where(hit, tr[key], out[key]) for key in out}
    return out


def terms(model: Any, A: Array) -> tuple[Array, Array]:
    """(drift beyond the symmetric part, sigma_E^2) of the parametric noises of an ExactModel
    on the orbit of amplitude A (vifpk.physics.noise.parametric: -D_c <d^2 v^2> and
    2 D_k <g^2 v^2> + 2 D_c <d^2 v^4>); zeros when they are off and at A = 0."""
    A = np.asarray(A, dtype=float)
    if not (model.D_k or model.D_c):
        return np.zeros_like(A), np.zeros_like(A)
    avg = averages(model, np.where(A > 0, A, 1.0))
    kw = {"D_k": model.D_k, "D_c": model.D_c, "avg": avg}
    rest = A > 0
    return (np.where(rest, parametric_noise.drift_beyond_symmetric(**kw), 0.0),
            np.where(rest, parametric_noise.energy_diffusion(**kw), 0.0))
