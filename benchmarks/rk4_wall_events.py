"""What the RK4 reference's wall handling does on a scene (issue 44, wall45): how often each
branch of bench_rk4_floor.py's ``step`` runs, counted by an instrumented copy of it (the
timed kernel is left as it is; this copy differs only by its counters).

The branches that could bias the reference: an impact found while the sub-step starts ON the
wall (after an impact earlier in the same step, the path re-crosses the same wall in the rest
of the step: the bisection's sign test is 0 there, so the crossing lands at s ~ 0 and the
velocity is reflected twice, a spurious r^2); eight impacts in one step (the rest of the step
dropped); a rebound below 1e-9 (the mass put at rest); a rest held by a pressing force. If all
are zero or rare, the event location (bisection on the step's cubic Hermite interpolant, the
restitution applied to the interpolant's velocity at the crossing) is what runs.

    NUMBA_NUM_THREADS=1 python benchmarks/rk4_wall_events.py [--scenes two-wall paper-base]
        [--time 2000] [--dt 0.01]   # -> benchmarks/results/rk4_wall_events.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench_rk4_floor as ref  # noqa: E402

PATHS = 256
EVENTS = ("rest_held", "impacts_lower", "impacts_upper", "bisection_from_the_wall",
          "rebound_below_1e-9", "eight_impacts_in_a_step")


@numba.njit
def _acc(x, v, xi, c):
    fr = 0.0
    if v > 0.0:
        fr = c[4]
    elif v < 0.0:
        fr = -c[4]
    return -(c[1] * x * x - c[0]) * v - (c[2] + c[3] * x * x) * x - fr + c[5] * xi


@numba.njit
def _rk4(x, v, xi0, xi1, tau, c):
    xim = 0.5 * (xi0 + xi1)
    k1x, k1v = v, _acc(x, v, xi0, c)
    k2x, k2v = v + 0.5 * tau * k1v, _acc(x + 0.5 * tau * k1x, v + 0.5 * tau * k1v, xim, c)
    k3x, k3v = v + 0.5 * tau * k2v, _acc(x + 0.5 * tau * k2x, v + 0.5 * tau * k2v, xim, c)
    k4x, k4v = v + tau * k3v, _acc(x + tau * k3x, v + tau * k3v, xi1, c)
    return (x + tau / 6 * (k1x + 2 * k2x + 2 * k3x + k4x),
            v + tau / 6 * (k1v + 2 * k2v + 2 * k3v + k4v))


@numba.njit
def _hermite(x0, v0, x1, v1, tau, s):
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    d00, d10 = (6 * s**2 - 6 * s) / tau, 3 * s**2 - 4 * s + 1
    d01, d11 = (-6 * s**2 + 6 * s) / tau, 3 * s**2 - 2 * s
    return (h00 * x0 + h10 * tau * v0 + h01 * x1 + h11 * tau * v1,
            d00 * x0 + d10 * v0 + d01 * x1 + d11 * v1)


@numba.njit
def _step(x, v, xi0, xi1, h, c, lo, hi, r, cnt):
    """bench_rk4_floor's step with counters (cnt[i] for EVENTS[i])."""
    t = 0.0
    for _ in range(8):
        tau = h - t
        if tau <= 0.0:
            return x, v
        xa = xi0 + (xi1 - xi0) * t / h
        if (x == lo and v == 0.0) or (x == hi and v == 0.0):
            F = _acc(x, 0.0, xa, c)
            if (x == lo and F <= 0.0) or (x == hi and F >= 0.0):
                cnt[0] += 1
                return x, 0.0
        xn, vn = _rk4(x, v, xa, xi1, tau, c)
        if lo <= xn <= hi:
            return xn, vn
        wall = lo if xn < lo else hi
        cnt[1 if wall == lo else 2] += 1
        if x == wall:
            cnt[3] += 1
        a_, b_ = 0.0, 1.0
        for _ in range(50):
            m = 0.5 * (a_ + b_)
            xm, _vm = _hermite(x, v, xn, vn, tau, m)
            if (xm - wall) * (x - wall) > 0.0:
                a_ = m
            else:
                b_ = m
        _xm, vh = _hermite(x, v, xn, vn, tau, b_)
        t += b_ * tau
        x, v = wall, -r * vh
        if abs(v) < 1e-9:
            v = 0.0
            cnt[4] += 1
    cnt[5] += 1
    return x, v


@numba.njit
def _path(normals, h, c, ou, walls, cnt):
    """One path from rest at x = 0.3 (as the reference's), the OU innovations ``normals``."""
    lo, hi, r = walls
    x, v, xi = 0.3, 0.0, 0.0
    for k in range(normals.size):
        xi1 = ou[0] * xi + ou[1] * normals[k]
        x, v = _step(x, v, xi, xi1, h, c, lo, hi, r, cnt)
        xi = xi1


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scenes", nargs="+", default=["two-wall", "paper-base"])
    ap.add_argument("--time", type=float, default=2000.0)
    ap.add_argument("--dt", type=float, default=ref.DT_RK4)
    a = ap.parse_args()
    ref.DT_RK4 = a.dt  # _coefficients reads it (the OU's exact update over dt)
    out = {"dt": a.dt, "time": a.time, "paths": PATHS, "start": "rest at x = 0.3",
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "scenes": {}}
    for name in a.scenes:
        c, ou, walls = ref._coefficients(ref._load(name))
        cnt = np.zeros(len(EVENTS), np.int64)
        n = round(a.time / a.dt)
        gen = np.random.default_rng(1)
        for _ in range(PATHS):
            _path(gen.standard_normal(n), a.dt, c, ou, walls, cnt)
        ev = dict(zip(EVENTS, (int(k) for k in cnt), strict=True))
        rate = {k: ev[k] / (PATHS * a.time) for k in ("impacts_lower", "impacts_upper")}
        out["scenes"][name] = {"walls": list(walls), "steps": n * PATHS, "events": ev,
                               "impacts_per_unit_time_a_path": rate}
        print(name, ev, {k: round(v, 4) for k, v in rate.items()}, flush=True)
    path = ROOT / "benchmarks" / "results" / "rk4_wall_events.json"
    path.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
