"""Every hard scene (scenes/hard/) cross-checked at its full default settings: time, verdicts,
warnings, and the same finite/normalised checks as tests/test_hard_scenes.py.

    python benchmarks/validate_hard_scenes.py          # writes results/hard_scenes.{json,md}
    python benchmarks/validate_hard_scenes.py NAME ... # only those: results/hard_scenes-subset.*

This is a validation run, not a test: at default settings a hard scene takes from seconds to
minutes (D-tiny's relaxation is long), far beyond the CI budget. The test suite runs the same
code path on reduced Monte Carlo settings (test_hard_scene_cross_check_small) and every
scene's closed forms and warnings (test_assumption_warnings); this script records what the full
runs give, with the provenance of the run, so that docs/report.md can quote it. It exits 1 if
any scene fails a check (the failures are listed in the JSON and on stderr).
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Any

from vifpk.harness.workflows.check import cross_check, output_problems

from vifpk.core.defaults import CHECK_MODELS as MODELS
from vifpk.core.io import write_atomic
from vifpk.core.provenance import collect
from vifpk.core.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"


def write(rows: list[dict[str, Any]], provenance: dict[str, Any], stem: str) -> None:
    """results/hard_scenes.json and .md with the scenes done so far (after every scene: an
    interrupted run keeps what it measured)."""
    out = {"provenance": provenance, "threads": os.cpu_count(),
           "load_average_end": os.getloadavg()[0], "scenes": rows}
    table = ["| scene | seconds (wall) | " + " | ".join(f"L1(A) {m}" for m in MODELS)
             + " | floor | warnings |", "|---|---|" + "---|" * len(MODELS) + "---|---|"]
    for r in rows:
        table.append(f"| {r['scene']} | {r['wall_seconds']:.0f} | " + " | ".join(
            f"{r['L1_A'][m]:.3f}" for m in MODELS) + f" | {r['L1_floor_A']:.3f} | "
            + (", ".join(r["warnings"]) or "–") + " |")
    write_atomic(RESULTS / f"{stem}.json", json.dumps(out, indent=1) + "\n")
    write_atomic(RESULTS / f"{stem}.md", "\n".join(table) + "\n")


def main(names: list[str]) -> int:
    paths = sorted((ROOT / "scenes" / "hard").glob("*.toml"))
    paths = [p for p in paths if p.stem != "no-noise" and (not names or p.stem in names)]
    rows: list[dict[str, Any]] = []
    provenance = collect(argv=sys.argv)
    for path in paths:
        t0, c0 = time.perf_counter(), time.process_time()
        res = cross_check(load_scene(path), quiet=True)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        met = res.metrics
        row = {"scene": path.stem, "wall_seconds": round(wall, 1), "cpu_seconds": round(cpu, 1),
               "stages": {k: round(v, 1) for k, v in met["timings"]["stages"].items()},
               "burn_in": met["monte_carlo"]["settings"]["burn_in"],
               "extensions": met["monte_carlo"]["convergence"]["extensions"],
               "equilibrated": met["monte_carlo"]["convergence"].get("equilibrated"),
               "L1_A": {m: met["models"][m]["averaging_error"]["A"]["L1"] for m in MODELS},
               "L1_floor_A": met["models"]["exact"]["averaging_error"]["A"]["L1_floor"],
               "classes": {m: met["models"][m]["verdict_class"] for m in MODELS},
               "warnings": [w.title for w in res.warnings],
               "problems": output_problems(res)}
        rows.append(row)
        print(f"{row['scene']:14s} {wall:7.1f} s  " + "  ".join(
            f"{m} {row['L1_A'][m]:.3f}" for m in MODELS) + f"  {row['warnings']}"
            + (f"  PROBLEMS {row['problems']}" if row["problems"] else ""), flush=True)
        write(rows, provenance, "hard_scenes-subset" if names else "hard_scenes")
    bad = [r["scene"] for r in rows if r["problems"]]
    if bad:
        print(f"checks failed on: {', '.join(bad)}", file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
