"""Driver of the Monte Carlo of the original system: seeding, batching, histograms, errors.

Independent blocks of paths are the batches: block b runs ``paths_per_block`` paths seeded by
the b-th child of ``numpy.random.SeedSequence(seed)``, inside one numba thread, so the same
seed gives identical histograms for any number of threads. Densities are block means; the
error bar of each bin is the standard error of the block means (paths in different blocks
are independent, samples along one path are not). The L1 noise floor is the expected L1 of
pure sampling noise, sum_i sqrt(2/pi) se_i w_i (Gaussian bin errors).
"""

from __future__ import annotations

import math
import platform
import sys
import time
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numba
import numpy as np

from . import kernels as K
from .rng import states_from_seed

OBSERVABLES = ("A", "x1", "x2", "joint", "moments", "events")


class Result(NamedTuple):
    data: dict[str, dict[str, Any]]
    info: dict[str, Any]


@dataclass(frozen=True, kw_only=True)
class Settings:
    """Monte Carlo settings (the scene's [montecarlo] section); defaults from docs/montecarlo.md."""

    paths: int = 512
    dt: float = 0.01
    time: float = 2000.0
    burn_in: float = 200.0
    sample_every: float = 0.5
    seed: int = 20190101
    blocks: int = 32
    bins: int = 100
    threads: int = 0
    observables: tuple[str, ...] = ("A", "x1", "x2", "joint", "moments", "events")
    progress: bool = True
    edges: dict[str, Any] = field(default_factory=dict, compare=False)


def block_seeds(seed: int, blocks: int) -> np.ndarray:
    """(blocks, 4) generator states from SeedSequence(seed).spawn(blocks) (rng.py)."""
    return states_from_seed(seed, blocks)


def _params(system: Any, noise: Any) -> dict[str, Any]:
    """Kernel physics arguments; a switched-off effect is None (pruned at compile time)."""
    return {
        "c1": float(system.c1), "c2": float(system.c2), "w0sq": float(system.omega0) ** 2,
        "alpha": float(system.alpha), "f": float(system.f), "D": float(noise.D),
        "mu": float(system.mu) if system.mu > 0 else None,
        "r": float(system.r) if getattr(system, "barrier", True) else None,
        "alpha1": float(noise.alpha1) if noise.kind == "ou" else None,
    }


def effects(system: Any, noise: Any) -> dict[str, bool | str]:
    p = _params(system, noise)
    return {"friction": p["mu"] is not None, "barrier": p["r"] is not None,
            "noise": "ou" if p["alpha1"] is not None else "white"}


def _call(seeds, n_paths, n_burn, n_samples, stride, h, phys, hist, moments, events,
          spread) -> None:
    ea, ex, ev = hist["edges_A"], hist["edges_x"], hist["edges_v"]
    K.run_blocks(seeds, n_paths, n_burn, n_samples, stride, h,
                 phys["c1"], phys["c2"], phys["w0sq"], phys["alpha"], phys["f"], phys["D"],
                 phys["mu"], phys["r"], phys["alpha1"], spread,
                 ea[0], 1.0 / (ea[1] - ea[0]), hist["A"],
                 ex[0], 1.0 / (ex[1] - ex[0]), hist["x"],
                 ev[0], 1.0 / (ev[1] - ev[0]), hist["v"], hist["joint"], moments, events)


def _empty(blocks: int, edges: dict[str, np.ndarray], obs: tuple[str, ...]) -> dict[str, Any]:
    na, nx, nv = (edges[k].size - 1 for k in ("edges_A", "edges_x", "edges_v"))
    return {
        **edges,
        "A": np.zeros((blocks, na)) if "A" in obs else None,
        "x": np.zeros((blocks, nx)) if "x1" in obs else None,
        "v": np.zeros((blocks, nv)) if "x2" in obs else None,
        "joint": np.zeros((blocks, nx, nv)) if "joint" in obs else None,
    }


def _pilot_edges(phys: dict[str, Any], h: float, bins: int, seed: int,
                 barrier: bool) -> dict[str, np.ndarray]:
    """Histogram ranges from a short pilot run (maxima x 1.25)."""
    seeds = block_seeds(seed + 7919, 8)
    dummy = {"edges_A": np.array([0.0, 1.0]), "edges_x": np.array([0.0, 1.0]),
             "edges_v": np.array([0.0, 1.0]), "A": None, "x": None, "v": None, "joint": None}
    mom = np.zeros((8, K.N_MOMENTS))
    ev = np.zeros((8, K.N_EVENTS))
    n_burn = int(round(200.0 / h))
    _call(seeds, 4, n_burn, 2000, max(int(round(0.5 / h)), 1), h, phys, dummy, mom, ev, 0.1)
    amax = 1.25 * float(np.max(mom[:, K.MO_MAXA]))
    if not math.isfinite(amax) or amax <= 0:
        amax = 1.0
    # |x| <= A and |v| <= sqrt(2 U(A)) on the orbit through (x, v)
    vmax = math.sqrt(2 * (0.5 * phys["w0sq"] * amax**2 + 0.25 * phys["alpha"] * amax**4))
    return {"edges_A": np.linspace(0.0, amax, bins + 1),
            "edges_x": np.linspace(0.0 if barrier else -amax, amax, bins + 1),
            "edges_v": np.linspace(-vmax, vmax, bins + 1)}


def _density(counts: np.ndarray, samples: np.ndarray, widths: np.ndarray) -> dict[str, Any]:
    """Block-mean density per unit length, its standard error and the L1 noise floor."""
    per_block = counts / (samples.reshape((-1,) + (1,) * (counts.ndim - 1)) * widths)
    mean = per_block.mean(axis=0)
    se = per_block.std(axis=0, ddof=1) / math.sqrt(counts.shape[0])
    floor = float(np.sum(math.sqrt(2.0 / math.pi) * se * widths))
    return {"p": mean, "err": se, "L1_floor": floor}


def simulate(system: Any, noise: Any, settings: Settings | None = None, **overrides: Any
             ) -> Result:
    """Monte Carlo of the original system for (duck-typed) scene.system and scene.noise."""
    from dataclasses import replace

    st = replace(settings or Settings(), **overrides)
    obs = tuple(o for o in st.observables if o in OBSERVABLES)
    h = float(st.dt)
    if not (h > 0 and st.paths >= st.blocks >= 2):
        raise ValueError("need dt > 0 and paths >= blocks >= 2")
    phys = _params(system, noise)
    barrier = phys["r"] is not None
    threads = st.threads or numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(threads)
    n_burn = int(round(st.burn_in / h))
    stride = max(int(round(st.sample_every / h)), 1)
    n_samples = max(int(st.time / (stride * h)), 1)
    per_block = st.paths // st.blocks
    seeds = block_seeds(st.seed, st.blocks)
    seeds_used = seeds.copy()

    # compile (or load from the cache) apart from the run: a one-step call of the same types
    t0 = time.perf_counter()
    edges = {k: np.asarray(v, dtype=float) for k, v in st.edges.items()}
    tiny = _empty(1, edges or {"edges_A": np.linspace(0, 1, 3), "edges_x": np.linspace(0, 1, 3),
                                "edges_v": np.linspace(-1, 1, 3)}, obs)
    _call(seeds[:1].copy(), 1, 1, 1, 1, h, phys, tiny, np.zeros((1, K.N_MOMENTS)),
          np.zeros((1, K.N_EVENTS)), 0.1)
    compile_s = time.perf_counter() - t0
    t1 = time.perf_counter()
    if not edges:
        edges = _pilot_edges(phys, h, st.bins, st.seed, barrier)
    pilot_s = time.perf_counter() - t1

    hist = _empty(st.blocks, edges, obs)
    moments = np.zeros((st.blocks, K.N_MOMENTS))
    events = np.zeros((st.blocks, K.N_EVENTS))
    chunk = max(2 * threads, 1)
    t2 = time.perf_counter()
    bar = _progress(st.blocks, st.progress)
    for start in range(0, st.blocks, chunk):
        sl = slice(start, min(start + chunk, st.blocks))
        part = {k: (v[sl] if isinstance(v, np.ndarray) and k in ("A", "x", "v", "joint")
                    else v) for k, v in hist.items()}
        _call(seeds[sl], per_block, n_burn, n_samples, stride, h, phys, part, moments[sl],
              events[sl], 0.1)
        if bar is not None:
            bar.update(sl.stop - sl.start)
    if bar is not None:
        bar.close()
    run_s = time.perf_counter() - t2

    samples = events[:, K.EV_SAMPLES]
    data: dict[str, dict[str, Any]] = {}
    names = {"A": ("A", "edges_A"), "x1": ("x", "edges_x"), "x2": ("v", "edges_v")}
    floors = {}
    for name, (key, ekey) in names.items():
        if hist[key] is None:
            continue
        e = edges[ekey]
        d = _density(hist[key], samples, np.diff(e))
        data[name] = {"x": 0.5 * (e[1:] + e[:-1]), "p": d["p"], "edges": e, "err": d["err"]}
        floors[name] = d["L1_floor"]
    if hist["joint"] is not None:
        ex, ev = edges["edges_x"], edges["edges_v"]
        area = np.outer(np.diff(ex), np.diff(ev))
        d = _density(hist["joint"], samples, area)
        data["joint"] = {"x1": 0.5 * (ex[1:] + ex[:-1]), "x2": 0.5 * (ev[1:] + ev[:-1]),
                         "p": d["p"], "err": d["err"], "edges_x1": ex, "edges_x2": ev}
        floors["joint"] = d["L1_floor"]

    steps = float(st.blocks * per_block * (n_burn + n_samples * stride))
    sim_time = events[:, K.EV_TIME]
    info: dict[str, Any] = {
        "solver": "montecarlo",
        "settings": {"paths": st.blocks * per_block, "dt": h, "time": n_samples * stride * h,
                     "burn_in": n_burn * h, "sample_every": stride * h, "blocks": st.blocks,
                     "bins": st.bins, "observables": list(obs)},
        "seed": {"root": st.seed, "scheme": "numpy.random.SeedSequence(root).spawn(blocks)",
                 "first_block_state": [int(v) for v in seeds_used[0]]},
        "effects": effects(system, noise),
        "threads": threads,
        "order": {"weak": 2, "note": "Strang splitting; 2 on the smooth sub-system "
                                     "(no barrier, no friction), measured in tests"},
        "L1_floor": floors,
        "seconds": {"compile": compile_s, "pilot": pilot_s, "run": run_s,
                    "total": compile_s + pilot_s + run_s},
        "steps": steps, "steps_per_second": steps / run_s if run_s > 0 else math.nan,
        "versions": {"numba": numba.__version__, "numpy": np.__version__,
                     "python": platform.python_version()},
    }
    if "events" in obs:
        info["events"] = _events(events, sim_time, samples)
    if "moments" in obs:
        info["moments"] = _moments(moments, samples)
    ok = all(np.all(np.isfinite(d["p"])) for d in data.values())
    info["status"] = {"ok": bool(ok), "message": "simulated" if ok else "non-finite histogram"}
    return Result(data=data, info=info)


def _mean_se(per_block: np.ndarray) -> dict[str, float]:
    return {"value": float(per_block.mean()),
            "err": float(per_block.std(ddof=1) / math.sqrt(per_block.size))}


def _events(events: np.ndarray, sim_time: np.ndarray, samples: np.ndarray) -> dict[str, Any]:
    out = {
        "impacts_per_time": _mean_se(events[:, K.EV_IMPACTS] / sim_time),
        "stuck_fraction": _mean_se(events[:, K.EV_STUCK] / sim_time),
        "chatter_entries_per_time": _mean_se(events[:, K.EV_CHATTER] / sim_time),
        "chatter_entries": int(events[:, K.EV_CHATTER].sum()),
        "outside_fraction": {k: float(events[:, c].sum() / samples.sum()) for k, c in
                             (("A", K.EV_OUT_A), ("x1", K.EV_OUT_X), ("x2", K.EV_OUT_V))},
    }
    return out


def _moments(mom: np.ndarray, samples: np.ndarray) -> dict[str, Any]:
    s = samples
    out = {}
    for name, c1, c2 in (("A", K.MO_A, K.MO_A2), ("x1", K.MO_X, K.MO_X2), ("x2", K.MO_V, K.MO_V2)):
        out[name] = {"mean": _mean_se(mom[:, c1] / s), "second": _mean_se(mom[:, c2] / s)}
    out["max"] = {"A": float(mom[:, K.MO_MAXA].max()), "x1": float(mom[:, K.MO_MAXX].max()),
                  "x2": float(mom[:, K.MO_MAXV].max())}
    return out


def _progress(total: int, enabled: bool) -> Any:
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None
    return tqdm(total=total, desc="monte carlo", unit="block", delay=3.0, file=sys.stderr,
                leave=False)
