"""ns per path-step of the splitting kernels of the original system (advance_orig, cycles_orig)
and of the averaged SDE's kernels (the stationary run_sde_blocks; first passage, snapshots and
the splitting's advance_sde, cycles_sde: ``_sde_time``), before and after they were put in
struct-of-arrays lanes (issue 44), and against minimal kernels of the same scheme in lanes.

    NUMBA_NUM_THREADS=1 python benchmarks/bench_lanes_split_sde.py --before PYTHON [--rounds 5]
    # -> results/lanes_split_sde.json
    NUMBA_NUM_THREADS=1 python benchmarks/bench_lanes_split_sde.py --before PYTHON --only sde \
        --out benchmarks/results/lanes_sde_time.json   # the averaged SDE's kernels alone

PYTHON is the interpreter of a checkout before the change (its editable install; e.g. a
venv of main at aa1e12c). Each round runs one worker process of each side, alternating
(before, after); a worker loads its compiled kernels with a small call, then times each
kernel once in CPU seconds (process_time, one thread). Medians over the rounds; ratios of
medians in this one run.

Workloads (the same in both checkouts): paper-base at dt = 0.5 / 23 (bench_kernel_bound's
step), 256 paths from orbit starts at A = 0.45; the splitting's levels so wide (q_lo =
-1, below any energy, q_hi = U(5)) that no path is absorbed, so every path runs the same
number of steps
to t_max (the cycles: the same levels, n_burn 0) and the count of path-steps is exact. The
averaged SDE: the Rayleigh SDE m = -0.1 A + 0.01 / A, sigma^2 = 0.02 on a 4001-point table,
2 blocks x 64 paths, a sample every 50 steps, A only, and A with x1, x2 on the paper-base orbit
(``phase``). Minimal kernels (``after`` only): bench_kernel_bound._minimal_soa (paper-base's
scheme, the stationary lanes' target) and ``_minimal_sde`` below (the SDE step by hand in lanes:
the table's interpolation, two ziggurat normals on their fast path (lanes.fast_normal), a lane
whose normal took the slow path stepped again by averaged_sde.sde_step; its final state
checked equal to run_sde_blocks's).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np
from vifpk.montecarlo.averaged_sde import sde_step
from vifpk.montecarlo.lanes import fast_normal

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "results" / "lanes_split_sde.json"
H = 0.5 / 23
N_PATHS = 256
SDE_BLOCKS, SDE_PER, SDE_STRIDE = 2, 64, 50
NEVER = np.iinfo(np.int64).max // 2  # a burn-in never over: nothing sampled (transient.py's)
MINIMAL = "minimal SoA, paper-base (bench_kernel_bound)"


def _paper_base():
    from vifpk.montecarlo import splitting_kernels as SK
    from vifpk.montecarlo.ams import words
    from vifpk.montecarlo.geometry import potential
    from vifpk.montecarlo.pieces import record
    from vifpk.montecarlo.plan import bounds, fold, physics

    from vifpk.core.scene import load_scene

    sc = load_scene(ROOT / "scenes" / "paper-base.toml")
    ph = physics(sc.system, sc.noise)
    rec = record(ph, H)
    starts = np.zeros((N_PATHS, 5))
    SK.orbit_starts(0.45, starts, words(3, (7,), N_PATHS), ph["w0sq"], ph["alpha"], ph["khi"],
                    (fold(ph), *bounds(ph)), rec)

    def U(A):
        return float(potential(A, ph["w0sq"], ph["alpha"], ph["khi"]))
    return rec, (rec.bridge, rec.pk, rec.pc), starts, words(4, (8,), N_PATHS), U


def _steps_to(t_max: float) -> int:
    """The steps a path takes while t < t_max, t += H (the kernels' float clock)."""
    t, k = 0.0, 0
    while t < t_max:
        t += H
        k += 1
    return k


def _splitting():
    """{name: (call(n_steps) -> path-steps)} of advance_orig and cycles_orig."""
    try:
        from vifpk.montecarlo import splitting_lanes as K
    except ImportError:  # before issue 44's lanes
        from vifpk.montecarlo import splitting_kernels as K
    rec, B, starts, rng, U = _paper_base()
    q_lo, q_hi, M = -1.0, U(5.0), 10  # below any energy (the mass at rest: 0)
    lev0 = np.zeros(N_PATHS, dtype=np.int64)  # every start at level 0 of these wide levels

    def advance(n):
        recs = np.zeros((N_PATHS, M + 1, 5))
        recs[:, 0] = starts
        maxlev, outcome = np.zeros(N_PATHS, np.int64), np.zeros(N_PATHS, np.int64)
        K.advance_orig(recs, np.arange(N_PATHS, dtype=np.int64), lev0, rng, maxlev, outcome,
                       (q_lo, q_hi, M, n * H), H, B, rec)
        assert np.all(outcome == -1)  # every path ran to t_max
        return N_PATHS * _steps_to(n * H)

    def cycles(n):
        e, s = np.zeros((N_PATHS, 2, 5)), np.zeros((N_PATHS, 7))
        K.cycles_orig(starts, rng, (2, q_lo, U(0.03), q_hi, n * H, 0), H, B, rec, e, s)
        assert np.all(s[:, 5] == 1.0)  # every path ran to t_max
        return N_PATHS * _steps_to(n * H)
    return {"splitting advance_orig (AMS), paper-base": advance,
            "splitting cycles_orig, paper-base": cycles}


def _original():
    """{name: call(n_steps) -> path-steps} of the stationary kernel (lanes.run_paths: the A
    histogram sampled every 0.5 time units, as a floor run fills it; and nothing sampled, as
    the transient snapshots run it) and first passage (run_passage, a threshold U(5) no path
    reaches: every path runs n steps), from the splitting's starts and generator words."""
    from vifpk.montecarlo.kernels import N_EVENTS
    from vifpk.montecarlo.lanes import LANES, run_paths
    from vifpk.montecarlo.passage_kernels import run_passage
    rec, B, starts, rng, U = _paper_base()
    G = N_PATHS // LANES
    stride = max(1, round(0.5 / H))

    def stationary(n, n_burn=0):
        st = starts[:, :3].reshape(G, LANES, 3).copy()
        w = rng.reshape(G, LANES, 4).copy()
        out = (np.zeros((G, 100)), np.zeros((G, 0)), np.zeros((G, 0)), np.zeros((G, 0, 0)),
               np.zeros((G, LANES, 0)), np.zeros((G, N_EVENTS)), np.zeros((G, LANES)),
               np.zeros((G, LANES, 0)), np.zeros((G, LANES, 0)))
        run_paths(w, st, n, 0, n_burn, stride, H, rec, (0.0, 50.0, 0.0, 1.0, 0.0, 1.0), out, 1)
        return N_PATHS * n, st, w

    def passage(n):
        ints = [np.zeros((1, N_PATHS), np.int64) for _ in range(3)]
        arrs = (rng.reshape(1, N_PATHS, 4).copy(), np.zeros((1, N_PATHS, 3)),
                np.zeros((1, N_PATHS, 3)), *ints, np.zeros((1, N_PATHS)))
        run_passage(arrs, np.array([N_PATHS]), (n, 10 ** 9, 0, 1e9, U(5.0), 0.45, 0.0, 0), H,
                    B, rec)
        assert np.all(arrs[4] == n)  # every path ran n steps
        return N_PATHS * n
    return {"stationary lanes.run_paths, A sampled, paper-base": lambda n: stationary(n)[0],
            "transient lanes.run_paths, nothing sampled, paper-base":
                lambda n: stationary(n, NEVER)[0],
            "first passage run_passage, paper-base": passage}, stationary


def _sde_tables():
    from vifpk.montecarlo.averaged_sde import sde_tables

    grid, a_tab, b_tab = sde_tables(lambda A: -0.1 * A + 0.01 / A, lambda A: 0.02 + 0 * A,
                                    2.4, 4001)
    return grid[1] - grid[0], a_tab, b_tab


def _sde_time():
    """{name: call(n) -> path-steps} of the averaged SDE's time-domain and splitting kernels
    (n x SDE_STRIDE steps a path; the same calls in both checkouts): first passage where no
    path crosses (A0 = 0.32, Ac = 2: every path runs n_max steps) and to Ac = 0.8 (the steps
    each path took, from its time), snapshots at four marks, the AMS advance (the SDE
    m = -(A - 1), sigma^2 = 0.02 from A = 1, levels from A = 0.3 to 2: no path absorbed)
    and the cycles (A_lo 0.15, q1 at 0.3, A_hi 2: every path cycles to t_max)."""
    from vifpk.montecarlo import sde_time as T
    from vifpk.montecarlo.ams import words
    from vifpk.montecarlo.averaged_sde import sde_tables
    from vifpk.montecarlo.rng import block_seeds
    try:
        from vifpk.montecarlo import sde_lanes_splitting as K
    except ImportError:  # before issue 44's SDE lanes
        from vifpk.montecarlo import splitting_kernels as K
    dA, a_tab, b_tab = _sde_tables()
    nb, per = SDE_BLOCKS, SDE_PER
    paths = nb * per
    offset, count = np.array([0, per], np.int64), np.full(nb, per, np.int64)

    def passage(n, Ac, start):
        steps = n * SDE_STRIDE
        fpt, cens, bad = np.zeros(paths), np.zeros(paths, np.bool_), np.zeros(paths, np.int64)
        T.run_sde_passage(block_seeds(5, nb, per), np.full(paths, start), offset, count,
                          np.zeros(nb, np.int64), per, steps, steps * H, H, Ac, a_tab, b_tab,
                          1.0 / dA, fpt, cens, bad)
        assert not bad.any() and (Ac < 1.0 or cens.all())
        return int(np.sum(np.minimum(np.ceil(fpt / H - 1e-9), steps)))

    def snapshots(n):
        marks = np.array([n // 4, n // 2, 3 * n // 4, n], np.int64) * SDE_STRIDE
        hist, bad = np.zeros((nb, 4, 40)), np.zeros(paths, np.int64)
        T.run_sde_snapshots(block_seeds(5, nb, per), np.full(paths, 0.32), offset, count,
                            np.zeros(nb, np.int64), per, marks, H, a_tab, b_tab, 1.0 / dA,
                            0.0, 25.0, hist, bad)
        assert hist.sum() > 0.9 * 4 * paths
        return paths * n * SDE_STRIDE

    g_ou, a_ou, b_ou = sde_tables(lambda A: -(A - 1.0), lambda A: 0.02 + 0 * A, 2.4, 4001)
    # A about N(1, 0.1^2): never near the low level

    def advance(n):
        M, t_max = 10, n * SDE_STRIDE * H
        recs = np.zeros((paths, M + 1, 2))
        recs[:, 0, 0] = 1.0
        recs[:, 1:3, 0] = 1.0  # levels 1, 2 reached at the start (level_of(1.0) = 2)
        maxlev, outcome = np.zeros(paths, np.int64), np.zeros(paths, np.int64)
        K.advance_sde(recs, np.arange(paths, dtype=np.int64), np.full(paths, 2, np.int64),
                      words(4, (8,), paths), maxlev, outcome, 0.3**2, 4.0, M, t_max, H,
                      a_ou, b_ou, 1.0 / (g_ou[1] - g_ou[0]))
        assert np.all(outcome == -1)  # every path ran to t_max
        return paths * _steps_to(t_max)

    def cycles(n):
        t_max = n * SDE_STRIDE * H
        e, sm = np.zeros((paths, 2, 2)), np.zeros((paths, 7))
        K.cycles_sde(np.full(paths, 0.1), words(4, (9,), paths), 10**9, 0.15**2, 0.3**2, 4.0,
                     t_max, H, a_tab, b_tab, 1.0 / dA, e, sm)
        assert np.all(sm[:, 5] == 1.0) and sm[:, 2].sum() > 0  # cycled until t_max
        return paths * _steps_to(t_max)
    return {"averaged SDE run_sde_passage, none crosses": lambda n: passage(n, 2.0, 0.32),
            "averaged SDE run_sde_passage, to Ac 0.8": lambda n: passage(n, 0.8, 0.32),
            "averaged SDE run_sde_snapshots": snapshots,
            "averaged SDE splitting advance_sde (AMS)": advance,
            "averaged SDE splitting cycles_sde": cycles}


def _sde():
    """{name: call(n_samples) -> path-steps} of run_sde_blocks, A only and with x1, x2."""
    import inspect

    from vifpk.montecarlo import averaged_sde as S
    from vifpk.montecarlo.rng import block_seeds, states_from_seed

    lanes = "p0" in inspect.signature(S.run_sde_blocks).parameters
    dA, a_tab, b_tab = _sde_tables()

    def run(n, phase):
        hist, sums = np.zeros((SDE_BLOCKS, 40)), np.zeros((SDE_BLOCKS, 4))
        hx = np.zeros((SDE_BLOCKS, 20)) if phase else None
        hv = np.zeros((SDE_BLOCKS, 20)) if phase else None
        rest = (0, n, SDE_STRIDE, H, a_tab, b_tab, dA, 0.16, 0.0, 25.0, hist, sums, True,
                -math.inf, math.inf, 1.0, 0.6, None, 0.0, 12.5, hx, -2.0, 5.0, hv,
                np.zeros(0), 1.0, 0.0, None)
        if lanes:
            S.run_sde_blocks(block_seeds(5, SDE_BLOCKS, SDE_PER), 0, SDE_PER, *rest)
        else:
            S.run_sde_blocks(states_from_seed(5, SDE_BLOCKS), SDE_PER, *rest)
        return SDE_BLOCKS * SDE_PER * n * SDE_STRIDE
    return {"averaged SDE run_sde_blocks, A": lambda n: run(n, False),
            "averaged SDE run_sde_blocks, A x1 x2": lambda n: run(n, True)}


@numba.njit(error_model="numpy")
def _minimal_sde(Z, S, n, h, a_tab, b_tab, inv_d, hist, a_lo, a_inv, stride):
    """The averaged SDE's scheme by hand in lanes (Z: LANES values, S: 4 x LANES words)."""
    sq = math.sqrt(h)
    last = a_tab.size - 1
    m = Z.size
    Z0 = np.empty(m)
    W = np.empty((4, m), dtype=np.uint64)
    for k in range(n):
        for j in range(m):
            s0, s1, s2, s3 = S[0, j], S[1, j], S[2, j], S[3, j]
            Z0[j], W[0, j], W[1, j], W[2, j], W[3, j] = Z[j], s0, s1, s2, s3
            A = math.sqrt(Z[j])
            u = A * inv_d
            i = int(u)
            if i >= last:
                a, bb = a_tab[last], b_tab[last]
            else:
                w = u - i
                a = (1.0 - w) * a_tab[i] + w * a_tab[i + 1]
                bb = (1.0 - w) * b_tab[i] + w * b_tab[i + 1]
            z1, s0, s1, s2, s3 = fast_normal(s0, s1, s2, s3)
            z2, s0, s1, s2, s3 = fast_normal(s0, s1, s2, s3)
            y = A + bb * sq * z1
            y2 = bb * sq * z2
            z = y * y + y2 * y2 + a * h
            Z[j] = -z if z < 0.0 else z
            S[0, j], S[1, j], S[2, j], S[3, j] = s0, s1, s2, s3
        for j in range(m):
            if Z[j] == Z[j]:
                continue
            Z[j], _b, _r, S[0, j], S[1, j], S[2, j], S[3, j] = sde_step(
                Z0[j], W[0, j], W[1, j], W[2, j], W[3, j], h, sq, a_tab, b_tab, inv_d, last)
        if (k + 1) % stride == 0:
            for j in range(m):
                b = math.floor((math.sqrt(Z[j]) - a_lo) * a_inv)
                if 0 <= b < hist.size:
                    hist[b] += 1.0


def _minimal(stationary=None):
    """{name: call(n) -> path-steps} of the minimal lane kernels (this checkout's); with
    ``stationary`` (_original's), the paper-base one is first checked to end in the bits of
    the stationary kernel run from the same states and words, nothing sampled."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_kernel_bound import LANES, _minimal_soa
    from vifpk.montecarlo.rng import block_seeds
    rec, _B, starts, rng, _U = _paper_base()
    c = (rec.c1, rec.c2, rec.w0sq, rec.alpha, rec.mu, rec.lo_law_r, rec.f, rec.ou_a, rec.ou_s)
    dA, a_tab, b_tab = _sde_tables()

    def paper(n, ends=None):
        for g in range(0, N_PATHS, LANES):
            st = np.ascontiguousarray(starts[g:g + LANES, :3].T)
            S = np.ascontiguousarray(rng[g:g + LANES].T)
            _minimal_soa(st, S, n, H, c)
            if ends is not None:
                ends.append((st.T.copy(), S.T.copy()))
        return N_PATHS * n

    if stationary is not None:
        ends: list = []
        paper(500, ends)
        _n, st, w = stationary(500, NEVER)
        assert np.array_equal(np.concatenate([e[0] for e in ends]), st.reshape(-1, 3))
        assert np.array_equal(np.concatenate([e[1] for e in ends]), w.reshape(-1, 4))

    def sde(n):
        words = block_seeds(5, SDE_BLOCKS, SDE_PER)
        for b in range(SDE_BLOCKS):
            for g in range(0, SDE_PER, LANES):
                Z = np.full(LANES, 0.16)
                S = np.ascontiguousarray(words[b, g:g + LANES].T)
                _minimal_sde(Z, S, n * SDE_STRIDE, H, a_tab, b_tab, 1.0 / dA, np.zeros(40),
                             0.0, 25.0, SDE_STRIDE)
        return SDE_BLOCKS * SDE_PER * n * SDE_STRIDE
    return {MINIMAL: paper, "minimal SoA, averaged SDE": sde}


def _check_minimal_sde() -> None:
    """The minimal SDE kernel ends in run_sde_blocks's bits (final words and A histogram)."""
    from vifpk.montecarlo import averaged_sde as S
    from vifpk.montecarlo.lanes import LANES
    from vifpk.montecarlo.rng import block_seeds
    dA, a_tab, b_tab = _sde_tables()
    w = block_seeds(5, 1, LANES)
    hist, sums = np.zeros((1, 40)), np.zeros((1, 4))
    S.run_sde_blocks(w, 0, LANES, 0, 20, SDE_STRIDE, H, a_tab, b_tab, dA, 0.16, 0.0, 25.0,
                     hist, sums, True, -math.inf, math.inf, 1.0, 0.6, None, 0.0, 1.0, None,
                     0.0, 1.0, None, np.zeros(0), 1.0, 0.0, None)
    Z, W = np.full(LANES, 0.16), np.ascontiguousarray(block_seeds(5, 1, LANES)[0].T)
    h2 = np.zeros(40)
    _minimal_sde(Z, W, 20 * SDE_STRIDE, H, a_tab, b_tab, 1.0 / dA, h2, 0.0, 25.0, SDE_STRIDE)
    assert np.array_equal(W.T, w[0]) and np.array_equal(h2, hist[0])


def worker(side: str, n: int, passes: int, only: str) -> dict[str, list[float]]:
    """ns per path-step of each kernel of this checkout: ``passes`` passes over the kernels
    (each kernel timed once a pass, CPU time, the order rotated pass by pass); ``only`` =
    "sde": the averaged SDE's kernels and their minimal kernel alone."""
    numba.set_num_threads(1)
    if only == "sde":
        runs, stationary = {**_sde(), **_sde_time()}, None
    else:
        original, stationary = _original()
        runs = {**original, **_splitting(), **_sde(), **_sde_time()}
    if side == "after":
        _check_minimal_sde()
        runs.update({k: f for k, f in _minimal(stationary).items()
                     if only != "sde" or "SDE" in k})
    for name, fn in runs.items():
        fn(2 if "SDE" in name else 100)  # load the compiled kernel
    out: dict[str, list[float]] = {k: [] for k in runs}
    names = list(runs)
    for i in range(passes):
        for name in names[i % len(names):] + names[:i % len(names)]:
            k = n // SDE_STRIDE if "SDE" in name else n
            c0 = time.process_time()
            steps = runs[name](k)
            out[name].append((time.process_time() - c0) / steps * 1e9)
    return out


def _minimal_of(name: str) -> str:
    return "minimal SoA, averaged SDE" if "SDE" in name else MINIMAL


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=False, help="python of the checkout before")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--passes", type=int, default=3, help="passes over the kernels a round")
    ap.add_argument("--steps", type=int, default=20000, help="steps per path")
    ap.add_argument("--worker", choices=("before", "after"))
    ap.add_argument("--only", choices=("all", "sde"), default="all",
                    help="sde: the averaged SDE's kernels only")
    ap.add_argument("--out", default=str(OUT), help="the results' json")
    a = ap.parse_args()
    if a.worker:
        print(json.dumps(worker(a.worker, a.steps, a.passes, a.only)))
        return
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    sides = {"after": sys.executable} | ({"before": a.before} if a.before else {})
    load0 = os.getloadavg()
    rounds: dict[str, dict[str, list[float]]] = {s: {} for s in sides}
    paired: dict[str, list[float]] = {}  # kernel / minimal, pass by pass (after)
    for _ in range(a.rounds):
        for side, py in sorted(sides.items(), reverse=True):  # before, then after
            cwd = ROOT if side == "after" else None
            r = subprocess.run([py, str(Path(__file__).resolve()), "--worker", side, "--steps",
                                str(a.steps), "--passes", str(a.passes), "--only", a.only],
                               capture_output=True, text=True, env=env, cwd=cwd, check=True)
            got = json.loads(r.stdout.strip().splitlines()[-1])
            for k, v in got.items():
                rounds[side].setdefault(k, []).extend(v)
                if side == "after" and not k.startswith("minimal"):
                    paired.setdefault(k, []).extend(
                        x / y for x, y in zip(v, got[_minimal_of(k)], strict=True))
    med = {s: {k: float(np.median(v)) for k, v in d.items()} for s, d in rounds.items()}
    after = med["after"]
    res = {"ns_per_path_step_median": med, "rounds": rounds,
           "after_over_minimal_soa": {k: after[k] / after[_minimal_of(k)]
                                      for k in after if not k.startswith("minimal")},
           "after_over_minimal_soa_paired_median": {k: float(np.median(v))
                                                    for k, v in paired.items()},
           "settings": {"dt": H, "paths": N_PATHS, "steps_per_path": a.steps,
                        "sde": {"blocks": SDE_BLOCKS, "paths_per_block": SDE_PER,
                                "stride": SDE_STRIDE}, "rounds": a.rounds,
                        "passes": a.passes, "before": a.before, "only": a.only},
           "machine": {"cpus": os.cpu_count(), "load_average_start": load0,
                       "load_average_end": os.getloadavg()}}
    if "before" in med:
        res["before_over_after"] = {k: med["before"][k] / after[k] for k in med["before"]}
        res["before_over_minimal_soa"] = {k: v / after[_minimal_of(k)]
                                          for k, v in med["before"].items()}
    Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
    print(json.dumps({k: res[k] for k in res if k != "rounds"}, indent=1))


if __name__ == "__main__":
    main()
