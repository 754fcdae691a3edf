"""A rejected alternative for the impact term (docs/averaging.md 10.5.4).

``exact`` plus the impact jump's second Kramers-Moyal moment as a diffusion,
sigma_E^2 += (2/T) (1 - r^2)^2 E^2 (two impacts a period, each H -> r^2 H), with the Ito
stationary density p(E) ~ exp(int 2 m / sigma^2) / sigma^2 (m includes the noise-induced drift
(1/2T) d(T sigma_noise^2)/dE), against the Monte Carlo histograms cached by regime_probes.py
(floor 0.01, dt 0.01; run that first).

    nice -n 10 python docs/scripts/km_jump_variant.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "docs" / "scripts"))

import regime_probes as rp  # noqa: E402
from vifpk.harness.workflows.compare import compare  # noqa: E402

from vifpk import averaging  # noqa: E402

FILES = ("regime_probes_f01.json", "regime_mechanism_f01.json")


def km_density(scene) -> dict:
    m = averaging.build_model(scene, "exact")
    top = 2.5 * float(averaging.solve(scene, model="exact").data["A"]["x"][-1])
    A = np.linspace(1e-4, top, 3001)
    et = m.energy_terms(A)
    E, T, s2n = et["E"], et["T"], et["sigma2"]
    m_noise = np.gradient(T * s2n, E) / (2 * T)
    jump = 2.0 / T * (1 - m.r**2) ** 2 * E**2 if m.barrier else 0.0 * E
    m_tot = et["damping"] + et["impact"] + et["friction"] + m_noise
    s2 = s2n + jump
    q = 2 * m_tot / s2
    lp = -np.log(s2) + np.concatenate([[0.0], np.cumsum(0.5 * (q[1:] + q[:-1]) * np.diff(E))])
    pA = np.exp(lp - lp.max()) * np.gradient(E, A)
    return {"x": A, "p": pA / np.trapezoid(pA, A)}


def main() -> None:
    res = {}
    for f in FILES:
        rows = json.loads((ROOT / "benchmarks" / "results" / f).read_text())
        res.update({k.split(" @")[0]: v for k, v in rows.items() if "dt=0.01 " in k})
    scenes = dict(rp.all_scenes())
    for name, r in res.items():
        if name not in scenes:
            continue
        sc = scenes[name]
        dens = rp.model_densities(sc)
        top = 1.1 * max(float(dens[m]["x"][-1]) for m in ("exact", "compounded"))
        h = rp.mc_histogram(sc, Path("/tmp/vifpk-probes"), 0.01, 0.01, top)
        km = compare(km_density(sc), h)["L1"]
        M = r["models"]
        print(f"{name[:32]:32s} floor={r['L1_floor']:.3f} exact={M['exact']['L1']:.3f} "
              f"compounded={M['compounded']['L1']:.3f} corrected={M['corrected']['L1']:.3f} "
              f"exact+KM-jump={km:.3f}", flush=True)


if __name__ == "__main__":
    main()
