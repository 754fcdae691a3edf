"""Which side is biased where vifpk's p(A) and the RK4 reference's differ (issue 44: on
paper-base bench_rk4_floor.py measured L1 0.0158 between them against 0.0070 of the two
floors). Independent evidence, all on the same histogram edges and the same sampled time:

- vifpk at its auto step and at 1/4 of it (the bias ladder: its own step's bias);
- the RK4 reference (bench_rk4_floor.rk4_block) at dt = 0.01 and 0.005 (an O(dt) bias of the
  reference, e.g. from the wall or the friction switch, halves);
- the RK4 reference with twice the burn-in, and its first half of sampled time against its
  second half (a start that has not relaxed);
- two seeds of each side (the spread of L1 between independent runs of the same model: with
  a slow amplitude a block's paths move the whole histogram together, so L1 of noise alone
  is far from its mean sum sqrt(2/pi) se_i w_i in a single pair).

Beside each L1: the pair's floor sum sqrt(2/pi) sqrt(se_i^2 + se'_i^2) w_i (its expected
value under noise alone) and the mean amplitude E[A] (from the histogram, per block) with its
standard error: a bias of the energy balance moves E[A], a scalar whose noise is Gaussian
(z-scores below are the difference over the combined standard error).

Runs are grouped by configuration (side:dt, the seeds apart): E[A] per seed with the spread
between seeds beside the block standard error, and for each pair of configurations the L1 /
floor of every independent pair (min, mean, max) and of the seed-pooled densities (``groups``);
the configuration with the most seeds gives the null: the percentiles of L1 / floor over its
own pairs, what one pair shows under noise alone (``null``).

    NUMBA_NUM_THREADS=1 python benchmarks/bench_rk4_discrepancy.py [--scene S] [--time 4000]
        [--runs side:dt:seed ...] [--cache RUNS.json] [--bins-of VIFPK.json]
        [--add KEY=WORKER.json ...] [--label KEY]   # -> benchmarks/results/rk4_discrepancy.json

Two-wall (issue 44, wall45): the ladder and the null of the docs (docs/performance.md, "The
two-wall gap"), then the recorded pair itself on its own bins:

    R="vifpk:auto:1 ... vifpk:auto:20 rk4:0.01:1 rk4:0.01:2 rk4:0.01:3 vifpk:fine:1
       vifpk:fine:2 rk4:0.005:1 rk4:0.005:2 rk4:0.0025:1"
    NUMBA_NUM_THREADS=1 python benchmarks/bench_rk4_discrepancy.py --scene two-wall --runs $R
    python benchmarks/bench_rk4_floor.py --worker vifpk two-wall 1 > V.json
    python benchmarks/bench_rk4_floor.py --worker rk4 two-wall V.json 1 > K.json
    NUMBA_NUM_THREADS=1 python benchmarks/bench_rk4_discrepancy.py --scene two-wall \
        --label two-wall-recorded-pair --bins-of V.json --time 4750 \
        --add floorvifpk:auto:1=V.json floorrk4:0.01:1=K.json --runs vifpk:auto:2 ... rk4:0.01:4
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_rk4_floor import _coefficients, _load, _rk4_kernels  # noqa: E402
from bench_rk4_floor import block_summary as _summary  # noqa: E402
from bench_rk4_floor import compare_pair as compare  # noqa: E402

OUT = ROOT / "benchmarks" / "results" / "rk4_discrepancy.json"
FLOOR = 0.005  # the target floor whose auto step is vifpk's "auto"


def _all_edges(scene, ea: np.ndarray) -> dict:
    """The kernel's three histograms' edges from p(A)'s (as bench_dt_bias.py)."""
    from vifpk.montecarlo.plan import physics
    from vifpk.montecarlo.tuning import _spring
    phys = physics(scene.system, scene.noise)
    a_hi = float(ea[-1])
    vmax = math.sqrt(2 * sum(c * a_hi ** (2 * i + 2) / (2 * i + 2)
                              for i, c in enumerate(_spring(phys))))
    return {"edges_A": ea, "edges_x": np.linspace(0.0 if phys["lower"] is not None else -a_hi,
                                                   a_hi, ea.size),
            "edges_v": np.linspace(-vmax, vmax, ea.size)}


def run_vifpk(name: str, dt: float | str, seed: int, T: float, edges, burn_in) -> dict:
    import numba

    from vifpk import montecarlo
    numba.set_num_threads(1)
    scene = _load(name)
    st = montecarlo.Settings(**{**dataclasses.asdict(scene.montecarlo), "dt": dt,
                                "floor": 0.0, "time": T, "threads": 1, "seed": seed,
                                "burn_in": burn_in, "dt_check": False,
                                "edges": {} if edges is None else _all_edges(scene, edges)},
                             observables=("A",), progress=False)
    c0 = time.process_time()
    r = montecarlo.simulate(scene.system, scene.noise, st)
    a = r.data["A"]
    e = np.asarray(a["edges"], float)
    out = _summary(np.asarray(a["p_blocks"], float), e)
    out.update(edges=e, cpu=time.process_time() - c0, dt=r.info["settings"]["dt"],
               amplitude=(r.info.get("dt_rule") or {}).get("amplitude"),
               burn_in=r.info["settings"]["burn_in"])
    return out


def run_rk4(name: str, dt: float, seed: int, T: float, edges: np.ndarray, burn_in: float
            ) -> dict:
    """The reference of bench_rk4_floor.py at step dt (its OU record made for dt), 32 x 32
    paths from rest at x = 0.3, burn_in, then T sampled in two halves (kept apart)."""
    import bench_rk4_floor as b
    b.DT_RK4 = dt  # _coefficients reads it (the OU's exact update over dt)
    block = _rk4_kernels()
    scene = _load(name)
    c, ou, walls = _coefficients(scene)
    nb, per = 32, 32
    stride = round(0.5 / dt)
    halves = np.zeros((2, nb, edges.size - 1))
    samples = np.zeros((2, nb))
    gens = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(nb)]
    state = np.zeros((nb, per, 2))
    state[..., 0] = 0.3
    xi = np.zeros((nb, per))
    w = np.diff(edges)
    c0 = time.process_time()
    burn = round(burn_in / dt)
    chunk = round(250.0 / dt)
    n_chunks = max(round(T / 250.0), 2)
    for k in range(n_chunks):
        half = 0 if k < n_chunks // 2 else 1
        n = chunk + (burn if k == 0 else 0)
        for j in range(nb):
            normals = gens[j].standard_normal((per, n))
            samples[half, j] += block(state[j], xi[j], normals, n, burn if k == 0 else 0,
                                      stride, dt, c, ou, walls, edges[0], 1.0 / w[0],
                                      halves[half, j])
    cpu = time.process_time() - c0
    both = halves.sum(axis=0) / (samples.sum(axis=0)[:, None] * w)
    out = _summary(both, edges)
    out.update(cpu=cpu, dt=dt, burn_in=burn_in, edges=edges,
               first_half=_summary(halves[0] / (samples[0][:, None] * w), edges),
               second_half=_summary(halves[1] / (samples[1][:, None] * w), edges))
    return out


def vifpk_halves(name: str, dt: float, seeds: int, T: float, edges: np.ndarray,
                 burn_in: float) -> dict:
    """vifpk's first half of sampled time against its second, the control of the RK4 runs'
    ``halves``: seed s run for T / 2 and for T (the same paths: the T / 2 run is the T run's
    first half), the second half's blocks 2 p_T - p_{T/2} (equal sample counts)."""
    w = np.diff(edges)
    rows = []
    for sd in range(1, seeds + 1):
        a = run_vifpk(name, dt, sd, T / 2, edges, burn_in)
        b = run_vifpk(name, dt, sd, T, edges, burn_in)
        c = compare(a, _summary(2 * b["blocks"] - a["blocks"], edges), w)
        rows.append({"seed": sd, "dmean_A": c["dmean_A"], "dmean_A_se": c["dmean_A_se"]})
        print(f"vifpk seed {sd} halves dE[A] {c['dmean_A']:+.5f} +- {c['dmean_A_se']:.5f}",
              flush=True)
    d = np.array([r["dmean_A"] for r in rows])
    se = np.array([r["dmean_A_se"] for r in rows])
    return {"dt": dt, "time": T, "burn_in": burn_in, "runs": rows, "mean": float(d.mean()),
            "z_combined": float(d.sum() / math.sqrt(np.sum(se ** 2))),
            "positive": int(np.sum(d > 0))}


def _short(x: np.ndarray) -> list:
    """A density for the results file: 5 significant digits (its noise is in the 3rd)."""
    return [float(f"{v:.5g}") for v in np.asarray(x, float)]


def _cached(path: Path | None) -> dict:
    """The finished runs of ``--cache`` (blocks kept, so pooled seeds can be re-summarised)."""
    if path is None or not path.exists():
        return {}
    out = {}
    for k, r in json.loads(path.read_text()).items():
        e = np.asarray(r["edges"], float)
        s = _summary(np.asarray(r["blocks"], float), e)
        for h in ("first_half", "second_half"):
            if h in r:
                s[h] = _summary(np.asarray(r[h], float), e)
        s.update(edges=e, cpu=r["cpu"], dt=r["dt"], burn_in=r["burn_in"])
        out[k] = s
    return out


def _cache(path: Path | None, runs: dict) -> None:
    if path is None:
        return
    raw = {k: {"edges": r["edges"].tolist(), "blocks": r["blocks"].tolist(), "cpu": r["cpu"],
               "dt": r["dt"], "burn_in": r["burn_in"],
               **{h: r[h]["blocks"].tolist() for h in ("first_half", "second_half") if h in r}}
           for k, r in runs.items()}
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(raw))
    tmp.replace(path)


def groups(runs: dict, w: np.ndarray) -> dict:
    """The runs by configuration (side:dt, seeds apart): E[A] of each seed, their mean and
    standard deviation between seeds (the observed spread, beside the per-run block standard
    error); and, for every configuration pair, the L1 / floor of each independent pair of runs
    (min, mean, max: a single pair's L1 spreads widely about its floor when a few slow modes
    carry the noise) and of the seed-pooled densities."""
    by: dict[str, list[str]] = {}
    for k in runs:
        by.setdefault(k.rsplit(":", 1)[0], []).append(k)
    out: dict = {"configs": {}, "pairs": {}}
    pooled = {}
    for g, ks in by.items():
        m = np.array([runs[k]["mean_A"] for k in ks])
        se = np.array([runs[k]["mean_A_se"] for k in ks])
        pooled[g] = {"p": np.mean([runs[k]["p"] for k in ks], axis=0),
                     "se": np.sqrt(np.sum([runs[k]["se"] ** 2 for k in ks], axis=0)) / len(ks),
                     "mean_A": float(m.mean()),
                     "mean_A_se": float(math.sqrt(np.sum(se ** 2)) / len(ks))}
        out["configs"][g] = {"runs": ks, "dt": runs[ks[0]]["dt"], "mean_A": m.tolist(),
                             "mean_A_pooled": float(m.mean()),
                             "mean_A_se_pooled": pooled[g]["mean_A_se"],
                             "mean_A_sd_between_seeds": float(m.std(ddof=1)) if m.size > 1
                             else None,
                             "mean_A_se_per_run": float(np.mean(se))}
    for ga, gb in itertools.combinations_with_replacement(by, 2):
        prs = [compare(runs[x], runs[y], w)
               for x, y in itertools.product(by[ga], by[gb]) if x < y or ga != gb]
        prs = [p for p in prs if p is not None]
        if not prs:
            continue
        rat = np.array([p["L1_over_floor"] for p in prs])
        z = np.abs([p["z"] for p in prs])
        item = {"n": len(prs), "L1_mean": float(np.mean([p["L1"] for p in prs])),
                "L1_over_floor_min": float(rat.min()), "L1_over_floor_mean": float(rat.mean()),
                "L1_over_floor_max": float(rat.max()), "abs_z_mean_A_max": float(z.max())}
        if ga != gb:
            item["pooled"] = compare(pooled[ga], pooled[gb], w)
        out["pairs"][f"{ga} vs {gb}"] = item
    most = max(by, key=lambda g: len(by[g]))
    if len(by[most]) >= 4:
        rat = np.array([compare(runs[x], runs[y], w)["L1_over_floor"]
                        for x, y in itertools.combinations(by[most], 2)])
        out["null"] = {"config": most, "seeds": len(by[most]), "pairs": int(rat.size),
                       "mean": float(rat.mean()), "sd": float(rat.std(ddof=1)),
                       **{f"q{round(100 * q)}": float(np.quantile(rat, q))
                          for q in (0.5, 0.9, 0.95, 0.99)},
                       "max": float(rat.max()),
                       "share_at_least": {str(x): float(np.mean(rat >= x))
                                          for x in (1.5, 1.69, 2.0)}}
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="paper-base")
    ap.add_argument("--time", type=float, default=4000.0)
    ap.add_argument("--runs", nargs="+", default=[
        "vifpk:auto:1", "vifpk:auto:2", "vifpk:fine:1", "rk4:0.01:1", "rk4:0.01:2",
        "rk4:0.005:1", "rk4long:0.01:3"],
        help="side:dt:seed; dt 'fine' = vifpk's auto step / 4; rk4long: twice the burn-in")
    ap.add_argument("--bins-of", type=Path, metavar="VIFPK_JSON",
                    help="edges and burn-in of a bench_rk4_floor.py vifpk worker's run "
                         "(--worker vifpk SCENE SEED > JSON) instead of a pilot's")
    ap.add_argument("--add", nargs="*", default=[], metavar="KEY=JSON",
                    help="a bench_rk4_floor.py worker's run (vifpk or rk4, with p_blocks) as "
                         "one more run named KEY (side:dt:seed), on its own sampled time")
    ap.add_argument("--note", help="recorded beside the machine's load (e.g. when the cached "
                                   "runs were made)")
    ap.add_argument("--vifpk-halves", type=int, metavar="SEEDS",
                    help="only the control of the RK4 runs' halves: vifpk at its auto step, "
                         "seeds 1..SEEDS, first half of --time against the second (recorded "
                         "as the label's 'vifpk_halves')")
    ap.add_argument("--label", help="the key in the results file (default: the scene)")
    ap.add_argument("--cache", type=Path,
                    help="a JSON file of finished runs (their blocks): read first, written "
                         "after each run, so a long ladder survives a crash or is extended")
    a = ap.parse_args()
    load0 = os.getloadavg()
    # the auto step at floor 0.005 (what bench_rk4_floor.py's vifpk runs use), from a short
    # pilot run's amplitude; its edges and burn-in are every run's
    from vifpk.montecarlo.plan import physics
    from vifpk.montecarlo.tuning import auto_dt
    pilot = run_vifpk(a.scene, "auto", 1, 20.0, None, "auto")
    edges, burn = pilot["edges"], pilot["burn_in"]
    sc = _load(a.scene)
    h_auto = auto_dt(FLOOR, physics(sc.system, sc.noise), pilot["amplitude"])
    if a.bins_of:
        given = json.loads(a.bins_of.read_text().strip().splitlines()[-1])
        edges, burn, h_auto = np.asarray(given["edges"], float), given["burn_in"], given["dt"]
    if a.vifpk_halves:
        res = vifpk_halves(a.scene, h_auto, a.vifpk_halves, a.time, edges, burn)
        print(f"mean {res['mean']:+.5f}, combined z {res['z_combined']:.2f}, positive "
              f"{res['positive']}/{len(res['runs'])}")
        old = json.loads(OUT.read_text()) if OUT.exists() else {}
        old.setdefault(a.label or a.scene, {})["vifpk_halves"] = {
            **res, "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
        OUT.write_text(json.dumps(old, indent=1) + "\n")
        return
    runs: dict = {k: r for k, r in _cached(a.cache).items() if k in a.runs}
    for item in a.add:
        key, path = item.split("=", 1)
        wr = json.loads(Path(path).read_text().strip().splitlines()[-1])
        r = _summary(np.asarray(wr["p_blocks"], float), np.asarray(wr["edges"], float))
        r.update(edges=np.asarray(wr["edges"], float), cpu=wr["cpu"],
                 dt=wr.get("dt") or float(key.split(":")[1]), burn_in=wr["burn_in"])
        runs[key] = r
    for r in runs.values():
        assert np.array_equal(r["edges"], edges), "a cached or added run is on other edges"
    for key in a.runs:
        if key in runs:
            continue
        side, dt, seed = key.split(":")
        if side == "vifpk":
            h = h_auto / 4 if dt == "fine" else (h_auto if dt == "auto" else float(dt))
            runs[key] = run_vifpk(a.scene, h, int(seed), a.time, edges, burn)
        else:
            runs[key] = run_rk4(a.scene, float(dt), int(seed), a.time, edges,
                                burn * (2 if side == "rk4long" else 1))
        r = runs[key]
        print(key, f"dt {r['dt']:.5g} cpu {r['cpu']:.1f} E[A] {r['mean_A']:.5f} "
              f"+- {r['mean_A_se']:.5f}", flush=True)
        _cache(a.cache, {**_cached(a.cache), **runs})
    w = np.diff(edges)
    pairs = {f"{x} vs {y}": compare(runs[x], runs[y], w)
             for x, y in itertools.combinations(runs, 2)}
    halves = {k: compare(r["first_half"], r["second_half"], w)
              for k, r in runs.items() if "first_half" in r}
    shown = pairs if len(runs) <= 16 else {}  # many runs: the groups below summarise them
    for k, v in {**shown, **{f"{k} halves": v for k, v in halves.items()}}.items():
        print(f"{k:34s} L1 {v['L1']:.4f} floor {v['floor']:.4f} ({v['L1_over_floor']:.2f}x) "
              f"dE[A] {v['dmean_A']:+.5f} +- {v['dmean_A_se']:.5f} (z {v['z']:+.1f})")
    grp = groups(runs, w)
    for g, v in grp["configs"].items():
        sd = v["mean_A_sd_between_seeds"]
        print(f"{g:14s} dt {v['dt']:.5g} E[A] {v['mean_A_pooled']:.5f} +- "
              f"{v['mean_A_se_pooled']:.5f} (seeds {len(v['runs'])}, sd between seeds "
              f"{'-' if sd is None else f'{sd:.5f}'}, se a run {v['mean_A_se_per_run']:.5f})")
    for g, v in grp["pairs"].items():
        po = v.get("pooled")
        print(f"{g:30s} pairs {v['n']:2d} L1/floor {v['L1_over_floor_min']:.2f}.."
              f"{v['L1_over_floor_mean']:.2f}..{v['L1_over_floor_max']:.2f}"
              + (f"  pooled L1 {po['L1']:.4f} floor {po['floor']:.4f} dE[A] "
                 f"{po['dmean_A']:+.5f} (z {po['z']:+.1f})" if po else ""))
    if "null" in grp:
        nl = grp["null"]
        print(f"null ({nl['config']}, {nl['seeds']} seeds, {nl['pairs']} pairs): L1/floor mean "
              f"{nl['mean']:.2f} sd {nl['sd']:.2f} q50 {nl['q50']:.2f} q90 {nl['q90']:.2f} "
              f"q95 {nl['q95']:.2f} q99 {nl['q99']:.2f} max {nl['max']:.2f}; share >= "
              + ", ".join(f"{k}: {v:.3f}" for k, v in nl["share_at_least"].items()))
    null_cfg = grp.get("null", {}).get("config")
    res = {"scene": a.scene, "time": a.time, "burn_in": burn, "dt_auto": h_auto,
           "edges": edges.tolist(),
           "runs": {k: {"dt": r["dt"], "cpu": r["cpu"], "burn_in": r["burn_in"],
                        "mean_A": r["mean_A"], "mean_A_se": r["mean_A_se"],
                        "p": _short(r["p"]), "se": _short(r["se"])}
                    for k, r in runs.items()},
           # the pairs inside the null's configuration are summarised by groups["null"]
           "pairs": {k: v for k, v in pairs.items()
                     if not (null_cfg and all(x.rsplit(":", 1)[0] == null_cfg
                                              for x in k.split(" vs ")))},
           "halves": halves, "groups": grp,
           "machine": {"load_average_start": load0, "load_average_end": os.getloadavg(),
                       "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                       **({"note": a.note} if a.note else {})}}
    old = json.loads(OUT.read_text()) if OUT.exists() else {}
    old[a.label or a.scene] = res
    OUT.write_text(json.dumps(old, indent=1) + "\n")


if __name__ == "__main__":
    main()
