"""Time to a noise floor of 0.005 in L1 of p(A): vifpk's Monte Carlo against an independent
RK4 simulation of the original system at dt = 0.01 (issue 44, item 5), CPU seconds.

    NUMBA_NUM_THREADS=1 python benchmarks/bench_rk4_floor.py [--before PYTHON] [--rounds 3]
        [--seeds]  # -> benchmarks/results/rk4_floor.json

``--seeds``: round i runs vifpk with seed 1 + i (before and after alike). The sampled time a
floor takes is itself random (paper-base, seeds 1-4: 7375-8875 time units), and a change that
moves the paths (a different burn-in) draws another realisation at the same seed; so the
summary also gives each run at the mean sampled time of all the vifpk runs of its scene
(``cpu_at_mean_time``: its sampling CPU scaled by T_mean / T, its other stages as measured).

THE REFERENCE (``rk4_block``, written here, sharing no code with vifpk's kernels): the classical
fourth-order Runge-Kutta method on (x, v) of

    x'' + d(x) x' + g(x) + mu sgn(x') = f xi(t),   a <= x <= b,   x'(+) = -r x'(-) at a wall,

with the OU noise xi advanced exactly at the step's ends (xi <- e^{-alpha1 dt} xi + sd N) and
taken linear in between (RK4 of the random ODE between the grid times), and EVENT LOCATION at
the walls: a step that ends beyond a wall is cut at the crossing, found by bisection on the
step's cubic Hermite interpolant of x (from x, v at both ends), the velocity there reflected,
v -> -r v, and the rest of the step integrated again from the wall (up to 8 impacts a step). A
rebound slower than 1e-9 (an impact cascade, Zeno) leaves the mass resting on the wall while the
net force presses it there. Paths: 32 blocks x 32, started at rest on x = 0.3, each block from
its own numpy Generator (SeedSequence(seed).spawn), burned in for the time vifpk's own run used,
then sampled every 0.5 time units into vifpk's run's bins of p(A), in chunks of 250 time units
until the L1 noise floor sum sqrt(2/pi) se_i w_i (block means, as montecarlo/summary.py) is
<= 0.005. The amplitude: U(A) = v^2/2 + U(x), U = w0^2 x^2/2 + alpha x^4/4 (closed form).

vifpk: ``montecarlo.simulate`` with the scene's settings, floor 0.005 and dt "auto" (what
``vifpk solve SCENE --solver montecarlo --floor 0.005 --dt auto`` runs), one thread, warm
numba cache; its seconds include its pilots, burn-in, certificate and step check (imports and
the report are not: fixed costs, issue 44 item 3). Each side's run is a fresh process; rounds
alternate (before, after, RK4), and the medians' ratios are reported.

Accuracy (``_accuracy``; ``--accuracy-only`` re-measures it alone, the timings kept): L1
between the RK4 p(A) and the seed-1 vifpk run's on the same bins, beside the two floors in
quadrature, the pair's own floor (E[L1] under noise alone) and the difference of E[A] with
its z-score. One pair's L1 / floor spreads widely under noise alone, since the slow amplitude
moves many bins together: over 190 pairs of independent vifpk runs of two-wall its mean is
1.00 and its 95th percentile 1.76 (NULL_L1_OVER_FLOOR). So a single pair above its floor is
not a bias; seeds pooled are the test (bench_rk4_discrepancy.py; docs/performance.md, "The
two-wall gap").

Scenes: paper-base, and paper-base between two walls (benchmarks/two-wall.toml: the upper wall
at x = 0.45, r = 0.96, inside the range of A: E[A] 0.314, and 18% of the impacts are on it).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SCENES = {"paper-base": "paper-base", "two-wall": str(ROOT / "benchmarks" / "two-wall.toml")}
FLOOR = 0.005
DT_RK4 = 0.01


def _rk4_kernels():
    import numba

    @numba.njit(error_model="numpy")
    def acc(x, v, xi, c):
        c1, c2, w0sq, alpha, mu, f = c[0], c[1], c[2], c[3], c[4], c[5]
        fr = 0.0
        if v > 0.0:
            fr = mu
        elif v < 0.0:
            fr = -mu
        return -(c2 * x * x - c1) * v - (w0sq + alpha * x * x) * x - fr + f * xi

    @numba.njit(error_model="numpy")
    def rk4(x, v, xi0, xi1, tau, c):
        xim = 0.5 * (xi0 + xi1)
        k1x, k1v = v, acc(x, v, xi0, c)
        k2x, k2v = v + 0.5 * tau * k1v, acc(x + 0.5 * tau * k1x, v + 0.5 * tau * k1v, xim, c)
        k3x, k3v = v + 0.5 * tau * k2v, acc(x + 0.5 * tau * k2x, v + 0.5 * tau * k2v, xim, c)
        k4x, k4v = v + tau * k3v, acc(x + tau * k3x, v + tau * k3v, xi1, c)
        return (x + tau / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
                v + tau / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v))

    @numba.njit(error_model="numpy")
    def hermite(x0, v0, x1, v1, tau, s):
        """x and x' at the fraction s of the step from the cubic Hermite interpolant."""
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        d00, d10 = (6 * s**2 - 6 * s) / tau, 3 * s**2 - 4 * s + 1
        d01, d11 = (-6 * s**2 + 6 * s) / tau, 3 * s**2 - 2 * s
        return (h00 * x0 + h10 * tau * v0 + h01 * x1 + h11 * tau * v1,
                d00 * x0 + d10 * v0 + d01 * x1 + d11 * v1)

    @numba.njit(error_model="numpy")
    def step(x, v, xi0, xi1, h, c, lo, hi, r):
        """One RK4 step of h with event location at the walls lo < hi (+-inf: none)."""
        t = 0.0
        for _ in range(8):
            tau = h - t
            if tau <= 0.0:
                break
            xa = xi0 + (xi1 - xi0) * t / h
            resting = (x == lo and v == 0.0) or (x == hi and v == 0.0)
            if resting:  # on a wall: held while the net force presses it there
                F = acc(x, 0.0, xa, c)
                if (x == lo and F <= 0.0) or (x == hi and F >= 0.0):
                    return x, 0.0
            xn, vn = rk4(x, v, xa, xi1, tau, c)
            if lo <= xn <= hi:
                return xn, vn
            wall = lo if xn < lo else hi
            a_, b_ = 0.0, 1.0
            for _ in range(50):  # the crossing on the Hermite interpolant
                m = 0.5 * (a_ + b_)
                xm, _vm = hermite(x, v, xn, vn, tau, m)
                if (xm - wall) * (x - wall) > 0.0:
                    a_ = m
                else:
                    b_ = m
            _xm, vh = hermite(x, v, xn, vn, tau, b_)
            t += b_ * tau
            x, v = wall, -r * vh
            if abs(v) < 1e-9:
                v = 0.0
        return x, v

    @numba.njit(error_model="numpy", nogil=True)
    def block(state, xi_state, normals, n_steps, burn, stride, h, c, ou, walls, a_lo, a_inv,
              hist):
        """Advance the block's paths n_steps (normals[p, n]: the OU innovations), sampling
        A every stride steps after ``burn``; returns the samples taken."""
        ou_a, ou_s = ou
        lo, hi, r = walls
        w0sq, alpha = c[2], c[3]
        samples = 0
        for p in range(state.shape[0]):
            x, v, xi = state[p, 0], state[p, 1], xi_state[p]
            for n in range(n_steps):
                xi1 = ou_a * xi + ou_s * normals[p, n]
                x, v = step(x, v, xi, xi1, h, c, lo, hi, r)
                xi = xi1
                if n >= burn and (n - burn + 1) % stride == 0:
                    E = 0.5 * v * v + 0.5 * w0sq * x * x + 0.25 * alpha * x ** 4
                    # U(A) = E: A^2 = (-w0^2 + sqrt(w0^4 + 4 alpha E)) / alpha
                    A = math.sqrt((-w0sq + math.sqrt(w0sq * w0sq + 4.0 * alpha * E)) / alpha)
                    i = int(math.floor((A - a_lo) * a_inv))
                    if 0 <= i < hist.shape[0]:
                        hist[i] += 1.0
                    samples += 1
            state[p, 0], state[p, 1], xi_state[p] = x, v, xi
        return samples
    return block


def block_summary(blocks: np.ndarray, edges: np.ndarray) -> dict:
    """p, se per bin and E[A] +- se from per-block densities (bin centres): blocks are
    independent paths, so their spread is the estimate's whole noise, correlated samples
    within a block included."""
    w = np.diff(edges)
    c = 0.5 * (edges[1:] + edges[:-1])
    nb = blocks.shape[0]
    mean_a = blocks @ (c * w)
    return {"p": blocks.mean(axis=0), "se": blocks.std(axis=0, ddof=1) / math.sqrt(nb),
            "mean_A": float(mean_a.mean()),
            "mean_A_se": float(mean_a.std(ddof=1) / math.sqrt(nb)), "blocks": blocks}


def compare_pair(a: dict, b: dict, w: np.ndarray) -> dict:
    """Two independent estimates (block_summary) on the same bins: L1 between them; the pair's
    floor sum sqrt(2/pi) sqrt(se_a^2 + se_b^2) w, which is E[L1] under noise alone (each bin's
    difference N(0, se_a^2 + se_b^2); >= the two runs' floors in quadrature); a bias estimate
    sqrt(L1^2 - floor^2); and E[A]'s difference with its standard error and z-score (a scalar
    whose noise is Gaussian: the sharper test where one slow mode, the amplitude, moves many
    bins together and makes one pair's L1 / floor spread widely about 1)."""
    l1 = float(np.sum(np.abs(a["p"] - b["p"]) * w))
    floor = float(np.sum(math.sqrt(2 / math.pi) * np.hypot(a["se"], b["se"]) * w))
    d = a["mean_A"] - b["mean_A"]
    se = math.hypot(a["mean_A_se"], b["mean_A_se"])
    return {"L1": l1, "floor": floor, "L1_over_floor": l1 / floor,
            "bias_est": math.sqrt(max(l1 * l1 - floor * floor, 0.0)),
            "dmean_A": d, "dmean_A_se": se, "z": d / se}


def _coefficients(scene):
    """The scene's numbers (read through vifpk's physics layer: numbers only, no numerics)."""
    from vifpk.montecarlo.plan import physics
    ph = physics(scene.system, scene.noise)
    nz = scene.noise
    c = np.array([ph["c1"], ph["c2"], ph["w0sq"], ph["alpha"], ph["mu"] or 0.0, ph["f"]])
    a = math.exp(-nz.alpha1 * DT_RK4)
    ou = (a, math.sqrt(nz.D / nz.alpha1 * (1 - a * a)))
    lo, up = ph["lower"], ph["upper"]
    rs = {w.r for w in (lo, up) if w is not None}
    assert len(rs) == 1 and ph["khi"] is None and ph["dhi"] is None and ph["ev"] is None
    return c, ou, (lo.at if lo else -math.inf, up.at if up else math.inf, rs.pop())


def _load(name):
    from vifpk.core.scene import load_scene
    return load_scene(SCENES[name])


def worker_vifpk(name: str, seed: int | None = None) -> dict:
    import numba

    from vifpk import montecarlo
    numba.set_num_threads(1)
    scene = _load(name)
    seed = scene.montecarlo.seed if seed is None else seed
    st = montecarlo.Settings(**{**dataclasses.asdict(scene.montecarlo), "dt": "auto",
                                "floor": FLOOR, "threads": 1, "seed": seed},
                             observables=("A",), progress=False)
    quick = dataclasses.replace(st, floor=0.0, time=20.0, burn_in=10.0, dt_check=False)
    montecarlo.simulate(scene.system, scene.noise, quick)  # numba's cache loaded
    c0 = time.process_time()
    r = montecarlo.simulate(scene.system, scene.noise, st)
    cpu = time.process_time() - c0
    a = r.data["A"]
    stages = {k: v["cpu"] for k, v in r.info.get("timing", {}).get("stages", {}).items()}
    path_steps = (scene.montecarlo.paths * (r.info["settings"]["time"]
                                            + r.info["settings"]["burn_in"])
                  / r.info["settings"]["dt"])
    return {"cpu": cpu, "floor": r.info["L1_floor"]["A"], "dt": r.info["settings"]["dt"],
            "stages_cpu": stages, "path_steps": path_steps,
            "ns_per_path_step_sampling": 1e9 * stages.get("sampling", math.nan)
            / (scene.montecarlo.paths * r.info["settings"]["time"] / r.info["settings"]["dt"]),
            "time": r.info["settings"]["time"], "burn_in": r.info["settings"]["burn_in"],
            "seed": seed,
            "edges": a["edges"].tolist(), "p": a["p"].tolist(), "err": a["err"].tolist(),
            "p_blocks": np.asarray(a["p_blocks"], float).tolist()}


def worker_rk4(name: str, edges: list, burn_in: float, seed: int = 1) -> dict:
    block = _rk4_kernels()
    scene = _load(name)
    c, ou, walls = _coefficients(scene)
    e = np.asarray(edges)
    blocks, per, chunk = 32, 32, 250.0
    stride = round(0.5 / DT_RK4)
    hist = np.zeros((blocks, e.size - 1))
    samples = np.zeros(blocks)
    gens = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(blocks)]
    state = np.zeros((blocks, per, 2))
    state[..., 0] = 0.3
    xi = np.zeros((blocks, per))
    w = np.diff(e)
    a_inv = 1.0 / w[0]
    small = np.zeros((1, 2)), np.zeros(1), np.zeros((1, 10))
    block(*small, 10, 0, stride, DT_RK4, c, ou, walls, e[0], a_inv, np.zeros(e.size - 1))
    c0 = time.process_time()
    burn = round(burn_in / DT_RK4)
    sampled = 0.0
    floor = math.inf
    while floor > FLOOR:
        n = round(chunk / DT_RK4) + burn
        for b in range(blocks):
            normals = gens[b].standard_normal((per, n))
            samples[b] += block(state[b], xi[b], normals, n, burn, stride, DT_RK4, c, ou,
                                walls, e[0], a_inv, hist[b])
        burn = 0
        sampled += chunk
        pb = hist / (samples[:, None] * w)
        se = pb.std(axis=0, ddof=1) / math.sqrt(blocks)
        floor = float(np.sum(math.sqrt(2 / math.pi) * se * w))
    cpu = time.process_time() - c0
    path_steps = blocks * per * (sampled + burn_in) / DT_RK4
    return {"cpu": cpu, "floor": floor, "time": sampled, "burn_in": burn_in,
            "path_steps": path_steps, "ns_per_path_step": 1e9 * cpu / path_steps,
            "p": pb.mean(axis=0).tolist(), "edges": list(edges), "seed": seed,
            "p_blocks": pb.tolist()}


#: L1 / (the pair's floor) between two independent vifpk runs of two-wall at its auto step,
#: 4000 time units each: its 50th, 90th, 95th and 99th percentiles over the 190 pairs of 20
#: seeds (bench_rk4_discrepancy.py --scene two-wall, results/rk4_discrepancy.json "null"):
#: the spread a single pair shows under noise alone (mean 1.00, sd 0.35)
NULL_L1_OVER_FLOOR = {"q50": 0.94, "q90": 1.45, "q95": 1.76, "q99": 2.17}


def _accuracy(mine: dict | None, rk: dict) -> dict:
    """L1 between the RK4 p(A) and a vifpk run on the same bins, beside the two floors in
    quadrature, the pair's own floor and E[A]'s z-score (compare_pair); None without a vifpk
    run on the RK4 run's bins."""
    if mine is None:
        return {"L1_rk4_vs_vifpk": None, "floors_in_quadrature": None}
    e = np.asarray(rk["edges"], float)
    out = {"L1_rk4_vs_vifpk": float(np.sum(np.abs(np.asarray(mine["p"]) - np.asarray(rk["p"]))
                                           * np.diff(e))),
           "floors_in_quadrature": math.hypot(mine["floor"], rk["floor"]),
           "vifpk_seed": mine.get("seed"), "rk4_seed": rk.get("seed", 1)}
    if "p_blocks" in mine and "p_blocks" in rk:
        a, b = (block_summary(np.asarray(r["p_blocks"], float), e) for r in (mine, rk))
        pair = compare_pair(b, a, np.diff(e))
        out.update({"pair_floor": pair["floor"], "L1_over_pair_floor": pair["L1_over_floor"],
                    "mean_A_rk4": b["mean_A"], "mean_A_vifpk": a["mean_A"],
                    "dmean_A_rk4_minus_vifpk": pair["dmean_A"],
                    "dmean_A_se": pair["dmean_A_se"], "z_mean_A": pair["z"],
                    "null_L1_over_floor": NULL_L1_OVER_FLOOR})
    return out


def _run(python: str, *args: str) -> dict:
    env = dict(os.environ, NUMBA_NUM_THREADS="1")
    out = subprocess.run([python, __file__, "--worker", *args], capture_output=True, text=True,
                         env=env, check=True, cwd=ROOT).stdout
    return json.loads(out.strip().splitlines()[-1])


def _accuracy_only(scenes: list[str]) -> None:
    out = ROOT / "benchmarks" / "results" / "rk4_floor.json"
    res = json.loads(out.read_text()) if out.exists() else {"scenes": {}}
    for name in scenes:
        mine = _run(sys.executable, "vifpk", name, "1")
        ref = ROOT / "benchmarks" / "results" / f".rk4_edges_{name}.json"
        ref.write_text(json.dumps(mine))
        try:
            rk = _run(sys.executable, "rk4", name, str(ref), "1")
        finally:
            ref.unlink()
        acc = {**_accuracy(mine, rk), "vifpk_time": mine["time"], "vifpk_dt": mine["dt"],
               "rk4_time": rk["time"], "burn_in": mine["burn_in"],
               "measured": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
               "command": "NUMBA_NUM_THREADS=1 python benchmarks/bench_rk4_floor.py "
                          f"--accuracy-only --scenes {name}"}
        res.setdefault("scenes", {}).setdefault(name, {})["accuracy"] = acc
        print(name, json.dumps({k: v for k, v in acc.items() if k != "null_L1_over_floor"}),
              flush=True)
    out.write_text(json.dumps(res, indent=1) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", help="python of an environment with the 'before' checkout")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--worker", nargs="+")
    ap.add_argument("--scenes", nargs="+", default=list(SCENES))
    ap.add_argument("--seeds", action="store_true",
                    help="round i runs vifpk (before and after alike) with seed 1 + i: the "
                         "sampled time a floor takes is a random number (seeds 1-4 of "
                         "paper-base: 7375-8875), so one seed's before/after pair differs "
                         "by its realisation wherever the paths differ")
    ap.add_argument("--rk4", nargs="*", default=[], metavar="SCENE=JSON",
                    help="the RK4 reference's run of a scene, made before by this script's "
                         "worker (--worker rk4 SCENE VIFPK_JSON > JSON), instead of a new one")
    ap.add_argument("--accuracy-only", action="store_true",
                    help="the accuracy line alone: a scene's vifpk run at seed 1 and the RK4 "
                         "run on its bins and burn-in (seed 1: the pair the timing rounds "
                         "compare), written into the scene's 'accuracy' of rk4_floor.json, "
                         "its recorded timings kept")
    a = ap.parse_args()
    if a.accuracy_only:
        _accuracy_only(a.scenes)
        return
    if a.worker:
        kind, name = a.worker[0], a.worker[1]
        if kind == "vifpk":
            print(json.dumps(worker_vifpk(name, *(int(x) for x in a.worker[2:3]))))
        else:
            ref = json.loads(Path(a.worker[2]).read_text())
            print(json.dumps(worker_rk4(name, ref["edges"], ref["burn_in"],
                                        *(int(x) for x in a.worker[3:4]))))
        return
    load0 = os.getloadavg()
    res: dict = {"floor": FLOOR, "dt_rk4": DT_RK4, "scenes": {}}
    for name in a.scenes:
        runs: dict[str, list] = {"after": [], "rk4": []}
        given = dict(x.split("=", 1) for x in a.rk4)
        if name in given:  # the RK4 run is deterministic work: made once
            runs["rk4"].append(json.loads(Path(given[name]).read_text().strip().splitlines()[-1]))
        if a.before:
            runs["before"] = []
        for i in range(a.rounds):
            seed = [str(1 + i)] if a.seeds else []
            if a.before:
                runs["before"].append(_run(a.before, "vifpk", name, *seed))
            runs["after"].append(_run(sys.executable, "vifpk", name, *seed))
            if i == 0 and not runs["rk4"]:  # one RK4 run a scene (its work is deterministic)
                ref = ROOT / "benchmarks" / "results" / f".rk4_edges_{name}.json"
                ref.write_text(json.dumps(runs["after"][0]))
                runs["rk4"].append(_run(sys.executable, "rk4", name, str(ref)))
                ref.unlink()
            print(name, {k: round(v[-1]["cpu"], 2) for k, v in runs.items()}, flush=True)
        med = {k: float(np.median([r["cpu"] for r in v])) for k, v in runs.items()}
        # each vifpk run at the mean sampled time of all of them: its sampling's CPU scaled
        # by T_mean / T (the fixed stages as measured), so that before and after compare at
        # equal work where their seeds' floors were reached at different times
        mine_runs = [r for k, v in runs.items() if k != "rk4" for r in v]
        t_mean = float(np.mean([r["time"] for r in mine_runs]))
        for r in mine_runs:
            samp = r["stages_cpu"].get("sampling", 0.0)
            r["cpu_at_mean_time"] = r["cpu"] - samp + samp * t_mean / r["time"]
        eq = {k: float(np.median([r["cpu_at_mean_time"] for r in v]))
              for k, v in runs.items() if k != "rk4"}
        rk = runs["rk4"][0]
        same = [r for r in runs["after"] + runs.get("before", []) if r["edges"] == rk["edges"]]
        mine = same[0] if same else None  # a vifpk run on the RK4 run's bins
        res["scenes"][name] = {
            "cpu_seconds_median": med,
            "rk4_over_after": med["rk4"] / med["after"],
            "mean_sampled_time": t_mean, "cpu_at_mean_time_median": eq,
            "rk4_over_after_at_mean_time": med["rk4"] / eq["after"],
            **({"rk4_over_before_at_mean_time": med["rk4"] / eq["before"]}
               if a.before else {}),
            **({"rk4_over_before": med["rk4"] / med["before"],
                "before_over_after": med["before"] / med["after"]} if a.before else {}),
            "runs": {k: [{kk: r[kk] for kk in ("cpu", "floor", "time", "burn_in", "dt",
                                               "path_steps", "ns_per_path_step",
                                               "ns_per_path_step_sampling", "stages_cpu", "seed",
                                               "cpu_at_mean_time")
                          if kk in r} for r in v] for k, v in runs.items()},
            "accuracy": _accuracy(mine, rk)}
    res["machine"] = {"cpus": os.cpu_count(), "load_average_start": load0,
                      "load_average_end": os.getloadavg(),
                      "note": "CPU seconds of one thread (process_time), each run a fresh "
                              "process with a warm numba cache; rounds alternate"}
    out = ROOT / "benchmarks" / "results" / "rk4_floor.json"
    if out.exists():  # a run of other scenes: kept beside this one's
        old = json.loads(out.read_text())
        res["scenes"] = {**old.get("scenes", {}), **res["scenes"]}
        res["machine_earlier_scenes"] = old.get("machine")
    out.write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({k: v for k, v in res["scenes"].items()}, indent=1, default=str)[:3000])


if __name__ == "__main__":
    main()
