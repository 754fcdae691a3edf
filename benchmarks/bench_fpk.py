"""FPK speed at the default grid (paper model of the base scene).

    python benchmarks/bench_fpk.py            # writes benchmarks/results/fpk.json

Targets (issue 3): warm py-pde stepping to the stationary state <= 2 s, the direct solve
<= 10 ms, compile time reported apart.
"""

from __future__ import annotations

import json
import platform
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from timing import timed  # noqa: E402
from vifpk.averaging import build_model  # noqa: E402

from vifpk import fpk  # noqa: E402
from vifpk.core.scene import load_scene  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    scene = load_scene(ROOT / "scenes" / "paper-base.toml")
    m = build_model(scene, "paper")
    lo, hi, _ = fpk.choose_domain(m.drift, m.diffusion)
    cells = 400
    common = dict(cells=cells, lo=lo, hi=hi)
    rows = {
        "direct": timed(lambda: fpk.stationary(m.drift, m.diffusion, method="direct", **common)),
        "stepping_bdf": timed(lambda: fpk.stationary(m.drift, m.diffusion, method="stepping",
                                                     **common), repeats=3),
        "stepping_explicit_numba": timed(
            lambda: fpk.stationary(m.drift, m.diffusion, method="stepping", stepper="explicit",
                                   **common), repeats=2),
    }
    for row in rows.values():
        row["compile_or_first_call_overhead"] = row["first"] - row["min"]
    out = {"command": "python benchmarks/bench_fpk.py", "scene": "paper-base", "model": "paper",
           "cells": cells, "domain": [lo, hi], "seconds": rows,
           "machine": {"python": platform.python_version(), "processor": platform.machine()}}
    path = ROOT / "benchmarks" / "results" / "fpk.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    for k, v in rows.items():
        print(f"{k:26s} warm min {v['min'] * 1e3:9.2f} ms   first call {v['first'] * 1e3:9.1f} ms")


if __name__ == "__main__":
    main()
