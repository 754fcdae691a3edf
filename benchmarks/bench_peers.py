"""Peers at equal weak error, in one run: our numba kernel, the same scheme in vectorised
NumPy, and diffrax (JAX; the optional ``bench`` extra), on the smooth sub-system.

    pip install -e ".[bench]" && python benchmarks/bench_peers.py   # -> results/peers.json

The smooth sub-system is linearised (alpha = 0, c2 = 0, c1 = -0.5, no barrier, no friction;
OU noise D = 0.05, alpha1 = 1) so that the weak error is known exactly:
E[v^2] = f^2 int w^2 |H(w)|^2 S(w) dw = 0.04. For each implementation the relative bias of
E[v^2] is measured on a dt ladder, fitted by C dt^p, and solved for the dt giving 1%; the cost
is then seconds per path per unit of simulated time at that dt. Timing: a warm-up call
(compile), then the minimum of repeats.
"""

from __future__ import annotations

import json
import math
import platform
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from vifpk.montecarlo.plan import physics as _params  # noqa: E402
from vifpk.montecarlo.reference import simulate_numpy  # noqa: E402

from vifpk import montecarlo as mc  # noqa: E402
from vifpk.core.scene import MonteCarloSettings, Scene  # noqa: E402

DEFAULTS = mc.Settings(**asdict(MonteCarloSettings()), certificate=False)

G, D, A1, F = 0.5, 0.05, 1.0, 1.0
EXACT = 0.04
TARGET = 0.01
EDGES = {"edges_A": np.linspace(0, 2, 3), "edges_x": np.linspace(-2, 2, 3),
         "edges_v": np.linspace(-2, 2, 3)}


def scene() -> Scene:
    from dataclasses import replace

    s = Scene()
    return replace(s, system=replace(s.system, c1=-G, c2=0.0, alpha=0.0, mu=0.0, barrier=False,
                                     f=F), noise=replace(s.noise, D=D, alpha1=A1))


def numba_run(dt: float, paths: int, time_: float, threads: int = 0) -> tuple[float, float, float]:
    sc = scene()
    kw = dict(paths=paths, blocks=32, dt=dt, time=time_, burn_in=50.0, sample_every=2.0,
              progress=False, observables=("moments",), edges=EDGES, threads=threads)
    mc.simulate(sc.system, sc.noise, DEFAULTS, **dict(kw, paths=32, time=10.0))
    t0 = time.perf_counter()
    r = mc.simulate(sc.system, sc.noise, DEFAULTS, **kw)
    sec = time.perf_counter() - t0
    v2 = r.info["moments"]["x2"]["second"]
    return v2["value"], v2["err"], sec


def numpy_run(dt: float, paths: int, time_: float) -> tuple[float, float, float]:
    sc = scene()
    phys = _params(sc.system, sc.noise)
    steps, burn, stride = int((time_ + 50) / dt), int(50 / dt), max(int(2.0 / dt), 1)
    vals, secs = [], []
    for seed in range(4):
        t0 = time.perf_counter()
        o = simulate_numpy(phys, paths=paths // 4, steps=steps, burn=burn, stride=stride, h=dt,
                           edges_A=EDGES["edges_A"], seed=seed)
        secs.append(time.perf_counter() - t0)
        vals.append(o["mean_v2"])
    return float(np.mean(vals)), float(np.std(vals, ddof=1) / 2), float(np.sum(secs))


def diffrax_run(dt: float, paths: int, time_: float) -> tuple[float, float, float]:
    import diffrax
    import jax
    import jax.numpy as jnp

    jax.config.update("jax_enable_x64", True)

    def drift(t, y, args):
        return jnp.stack([y[1], -G * y[1] - y[0] + F * y[2], -A1 * y[2]])

    def one(key, dt, T):
        bm = diffrax.UnsafeBrownianPath(shape=(), key=key, levy_area=diffrax.SpaceTimeLevyArea)
        terms = diffrax.MultiTerm(diffrax.ODETerm(drift), diffrax.ControlTerm(
            lambda t, y, a: jnp.array([0.0, 0.0, math.sqrt(2 * D)]), bm))
        ts = jnp.arange(50.0, T, 2.0)
        sol = diffrax.diffeqsolve(terms, diffrax.SRA1(), 0.0, T, dt, jnp.zeros(3),
                                  saveat=diffrax.SaveAt(ts=ts), max_steps=int(T / dt) + 10,
                                  adjoint=diffrax.ForwardMode())
        return jnp.mean(sol.ys[:, 1] ** 2)

    run = jax.jit(jax.vmap(one, in_axes=(0, None, None)), static_argnums=(1, 2))
    keys = jax.random.split(jax.random.PRNGKey(1), paths)
    run(keys, dt, time_ + 50).block_until_ready()  # compile
    t0 = time.perf_counter()
    r = np.asarray(run(keys, dt, time_ + 50).block_until_ready())
    sec = time.perf_counter() - t0
    return float(r.mean()), float(r.std(ddof=1) / math.sqrt(paths)), sec


def study(name: str, fn, dts, paths: int, time_: float) -> dict:
    rows = []
    for dt in dts:
        v, e, sec = fn(dt, paths, time_)
        rows.append({"dt": dt, "rel_bias": v / EXACT - 1, "rel_err": e / EXACT,
                     "seconds": sec, "seconds_per_path_time": sec / (paths * (time_ + 50))})
        print(f"  {name:22s} dt={dt:<6g} bias {100 * (v / EXACT - 1):+.2f}% "
              f"± {100 * e / EXACT:.2f}%  {sec:.2f} s", flush=True)
    fit = [r for r in rows if abs(r["rel_bias"]) > 3 * r["rel_err"]]
    if len(fit) >= 2:
        p, logC = np.polyfit(np.log([r["dt"] for r in fit]),
                             np.log([abs(r["rel_bias"]) for r in fit]), 1)
        dt_target = float((TARGET / math.exp(logC)) ** (1 / p))
    else:
        p, dt_target = math.nan, math.nan
    # cost per step from the finest run, scaled to dt_target (cost ~ 1/dt)
    per_step = rows[-1]["seconds_per_path_time"] * rows[-1]["dt"]
    return {"ladder": rows, "order_fit": float(p), "dt_for_1pct": dt_target,
            "seconds_per_path_time_at_1pct": per_step / dt_target if dt_target else math.nan}


def main() -> None:
    out = {"command": "python benchmarks/bench_peers.py", "system": "linearised smooth "
           "sub-system, E[v^2] = 0.04 exactly", "target_weak_error": TARGET, "peers": {}}
    out["peers"]["vifpk numba (Strang, 2 threads)"] = study(
        "numba", numba_run, (0.4, 0.2828, 0.2, 0.1414), 256, 40000.0)
    out["peers"]["same scheme, NumPy"] = study("numpy", numpy_run, (0.4, 0.2828, 0.2), 1024,
                                               1000.0)
    try:
        out["peers"]["diffrax SRA1 (JAX, vmap)"] = study("diffrax", diffrax_run,
                                                         (0.8, 0.566, 0.4), 2048, 2000.0)
    except ImportError as exc:
        out["peers"]["diffrax SRA1 (JAX, vmap)"] = {"skipped": f"not installed: {exc}"}
    base = out["peers"]["vifpk numba (Strang, 2 threads)"]["seconds_per_path_time_at_1pct"]
    for name, r in out["peers"].items():
        if "seconds_per_path_time_at_1pct" in r:
            r["cost_relative_to_vifpk"] = r["seconds_per_path_time_at_1pct"] / base
            print(f"{name:34s} dt for 1%: {r['dt_for_1pct']:.3g}   cost "
                  f"{r['seconds_per_path_time_at_1pct'] * 1e9:.1f} ns per path per time unit "
                  f"({r['cost_relative_to_vifpk']:.1f}x vifpk)")
    out["machine"] = {"python": platform.python_version()}
    (ROOT / "benchmarks" / "results" / "peers.json").write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
