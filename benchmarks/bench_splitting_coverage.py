"""Coverage of the splitting estimator's 95% interval, measured on a closed form.

The Rayleigh amplitude of a linear oscillator under white noise, dA = (-beta A / 2
+ sigma^2 / (2 A)) dt + sigma dB (beta = 1, sigma^2 = 0.5, c = beta / (2 sigma^2) = 1): its scale
density is s(A) = e^{c A^2} / A, so S(A) = Ei(c A^2) / 2 and
P(reach Ac before a0 | A = a) = (Ei(c a^2) - Ei(c a0^2)) / (Ei(c Ac^2) - Ei(c a0^2)).
For each of ``--seeds`` seeds, montecarlo.splitting.sde_escape_probability gives p with a
Student-t 95% interval from independent AMS runs; we count the seeds whose interval holds the
closed form (nominal: 95 of 100; the binomial 95% range of the count is 90-99).

    NUMBA_NUM_THREADS=2 python benchmarks/bench_splitting_coverage.py [--seeds 100] [--out F]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time

import numpy as np
from scipy.special import expi
from vifpk.montecarlo.splitting import SplittingSettings, sde_escape_probability

BETA, S2 = 1.0, 0.5
C = BETA / (2 * S2)


def closed_form(a: float, lo: float, hi: float) -> float:
    return float((expi(C * a * a) - expi(C * lo * lo)) / (expi(C * hi * hi) - expi(C * lo * lo)))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=100)
    ap.add_argument("--threshold", type=float, default=4.7)
    ap.add_argument("--groups", type=int, default=10)
    ap.add_argument("--particles", type=int, default=100)
    ap.add_argument("--dt", type=float, default=1e-3)
    ap.add_argument("--out", default=os.path.join(os.path.dirname(__file__), "results",
                                                  "splitting_coverage.json"))
    a = ap.parse_args()
    low, start = 0.5, 1.0
    truth = closed_form(start, low, a.threshold)
    inside, z, rows = 0, [], []
    t0 = time.perf_counter()
    for seed in range(a.seeds):
        s = SplittingSettings(groups=a.groups, particles=a.particles, levels=100, dt=a.dt,
                              seed=seed)
        r = sde_escape_probability(lambda A: -BETA * A / 2 + S2 / (2 * A),
                                   lambda A: S2 + 0 * A, low=low, threshold=a.threshold,
                                   start=start, settings=s)
        p = r.data["p"]
        ok = p["ci"][0] <= truth <= p["ci"][1]
        inside += ok
        z.append((p["value"] - truth) / p["stderr"])
        rows.append({"seed": seed, "value": p["value"], "stderr": p["stderr"], "ci": p["ci"],
                     "inside": bool(ok)})
        print(f"seed {seed}: p = {p['value']:.4g} +- {p['stderr']:.2g}  inside {inside}/"
              f"{seed + 1}", flush=True)
    z = np.array(z)
    out = {"truth": truth, "threshold": a.threshold, "low": low, "start": start,
           "seeds": a.seeds, "inside": inside, "nominal": 0.95,
           "binomial_95_range": "90-99 of 100",
           "mean_relative_error": float(np.mean([r["value"] for r in rows]) / truth - 1),
           "z_mean": float(z.mean()), "z_sd": float(z.std(ddof=1)),
           "settings": {"groups": a.groups, "particles": a.particles, "levels": 100,
                        "dt": a.dt, "kill": "N // 10"},
           "seconds": time.perf_counter() - t0, "machine": platform.node(),
           "threads": os.environ.get("NUMBA_NUM_THREADS", "default"),
           "rows": rows}
    out["mean_relative_error_se"] = float(np.std([r["value"] for r in rows], ddof=1)
                                          / math.sqrt(a.seeds) / truth)
    with open(a.out + ".tmp", "w") as fh:
        json.dump(out, fh, indent=1)
    os.replace(a.out + ".tmp", a.out)
    print(f"inside {inside}/{a.seeds}; z mean {z.mean():.3f} sd {z.std(ddof=1):.3f}; "
          f"{out['seconds']:.0f} s")


if __name__ == "__main__":
    main()
