"""The same Strang-splitting scheme as ``kernels.py``, vectorised over paths in plain NumPy.

A reference for speed (benchmarks/bench_montecarlo.py: the ratio numba / NumPy is measured
in one run) and for correctness (tests/test_montecarlo.py checks that both give the same
statistics). Same physics, same rules (impacts, chatter guard, stick-slip); NumPy's own
random numbers, so results agree in distribution, not bit for bit. It is an independent
check: it does not use the noise kinds' compiled pieces (vifpk.physics.noise), but its own
NumPy version of each kind it knows (``_NOISES``); another kind raises in one line. Likewise
its reflection (``_drift``) is its own copy of the paper's wall (x = 0, Newton's law), an
independent check of montecarlo/pieces.py's ``reflect``; other walls raise.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def _exp_phi(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    small = np.abs(z) < 1e-8
    zz = np.where(small, 1.0, z)
    em = np.expm1(-zz)
    phi = np.where(small, 1.0 - 0.5 * z, -em / zz)
    return 1.0 - z * phi, phi


def _velocity_flow(v, tau, F, k, mu, at_wall):
    e, phi = _exp_phi(k * tau)
    if mu is None:
        return v * e + F * tau * phi, np.zeros_like(v)
    hold = np.where(at_wall, F <= mu, np.abs(F) <= mu)
    s = np.sign(v)
    s_rest = np.where(F > 0, 1.0, -1.0)
    moving = v != 0.0
    Fs = F - mu * np.where(moving, s, s_rest)
    vt = np.where(moving, v * e + Fs * tau * phi, Fs * tau * phi)
    crossed = moving & (vt * s <= 0.0)
    # zero crossing time (only where crossed)
    Fsafe = np.where(crossed, Fs, -1.0)
    z = -k * v / Fsafe
    zsafe = np.where(np.abs(z) < 1e-8, 1.0, z)
    L = np.where(np.abs(z) < 1e-8, 1.0 - 0.5 * z,
                 np.where(z > -1.0, np.log1p(np.maximum(zsafe, -1 + 1e-300)) / zsafe, np.inf))
    t_star = np.minimum((-v / Fsafe) * L, tau)
    rest = tau - t_star
    e2, phi2 = _exp_phi(k * rest)
    after = np.where(hold, 0.0, (F - mu * s_rest) * rest * phi2)
    v_new = np.where(crossed, after, vt)
    stuck = np.where(crossed & hold, rest, 0.0)
    at_rest = ~moving & hold
    v_new = np.where(at_rest, 0.0, v_new)
    stuck = np.where(at_rest, tau, stuck)
    return v_new, stuck


def _drift(x, v, tau, r, press, h):
    xn = x + v * tau
    if r is None:
        return xn, v, 0, 0
    hit = xn < 0.0
    if not hit.any():
        return xn, v, 0, 0
    t_hit = np.where(hit, -x / np.where(v == 0, -1.0, v), 0.0)
    w = -r * v
    rest = hit & (press > 0.0) & (w < press * h)
    x_new = np.where(hit, np.where(rest, 0.0, w * (tau - t_hit)), xn)
    v_new = np.where(hit, np.where(rest, 0.0, w), v)
    return x_new, v_new, int(hit.sum()), int(rest.sum())


class _OU:
    """xi' = -alpha1 xi + W: xi held over B(h), updated exactly after the step."""

    def __init__(self, noise: Any, f: float, h: float, paths: int, rng: Any) -> None:
        a1, D = float(noise.alpha1), float(noise.D)
        self.f, self.rng = f, rng
        self.xi = math.sqrt(D / a1) * rng.standard_normal(paths)
        self.a = math.exp(-a1 * h)
        self.s = math.sqrt(D / a1 * (1 - self.a * self.a))

    def press(self) -> np.ndarray:
        return -self.f * self.xi

    def velocity(self, v, g, k, mu, at_wall, h):
        return _velocity_flow(v, h, -g + self.f * self.xi, k, mu, at_wall)

    def advance(self) -> None:
        self.xi = self.a * self.xi + self.s * self.rng.standard_normal(self.xi.shape)


class _White:
    """xi = W: B(h/2), the kick f sqrt(2 D h) N, B(h/2)."""

    def __init__(self, noise: Any, f: float, h: float, paths: int, rng: Any) -> None:
        self.kick, self.rng, self.paths = f * math.sqrt(2 * float(noise.D) * h), rng, paths

    def press(self) -> np.ndarray:
        return np.zeros(self.paths)

    def velocity(self, v, g, k, mu, at_wall, h):
        v, st1 = _velocity_flow(v, 0.5 * h, -g, k, mu, at_wall)
        v = v + self.kick * self.rng.standard_normal(self.paths)
        v, st2 = _velocity_flow(v, 0.5 * h, -g, k, mu, at_wall)
        return v, st1 + st2

    def advance(self) -> None:
        pass


_NOISES = {"ou": _OU, "white": _White}


def simulate_numpy(phys: dict[str, Any], *, paths: int, steps: int, burn: int, stride: int,
                   h: float, edges_A: np.ndarray, seed: int = 0) -> dict[str, Any]:
    """Histogram of A (counts), impacts and stuck time, for ``paths`` paths of ``steps``."""
    rng = np.random.default_rng(seed)
    c1, c2, w0sq, alpha, f = (phys[k] for k in ("c1", "c2", "w0sq", "alpha", "f"))
    mu, kind, lo = phys["mu"], phys["noise"].kind, phys["lower"]
    if kind not in _NOISES:
        raise ValueError(f"noise kind {kind!r} has no NumPy reference (montecarlo.reference)")
    if phys["upper"] is not None or (lo is not None and (lo.at != 0.0 or lo.law != "newton")):
        raise ValueError("walls other than one at x = 0 with Newton's law have no NumPy "
                         "reference (montecarlo.reference)")
    r = lo.r if lo is not None else None
    x = 0.1 * rng.standard_normal(paths)
    if r is not None:
        x = np.abs(x)
    v = 0.1 * rng.standard_normal(paths)
    noise = _NOISES[kind](phys["noise"], f, h, paths, rng)
    half = 0.5 * h
    counts = np.zeros(edges_A.size - 1)
    v2_sum = 0.0
    n_samples = 0
    impacts = 0
    stuck_time = 0.0
    for n in range(steps):
        press = np.zeros(paths)
        if r is not None:
            press = noise.press()
            if mu is not None:
                press = press + mu
        x, v, i1, _ = _drift(x, v, half, r, press, h)
        at_wall = (x == 0.0) if r is not None else np.zeros(paths, dtype=bool)
        k = c2 * x * x - c1
        g = (w0sq + alpha * x * x) * x
        v, st = noise.velocity(v, g, k, mu, at_wall, h)
        x, v, i2, _ = _drift(x, v, half, r, press, h)
        noise.advance()
        if n >= burn:
            impacts += i1 + i2
            stuck_time += float(st.sum())
            if (n - burn + 1) % stride == 0:
                E = 0.5 * v * v + 0.5 * w0sq * x * x + 0.25 * alpha * x**4
                A = np.sqrt(4 * E / (w0sq + np.sqrt(w0sq * w0sq + 4 * alpha * E)))
                counts += np.histogram(A, bins=edges_A)[0]
                v2_sum += float(np.sum(v * v))
                n_samples += paths
    return {"counts": counts, "impacts": impacts, "stuck_time": stuck_time,
            "time": (steps - burn) * h * paths, "mean_v2": v2_sum / max(n_samples, 1)}
