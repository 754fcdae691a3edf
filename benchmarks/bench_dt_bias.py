"""The weak bias of p(A) against the time step on the base scene and on scenes unlike it
(issue 29, ``--dt auto``): what the step rule of montecarlo/tuning.py must predict.

For each scene a ladder of steps h (whole fractions of sample_every) and a reference step
h_ref, each run with ``SEEDS`` seeds of ``PATHS`` paths x ``TIME`` time units (burn-in
"auto", one thread) on the same histogram edges. The bias at h is the L1 distance of the
seed-averaged p(A) from the seed-averaged reference with the noise removed in quadrature,
sqrt(max(L1^2 - floor^2, 0)), floor = sqrt(floor_h^2 + floor_ref^2) of the averaged densities
(the expected L1 of noise alone). Beside it, the scene's time scales as the run sees them: the
conservative orbit's angular frequency at the RMS amplitude (impact oscillator: the half orbit
x > 0 plus the flight back, so pi / half-period), the impact rate and the stuck fraction.

    NUMBA_NUM_THREADS=1 python benchmarks/bench_dt_bias.py [SCENE ...]
    # -> benchmarks/results/dt_bias.json (scenes already there are kept unless re-run), and
    #    the densities of every run in results/dt_bias_SCENE.npz (not kept in git)
"""

from __future__ import annotations

import json
import math
import os
import platform
import sys
import time
import tomllib
from dataclasses import asdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from vifpk.montecarlo.plan import physics  # noqa: E402
from vifpk.montecarlo.tuning import _spring, scene_scales  # noqa: E402

from vifpk import montecarlo as mc  # noqa: E402
from vifpk.core.scene import MonteCarloSettings, scene_from_dict  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "dt_bias.json"
SEEDS = (1, 2, 3)
PATHS = 1024
TIME = 4000.0
LADDER = (0.2, 0.1, 0.05, 0.025)
H_REF = 0.00625

#: scenes: paper-base with these values set (section.key = value)
SCENES: dict[str, dict[str, dict[str, object]]] = {
    "base": {},
    "stiff": {"system": {"alpha": 2.0, "c1": 0.04}, "noise": {"D": 0.015}},
    "white": {"noise": {"kind": "white"}},
    "mu-0.05": {"system": {"mu": 0.05}},
    "r-0.5": {"system": {"r": 0.5}},
    "omega0-2": {"system": {"omega0": 2.0}, "noise": {"D": 0.04}},
    "damped": {"system": {"c1": -0.2}, "noise": {"D": 0.05}},
}


def scene(name: str):
    raw = tomllib.loads((ROOT / "scenes" / "paper-base.toml").read_text())
    for sec, kv in SCENES[name].items():
        raw.setdefault(sec, {}).update(kv)
    raw["name"] = name
    return scene_from_dict(raw)


def run(sc, h: float, seed: int, edges: dict | None) -> dict:
    st = mc.Settings(**{**asdict(MonteCarloSettings()), "progress": False, "threads": 1,
                        "observables": ("A", "moments", "events", "energy"), "paths": PATHS,
                        "time": TIME, "dt": h, "seed": seed, "edges": edges or {}})
    t0 = time.perf_counter()
    r = mc.simulate(sc.system, sc.noise, st)
    return {"p": r.data["A"]["p"], "err": r.data["A"]["err"], "edges": r.data["A"]["edges"],
            "seconds": time.perf_counter() - t0, "info": r.info}


def averaged(runs: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    p = np.mean([r["p"] for r in runs], axis=0)
    se = np.sqrt(np.sum([r["err"] ** 2 for r in runs], axis=0)) / len(runs)
    return p, se


def measure(name: str) -> dict:
    sc = scene(name)
    first = run(sc, H_REF, SEEDS[0], None)
    ea = first["edges"]
    phys = physics(sc.system, sc.noise)
    a_hi = float(ea[-1])
    vmax = math.sqrt(2 * sum(c * a_hi ** (2 * i + 2) / (2 * i + 2)
                              for i, c in enumerate(_spring(phys))))
    edges = {"edges_A": ea, "edges_x": np.linspace(0.0 if phys["lower"] is not None else -a_hi,
                                                   a_hi, ea.size),
             "edges_v": np.linspace(-vmax, vmax, ea.size)}
    runs = {H_REF: [first] + [run(sc, H_REF, s, edges) for s in SEEDS[1:]]}
    for h in LADDER:
        runs[h] = [run(sc, h, s, edges) for s in SEEDS]
    np.savez_compressed(OUT.with_name(f"dt_bias_{name}.npz"), edges=ea,
                        **{f"p_{h:g}": np.array([r["p"] for r in runs[h]]) for h in runs},
                        **{f"err_{h:g}": np.array([r["err"] for r in runs[h]]) for h in runs})
    w = np.diff(ea)
    p_ref, se_ref = averaged(runs[H_REF])
    info = first["info"]
    rms = math.sqrt(info["moments"]["A"]["second"]["value"])
    out = {"overrides": SCENES[name], "paths": PATHS, "time": TIME, "seeds": list(SEEDS),
           "h_ref": H_REF, "mean_A_ref": info["moments"]["A"]["mean"],
           "rms_A": rms,
           "impacts_per_time": info["events"]["impacts_per_time"]["value"],
           "stuck_fraction": info["events"]["stuck_fraction"]["value"],
           "scales": scene_scales(phys, rms),
           "energy_ref": [r["info"]["energy"] for r in runs[H_REF]], "rows": []}
    for h in LADDER:
        p, se = averaged(runs[h])
        l1 = float(np.sum(np.abs(p - p_ref) * w))
        floor = float(math.sqrt(2 / math.pi) * np.sum(np.sqrt(se**2 + se_ref**2) * w))
        per_seed = [float(np.sum(np.abs(r["p"] - p_ref) * w)) for r in runs[h]]
        ma = [r["info"]["moments"]["A"]["mean"]["value"] for r in runs[h]]
        mr = [r["info"]["moments"]["A"]["mean"]["value"] for r in runs[H_REF]]
        out["rows"].append({
            "dt": h, "L1": l1, "floor": floor,
            "bias": math.sqrt(max(l1 * l1 - floor * floor, 0.0)),
            "L1_per_seed": per_seed,
            "mean_A_shift": float(np.mean(ma) - np.mean(mr)),
            "mean_A_shift_se": float(math.sqrt(np.var(ma, ddof=1) / len(ma)
                                               + np.var(mr, ddof=1) / len(mr))),
            "energy_residual": [r["info"]["energy"]["residual"] for r in runs[h]],
            "energy_input": [r["info"]["energy"]["input"]["value"] for r in runs[h]],
            "energy_impacts": [r["info"]["energy"]["impacts"]["value"] for r in runs[h]],
            "seconds": float(sum(r["seconds"] for r in runs[h]))})
        print(name, out["rows"][-1], flush=True)
    return out


def main() -> None:
    names = sys.argv[1:] or list(SCENES)
    res = json.loads(OUT.read_text()) if OUT.exists() else {"scenes": {}}
    res["machine"] = {"python": platform.python_version(),
                      "numba_threads": os.environ.get("NUMBA_NUM_THREADS"),
                      "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    for n in names:
        res["scenes"][n] = measure(n)
        OUT.write_text(json.dumps(res, indent=1, default=float) + "\n")


if __name__ == "__main__":
    main()
