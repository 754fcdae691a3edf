"""The measured curves behind check's issue-23 thresholds (docs/report.md, "Warnings").

    python docs/scripts/warning_curves.py [RESULTS.json ...] [--png docs/img/warning-curves.png]

Reads the probe results of docs/scripts/regime_probes.py (default: benchmarks/results/
regime_probes_f01.json), recomputes each scene's validity numbers (averaging/validity.py) and
prints, per scene: the best of exact/corrected L1(A) in units of its floor, corrected - exact in
units of the floor, and the indicators band (alpha1/Omega, lowest over the bulk), wall
(delta/E at the 10% energy) and correlation (sigma_E^2/(alpha1 E^2) at the median energy),
as markdown, sorted by correlation. Writes a three-panel PNG and the rows as JSON beside it.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "docs" / "scripts"))

import regime_probes as rp  # noqa: E402
from vifpk.averaging.validity import validity  # noqa: E402
from vifpk.harness.workflows.assumptions import BAND_MIN, CORRELATION_MAX, WALL_MAX  # noqa: E402


def rows(paths: list[Path]) -> list[dict]:
    scenes = dict(rp.all_scenes())
    out = []
    for path in paths:
        for key, r in json.loads(path.read_text()).items():
            name = key.split(" @")[0]
            if name not in scenes or "dt=0.01 " not in key:
                continue
            v = validity(scenes[name])
            if v["band"] is None:
                continue
            fl, M = r["L1_floor"], r["models"]
            ex, co = M["exact"]["L1"], M["corrected"]["L1"]
            out.append({"scene": name, "source": path.name, "floor": fl, "exact": ex,
                        "corrected": co, "best_over_floor": min(ex, co) / fl,
                        "corrected_minus_exact_over_floor": (co - ex) / fl,
                        "band": min(v["band"]), "wall": v["wall"][0],
                        "correlation": v["correlation"][1]})
    return sorted(out, key=lambda x: x["correlation"])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("results", nargs="*",
                    default=[str(ROOT / "benchmarks/results/regime_probes_f01.json")])
    ap.add_argument("--png", default=str(ROOT / "docs/img/warning-curves.png"))
    args = ap.parse_args()
    rs = rows([Path(p) for p in args.results])
    print("| scene | floor | exact | corrected | best/floor | (corr-exact)/floor | "
          "alpha1/Omega | delta/E (10%) | sigma_E^2/(alpha1 E^2) (50%) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rs:
        print(f"| {r['scene']} | {r['floor']:.4f} | {r['exact']:.3f} | {r['corrected']:.3f} | "
              f"{r['best_over_floor']:.1f} | {r['corrected_minus_exact_over_floor']:+.1f} | "
              f"{r['band']:.2f} | {r['wall']:.2f} | {r['correlation']:.3f} |")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(13, 4))
    for a, key, lim, ylab, y in (
            (ax[0], "correlation", CORRELATION_MAX, "best L1 / floor", "best_over_floor"),
            (ax[1], "band", BAND_MIN, "best L1 / floor", "best_over_floor"),
            (ax[2], "wall", WALL_MAX, "(corrected - exact) / floor",
             "corrected_minus_exact_over_floor")):
        a.scatter([r[key] for r in rs], [r[y] for r in rs], s=18)
        a.axvline(lim, color="r", ls="--", lw=1)
        a.axhline(2.0 if y == "best_over_floor" else 1.0, color="gray", ls=":", lw=1)
        if y != "best_over_floor":
            a.axhline(-1.0, color="gray", ls=":", lw=1)
        a.set_xlabel({"correlation": "sigma_E^2 / (alpha1 E^2) at the median energy",
                      "band": "alpha1 / Omega(E), lowest over the 10-90% energies",
                      "wall": "delta / E at the 10% energy"}[key])
        a.set_ylabel(ylab)
        a.set_xscale("log")
    fig.tight_layout()
    fig.savefig(args.png, dpi=90)
    Path(args.png).with_suffix(".json").write_text(json.dumps(rs, indent=1))
    print(f"wrote {args.png}")


if __name__ == "__main__":
    main()
