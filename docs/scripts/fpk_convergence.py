"""Convergence of the flux-form FPK (direct solve of the SG discretisation) against closed forms.

    python docs/scripts/fpk_convergence.py     # writes docs/img/fpk_convergence.png
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.interpolate import CubicSpline  # noqa: E402
from vifpk.averaging import build_model, solve  # noqa: E402

from vifpk import fpk  # noqa: E402
from vifpk.core.scene import load_scene  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def main() -> None:
    cells = np.array([50, 100, 200, 400, 800, 1600])
    a, s = 0.1, 0.02
    ray = []
    for n in cells:
        r = fpk.stationary(lambda A: -a * A + s / (2 * A), lambda A: s + 0 * A, cells=int(n),
                           method="direct", lo=0.0, hi=2.5)
        x, p = r.data["A_cells"]["x"], r.data["A_cells"]["p"]
        exact = (2 * a / s) * x * np.exp(-a * x**2 / s)
        ray.append(np.sum(np.abs(p - exact)) * r.info["grid"]["h"])
    scene = load_scene(ROOT / "scenes" / "paper-base.toml")
    from dataclasses import replace

    fine = replace(scene, averaging=replace(scene.averaging, points=12801))
    cf = solve(fine, model="paper")
    spline = CubicSpline(cf.data["A"]["x"], cf.data["A"]["p"])
    m = build_model(scene, "paper")
    base = []
    for n in cells:
        r = fpk.stationary(m.drift, m.diffusion, cells=int(n), method="direct")
        x, p = r.data["A_cells"]["x"], r.data["A_cells"]["p"]
        ref = np.where(x <= cf.data["A"]["x"][-1], spline(np.minimum(x, cf.data["A"]["x"][-1])), 0)
        base.append(np.sum(np.abs(p - ref)) * r.info["grid"]["h"])
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for errs, label in [(ray, "Rayleigh (exact p known)"), (base, "base scene, paper model")]:
        slope = -np.polyfit(np.log(cells), np.log(errs), 1)[0]
        ax.loglog(cells, errs, "o-", label=f"{label}: slope {slope:.2f}")
    ax.loglog(cells, ray[0] * (cells / cells[0]) ** -2.0, "k--", lw=0.8, label="order 2")
    ax.axhline(1e-4, color="grey", lw=0.6)
    ax.set_xlabel("cells N")
    ax.set_ylabel("L1 error of p(A)")
    ax.set_title("Flux-form FPK (Scharfetter-Gummel) against closed forms")
    ax.legend(fontsize=8)
    fig.tight_layout()
    out = ROOT / "docs" / "img" / "fpk_convergence.png"
    fig.savefig(out, dpi=120)
    print(out, "\nRayleigh", ray, "\nbase", base)


if __name__ == "__main__":
    main()
