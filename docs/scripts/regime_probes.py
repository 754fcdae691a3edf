"""Probes of the regimes of issue 23: exact vs corrected (and the section-10.3 terms) against a
Monte Carlo of the original system at a target noise floor, with the MC's dt bias where asked.

    NUMBA_NUM_THREADS=1 nice -n 10 python docs/scripts/regime_probes.py \
        --floor 0.01 [--dt 0.01] [--only NAME ...] [--out benchmarks/results/regime_probes.json]

Each probe is the base scene (scenes/paper-base.toml) with a few values changed; the names say
which. Monte Carlo histograms are cached in --cache (key: system, noise, floor, dt). The JSON
holds, per probe: L1(A) and mean shift (model - MC) of every model, the MC floor, its mean A
with error bar, dt, the load average when the probe finished, and alpha1 / Omega(E) over the
bulk (10%-90% energy quantiles) of the exact model's p(E).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from vifpk.averaging.validity import validity  # noqa: E402
from vifpk.harness.door.solvers import montecarlo_solution  # noqa: E402
from vifpk.harness.workflows.compare import compare  # noqa: E402

from vifpk import averaging  # noqa: E402
from vifpk.core.scene import load_scene  # noqa: E402

# name -> overrides of the base scene. Regimes of issue 23 first, then the curves behind the
# narrow-band threshold (alpha1 against Omega at omega0 = 0.7, 1, 1.5, 2).
PROBES: dict[str, dict] = {
    "stiff w0=1.5 a1=1": {"system.omega0": 1.5, "noise.alpha1": 1.0},
    "posdamp c1=-0.01 r=0.99": {"system.c1": -0.01, "system.r": 0.99},
    "posdamp c1=-0.02 r=0.995": {"system.c1": -0.02, "system.r": 0.995},
    "friction mu=0.006 a1=1.2": {"system.mu": 0.006, "noise.alpha1": 1.2},
    "impact r=0.85": {"system.r": 0.85},
    "impact r=0.85 a1=1": {"system.r": 0.85, "noise.alpha1": 1.0},
    "w0=1.5 a1=1.5": {"system.omega0": 1.5, "noise.alpha1": 1.5},
    "w0=1.5 a1=2": {"system.omega0": 1.5, "noise.alpha1": 2.0},
    "w0=1.5 a1=3": {"system.omega0": 1.5, "noise.alpha1": 3.0},
    "w0=1 a1=0.75": {"noise.alpha1": 0.75},
    "w0=1 a1=1.5": {"noise.alpha1": 1.5},
    "w0=2 a1=2": {"system.omega0": 2.0, "noise.alpha1": 2.0},
    "w0=2 a1=4": {"system.omega0": 2.0, "noise.alpha1": 4.0},
    "w0=0.7 a1=1": {"system.omega0": 0.7, "noise.alpha1": 1.0},
    "w0=0.7 a1=0.5": {"system.omega0": 0.7, "noise.alpha1": 0.5},
    "friction mu=0.006 a1=2": {"system.mu": 0.006},
    "posdamp c1=-0.01 r=0.99 a1=1": {"system.c1": -0.01, "system.r": 0.99,
                                     "noise.alpha1": 1.0},
    "w0=1 a1=0.5": {"noise.alpha1": 0.5},
    "posdamp c1=-0.02 r=0.95": {"system.c1": -0.02, "system.r": 0.95},
    "posdamp c1=-0.02 r=0.95 D=0.005": {"system.c1": -0.02, "system.r": 0.95, "noise.D": 0.005},
    "impact r=0.9 a1=1.5": {"system.r": 0.9, "noise.alpha1": 1.5},
    "impact r=0.85 a1=4": {"system.r": 0.85, "noise.alpha1": 4.0},
    "friction mu=0.006 a1=1.2 w0=1.5": {"system.mu": 0.006, "noise.alpha1": 1.2,
                                         "system.omega0": 1.5},
    "posdamp c1=-0.02 r=0.98 a1=1.5": {"system.c1": -0.02, "system.r": 0.98,
                                       "noise.alpha1": 1.5},
}
HALF = {"system.c1": 0.0125, "system.c2": 0.025, "system.mu": 0.0005, "system.r": 0.98,
        "noise.D": 0.005}  # every dissipative coefficient, 1 - r and D halved (k = 1/2)
#: section-10 style experiments on the regimes (--mechanism): scaling eps (k = 1/2) and
#: switching effects off one at a time
MECHANISM: dict[str, dict] = {
    "stiff w0=1.5 a1=1 k=1/2": {**HALF, "system.omega0": 1.5, "noise.alpha1": 1.0},
    "stiff w0=1.5 a1=1 r=1": {"system.omega0": 1.5, "noise.alpha1": 1.0, "system.r": 1.0},
    "stiff w0=1.5 a1=1 no barrier": {"system.omega0": 1.5, "noise.alpha1": 1.0,
                                     "system.barrier": False},
    "w0=1.5 a1=3 k=1/2": {**HALF, "system.omega0": 1.5, "noise.alpha1": 3.0},
    "w0=1.5 a1=3 r=1": {"system.omega0": 1.5, "noise.alpha1": 3.0, "system.r": 1.0},
    "friction mu=0.006 a1=1.2 k=1/2": {**HALF, "system.mu": 0.003, "noise.alpha1": 1.2},
    "friction mu=0.006 a1=1.2 r=1": {"system.mu": 0.006, "noise.alpha1": 1.2, "system.r": 1.0},
    "impact r=0.85 a1=1 k=1/2": {**HALF, "system.r": 0.925, "noise.alpha1": 1.0},
    "posdamp c1=-0.01 r=0.99 a1=1 k=1/2": {**HALF, "system.c1": -0.005, "system.r": 0.995,
                                           "noise.alpha1": 1.0},
    "posdamp c1=-0.02 r=0.95 k=1/2": {**HALF, "system.c1": -0.01, "system.r": 0.975},
    "posdamp c1=-0.02 r=0.95 r=1": {"system.c1": -0.02, "system.r": 1.0},
    "posdamp c1=-0.01 a1=1 r=1": {"system.c1": -0.01, "system.r": 1.0, "noise.alpha1": 1.0},
}
SHIPPED = [("paper-base", 0), ("paper-fig2", 0), ("paper-fig2", 2), ("paper-fig3", 0),
           ("paper-fig3", 2), ("paper-fig4", 1), ("paper-fig4", 2), ("paper-fig5", 0),
           ("paper-fig5", 1), ("paper-fig5", 2), ("paper-fig6", 1)]


def all_scenes():
    """The shipped scene variants, the user-defined-system families (scenes/systems), then the
    probes."""
    for name, i in SHIPPED:
        sc = load_scene(ROOT / "scenes" / f"{name}.toml").variants()[i]
        yield sc.name, sc
    for path in sorted((ROOT / "scenes" / "systems").glob("*.toml")):  # issue 21 families
        sc = load_scene(path)
        yield sc.name, sc
    base = load_scene(ROOT / "scenes" / "paper-base.toml")
    for name, over in {**PROBES, **MECHANISM}.items():
        yield name, replace(base.with_values(over), name=name)


def mc_histogram(scene, cache: Path, floor: float, dt: float, top: float):
    key = hashlib.md5(json.dumps([scene.to_dict()["system"], scene.to_dict()["noise"],
                                  floor, dt, round(top, 6)]).encode()).hexdigest()[:12]
    fn = cache / f"mc_{key}.npz"
    if not fn.exists():
        edges = np.linspace(0.0, top, scene.montecarlo.bins + 1)
        sc = replace(scene, montecarlo=replace(scene.montecarlo, floor=floor, budget=3000,
                                               threads=1, dt=dt),
                     observables=replace(scene.observables, A=True, x1=False, x2=False,
                                         joint=False, events=True, moments=True))
        t0 = time.perf_counter()
        mc = montecarlo_solution(sc, progress=False, edges_A=edges, edges_x=edges,
                                 edges_v=np.linspace(-3 * top, 3 * top, 101))
        a = mc.data["A"]
        ev = mc.info.get("events", {})
        np.savez(fn, x=a["x"], p=a["p"], edges=a["edges"], err=a["err"],
                 mean=mc.info["summary"]["mean"], mean_err=mc.info["summary"]["mean_err"],
                 seconds=time.perf_counter() - t0,
                 stuck=ev.get("stuck_fraction", {}).get("value", 0.0),
                 dt_used=mc.info["settings"]["dt"])
    d = np.load(fn)
    return {k: d[k] for k in d.files}


def model_densities(scene):
    """name -> {"x", "p"} of p(A): the packaged models, and to switch the section-10.3 terms
    on and off: corrected with the fast-fluctuation map ("corrected+fast") and the map on
    exact ("exact+fast")."""
    from vifpk.averaging.corrected import observed_density

    out = {m: averaging.solve(scene, model=m).data["A"]
           for m in ("exact", "compounded", "corrected")}
    out["corrected+fast"] = averaging.solve(scene, model="corrected", fast=True).data["A"]
    cm = averaging.build_model(scene, "corrected", fast=True)
    x, p = observed_density(cm, out["exact"]["x"], out["exact"]["p"])
    out["exact+fast"] = {"x": x, "p": p}
    return out


def band_ratio(scene, dens) -> dict[str, float]:
    """alpha1 / Omega(E) at the 10%, 50%, 90% quantiles of the exact model's p(A)."""
    if scene.noise.kind != "ou":
        return {}
    A, p = dens["x"], dens["p"]
    c = np.concatenate([[0.0], np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(A))])
    c /= c[-1]
    q = np.interp([0.1, 0.5, 0.9], c, A)
    Om = 2 * np.pi / averaging.build_model(scene, "exact").period(q)
    return {f"alpha1_over_Omega_q{k}": float(scene.noise.alpha1 / o)
            for k, o in zip((10, 50, 90), Om, strict=True)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--floor", type=float, default=0.01)
    ap.add_argument("--dt", type=float, default=0.01)
    ap.add_argument("--cache", default="/tmp/vifpk-probes")
    ap.add_argument("--only", nargs="*")
    ap.add_argument("--shipped", action="store_true", help="also the shipped scene variants")
    ap.add_argument("--mechanism", action="store_true", help="only the MECHANISM experiments")
    ap.add_argument("--out", default=None)
    ap.add_argument("--table", nargs="+", help="print the markdown table of these result files")
    args = ap.parse_args()
    if args.table:
        table(args.table)
        return
    cache = Path(args.cache)
    cache.mkdir(parents=True, exist_ok=True)
    out_path = Path(args.out) if args.out else None
    results = json.loads(out_path.read_text()) if out_path and out_path.exists() else {}
    for name, scene in all_scenes():
        if args.only and name not in args.only:
            continue
        if args.mechanism != (name in MECHANISM) and not args.only:
            continue
        if not args.shipped and name not in PROBES and name not in MECHANISM and not args.only:
            continue
        dens = model_densities(scene)
        top = 1.1 * max(float(dens[m]["x"][-1]) for m in ("exact", "compounded"))
        h = mc_histogram(scene, cache, args.floor, args.dt, top)
        row = {"overrides": PROBES.get(name, MECHANISM.get(name)), "floor_target": args.floor,
               "dt": float(h["dt_used"]), "mc_mean_A": float(h["mean"]),
               "mc_mean_A_err": float(h["mean_err"]), "mc_seconds": float(h["seconds"]),
               "stuck_fraction": float(h["stuck"]), "load_average": os.getloadavg(),
               **band_ratio(scene, dens["exact"]), "validity": validity(scene), "models": {}}
        for m, d in dens.items():
            c = compare(d, h)
            row["models"][m] = {"L1": c["L1"], "L1_err": c["L1_err"],
                                "mean_diff": c["mean_diff"]}
            row["L1_floor"] = c["L1_floor"]
        results[f"{name} @dt={args.dt} floor={args.floor}"] = row
        cells = " ".join(f"{m}={v['L1']:.3f}({v['mean_diff']:+.3f})"
                         for m, v in row["models"].items())
        print(f"{name:32s} floor={row['L1_floor']:.4f} meanA={row['mc_mean_A']:.4f}"
              f"+-{row['mc_mean_A_err']:.4f} a1/Om50={row.get('alpha1_over_Omega_q50', 0):.2f} "
              f"{cells} [{row['mc_seconds']:.0f}s load {row['load_average'][0]:.2f}]",
              flush=True)
        if out_path:
            tmp = out_path.with_suffix(".tmp")
            tmp.write_text(json.dumps(results, indent=1, sort_keys=True))
            tmp.replace(out_path)




def table(paths: list[Path]) -> None:
    """Markdown table of stored rows (later files override earlier ones for the same scene):
    L1(A) (mean shift) of exact, compounded, corrected, the floor, dt, and what check would
    recommend from these numbers (harness.workflows.verdict.recommend with the scene's warnings)."""
    from vifpk.harness.workflows.assumptions import assumption_warnings
    from vifpk.harness.workflows.verdict import recommend

    rows: dict[str, dict] = {}
    for p in paths:
        for key, r in json.loads(Path(p).read_text()).items():
            rows[key.split(" @")[0]] = r
    print("| scene | exact | compounded | corrected | floor | dt | check recommends |")
    print("|---|---|---|---|---|---|---|")
    for name, scene in all_scenes():
        if name not in rows:
            continue
        r = rows[name]
        M = r["models"]
        val = validity(scene)
        closed = {"exact": averaging.solve(scene, model="exact")}
        mc_info = {"events": {"stuck_fraction": {"value": r.get("stuck_fraction", 0.0)}}}
        warns = assumption_warnings(scene, closed, mc_info, val)
        canned = {"models": {m: {"averaging_error": {"A": {"L1": M[m]["L1"],
                                                            "L1_floor": r["L1_floor"]}},
                                 "sampling_ok": True} for m in ("exact", "corrected")}}
        rec, line = recommend(canned, warns, val)
        body = line.split(" -- ", 1)[1]
        if rec == "none" and "fail here (" in body:
            why = body.split("fail here (", 1)[1].split(")")[0]
        else:
            why = body.split(" (")[0]
            if "energy-at-the-wall" in body:
                why += "; corrected's wall term out of range"
            if "correlated-noise regime" in body:
                why += "; correlated-noise regime"
        cells = " | ".join(f"{M[m]['L1']:.3f} ({M[m]['mean_diff']:+.3f})"
                           for m in ("exact", "compounded", "corrected"))
        print(f"| {name} | {cells} | {r['L1_floor']:.4f} | {r['dt']:g} | **{rec}**: {why} |")


if __name__ == "__main__":
    main()
