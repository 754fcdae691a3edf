"""What the residual of the averaged models is made of (docs/averaging.md section 10; issue 15).

    NUMBA_NUM_THREADS=1 nice -n 10 python docs/scripts/residual_study.py [--cache DIR]

For every shipped scene variant (duplicates of the base scene dropped) and the probe scenes
below, a Monte Carlo of the original system at a target L1 noise floor of 0.005 (100 bins on
[0, 1.1 A_max], cached in DIR, default /tmp/vifpk-residual) and L1(A) of:

    paper, exact, corrected              the shipped averaged models (averaging.solve)
    +offset                              corrected, with the impact loss charged on E - delta(E)
    +offset+fast                         ... and p(E) convolved with N(0, sigma_E^2 / (2 alpha1))

The last two are the prototype second-order terms of section 10, derived (no fitted constant)
but not in the package: delta(E) by linear response of one flight (RK4 of the orbit and its
variational equation from the wall), the fast fluctuation from the first-order corrector.
Prints a markdown table: L1 and mean shift (model - MC) per model, and the noise floor.
About 25 minutes on one shared core.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from vifpk.averaging.corrected import CorrectedModel, _flight  # noqa: E402
from vifpk.averaging.geometry import potential, restoring  # noqa: E402
from vifpk.averaging.stationary import amplitude_density  # noqa: E402
from vifpk.harness.door.solvers import montecarlo_solution  # noqa: E402
from vifpk.harness.workflows.compare import compare  # noqa: E402

from vifpk import averaging  # noqa: E402
from vifpk.core.scene import load_scene  # noqa: E402

# shipped scene variants without duplicates (fig6[r=0.975] is fig5[mu=0.001])
SHIPPED = [("paper-base", 0), ("paper-fig2", 0), ("paper-fig2", 2), ("paper-fig3", 0),
           ("paper-fig3", 2), ("paper-fig4", 1), ("paper-fig4", 2), ("paper-fig5", 0),
           ("paper-fig5", 1), ("paper-fig5", 2), ("paper-fig6", 1)]
HALF = {"system.c1": 0.0125, "system.c2": 0.025, "system.mu": 0.0005, "system.r": 0.98,
        "noise.D": 0.005}  # every dissipative coefficient, 1 - r and D scaled by k = 1/2
PROBES = [{"noise.alpha1": 0.5}, {"system.r": 0.92}, {"system.r": 1.0},
          {"noise.alpha1": 0.5, "system.r": 1.0}, {"noise.alpha1": 1.0, "system.r": 1.0},
          {"system.mu": 0.01, "system.r": 1.0}, {"noise.alpha1": 0.5, "system.barrier": False},
          HALF, {**HALF, "noise.alpha1": 1.0}, {**HALF, "noise.alpha1": 0.5}]
FLOOR = 0.005


def scenes():
    for name, i in SHIPPED:
        yield load_scene(ROOT / "scenes" / f"{name}.toml").variants()[i]
    base = load_scene(ROOT / "scenes" / "paper-base.toml")
    for over in PROBES:
        label = ", ".join(f"{k.split('.')[1]}={v}" for k, v in over.items())
        yield replace(base.with_values(over), name=f"base: {label}")


def mc_histogram(scene, cache: Path):
    key = hashlib.md5(json.dumps([scene.to_dict()["system"], scene.to_dict()["noise"],
                                  FLOOR]).encode()).hexdigest()[:12]
    fn = cache / f"mc_{key}.npz"
    if not fn.exists():
        closed = [averaging.solve(scene, model=m) for m in ("paper", "exact")]
        top = 1.1 * max(float(r.data["A"]["x"][-1]) for r in closed)
        edges = np.linspace(0.0, top, scene.montecarlo.bins + 1)
        sc = replace(scene, montecarlo=replace(scene.montecarlo, floor=FLOOR, budget=1500,
                                               threads=1),
                     observables=replace(scene.observables, A=True, x1=False, x2=False,
                                         joint=False, events=True, moments=True))
        mc = montecarlo_solution(sc, progress=False, edges_A=edges, edges_x=edges,
                                 edges_v=np.linspace(-3 * top, 3 * top, 101))
        a = mc.data["A"]
        np.savez(fn, x=a["x"], p=a["p"], edges=a["edges"], err=a["err"])
    d = np.load(fn)
    return {k: d[k] for k in ("x", "p", "edges", "err")}


# ---------------------------------------------------------------- prototype terms
def wall_offset(m, A, n=200):
    """delta(E): time average over a flight of E[H(t)] - H(wall), beyond a uniform gain.

    W(t) = int_0^t f xi x' dt' is the noise work since the impact; with the orbit response
    Phi (force impulse at t'' -> x, v at t) and R the OU covariance, to second order in xi:
      E W(t)          = f^2 int_0^t dt' int_0^t' R(t' - t'') Phi_v(t', t'') dt''
      E[dtau W(tau)]  = -(f^2 / x'(tau)) int dt x'(t) int dt'' Phi_x(tau, t'') R(t - t'')
      E W(tau')       = E W(tau) - f^2 int Phi_x(tau, t'') R(tau - t'') dt''
      delta = (int_0^tau E W dt + E[dtau W(tau)]) / tau - E W(tau') / 2.
    Quasi-static check (alpha = 0, alpha1 -> 0): delta -> f^2 D / (alpha1 omega0^2).
    """
    A = np.atleast_1d(np.asarray(A, float))
    o = m.orbit(A)
    tau = 0.5 * o["T"]
    Y, h = _flight(o["E"], (m.omega0**2, m.alpha), tau, n)  # the package's RK4
    t = np.arange(n + 1)[None, :] * h[:, None]
    xd = Y[:, :, 1]
    m00, m01, m10, m11 = (Y[:, :, k] for k in (2, 3, 4, 5))
    phi_v = m10[:, :, None] * (-m01[:, None, :]) + m11[:, :, None] * m00[:, None, :]
    phi_x_end = m00[:, -1, None] * (-m01) + m01[:, -1, None] * m00
    a1 = m.spectrum.alpha1
    R = (m.spectrum.D / a1) * np.exp(-a1 * np.abs(t[:, :, None] - t[:, None, :]))
    w = np.ones(n + 1)
    w[0] = w[-1] = 0.5
    K = R * phi_v * np.tril(np.ones((n + 1, n + 1)))[None]
    inner = (K.sum(axis=2) - 0.5 * K[:, :, 0] - 0.5 * np.einsum("nii->ni", K)) * h[:, None]
    inner[:, 0] = 0.0
    f2 = m.f**2
    EW = f2 * np.concatenate([np.zeros((A.size, 1)), np.cumsum(
        0.5 * (inner[:, 1:] + inner[:, :-1]), axis=1) * h[:, None]], axis=1)
    part = np.einsum("nij,nj,j->ni", R, phi_x_end, w) * h[:, None]
    cross = -(f2 / xd[:, -1]) * np.einsum("ni,ni,i->n", part, xd, w) * h
    total = EW[:, -1] - f2 * np.einsum("nj,nj,j->n", phi_x_end, R[:, -1, :], w) * h
    return (np.einsum("ni,i->n", EW, w) * h + cross) / tau - 0.5 * total


class WithOffset(CorrectedModel):
    """corrected, with the impact loss -(2/T) lambda (E - delta(E)) (delta tabulated)."""

    def energy_terms(self, A):
        et = super().energy_terms(A)
        if self.barrier and self.spectrum.kind == "ou":
            if self not in _TABLES:
                _TABLES[self] = self._table()
            tab = _TABLES[self]
            d = np.interp(et["E"], tab[0], tab[1])
            et["impact"] = -(2.0 / et["T"]) * self.lam * (et["E"] - d)
        return et

    def _table(self):
        A = np.linspace(1e-3, 3.0, 121)
        return potential(A, self.omega0, self.alpha), wall_offset(self, A)


_TABLES: dict = {}


def fast_fluctuation(m, A, p):
    """p_H = p_E convolved with N(0, V(E)), V = sigma_E^2 / (2 alpha1) (first-order corrector
    psi = xi a(phase): its variance (D / alpha1) <a^2> = sigma_E^2 / (2 alpha1))."""
    if m.spectrum.kind != "ou":
        return A, p
    E, g = potential(A, m.omega0, m.alpha), restoring(A, m.omega0, m.alpha)
    pE = np.where(g > 0, p / np.maximum(g, 1e-300), 0.0)
    V = m.sigma2_energy(np.maximum(A, 1e-9)) / (2 * m.spectrum.alpha1) + 1e-300
    K = np.exp(-(E[:, None] - E[None, :]) ** 2 / (2 * V)) / np.sqrt(2 * np.pi * V)
    pA = (K @ (pE * np.gradient(E))) * g
    return A, pA / np.trapezoid(pA, A)


def densities(scene):
    out = {m: averaging.solve(scene, model=m).data["A"] for m in ("paper", "exact", "corrected")}
    wo = WithOffset.from_scene(scene)
    amp = amplitude_density(wo, points=801)
    out["+offset"] = {"x": amp.A, "p": amp.p}
    x, p = fast_fluctuation(wo, amp.A, amp.p)
    out["+offset+fast"] = {"x": x, "p": p}
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cache", default="/tmp/vifpk-residual")
    cache = Path(ap.parse_args().cache)
    cache.mkdir(parents=True, exist_ok=True)
    names = ("paper", "exact", "corrected", "+offset", "+offset+fast")
    print("| scene | " + " | ".join(names) + " | MC floor |")
    print("|---|" + "---|" * (len(names) + 1))
    for scene in scenes():
        h = mc_histogram(scene, cache)
        cells, floor = [], 0.0
        for d in densities(scene).values():
            c = compare(d, h)
            floor = c["L1_floor"]
            cells.append(f"{c['L1']:.3f} ({c['mean_diff']:+.3f})")
        print(f"| {scene.name} | " + " | ".join(cells) + f" | {floor:.4f} |", flush=True)


if __name__ == "__main__":
    main()
