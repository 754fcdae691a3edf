"""Cost and results of the time-domain workflows on a scene (issue 30): each ``vifpk passage``
run at the given thresholds and one ``vifpk transient`` run, as a user runs them (a fresh
``python -m vifpk`` process from the checkout's root, numba's cache warm from a first untimed
run), recording from each metrics.json

- the stage times (``timings.stages``): the averaged routes (FPK reliability + quadrature per
  model), the Monte Carlo of the original system, the averaged SDEs' Monte Carlo;
- the process's wall time, so that the cost of the whole check stands beside the bare
  original-system Monte Carlo it contains;
- the MFPTs with their error bars and the relaxation times (the numbers docs/passage.md quotes).

    python benchmarks/bench_timedomain.py --scene paper-base --thresholds 1.5,2,2.5 \\
        --transient-start 1.0 --times 5,10,20,40,80 [--out results/timedomain.json]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def _run(args: list[str]) -> tuple[float, str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "vifpk", *args], cwd=ROOT, env=env, check=True,
                       capture_output=True, text=True)
    return time.perf_counter() - t0, p.stdout


def _shown(args: list[str], out: Path) -> str:
    """The command as a user types it (the temporary --out DIR left out)."""
    shown = [a for a in args if a != str(out)]
    shown.remove("--out")
    return "vifpk " + " ".join(shown)


def passage(scene: str, threshold: str, extra: list[str], work: Path) -> dict:
    out = work / f"passage-{threshold}"
    args = ["passage", scene, "--threshold", threshold, "--out", str(out), "--quiet", *extra]
    wall, _ = _run(args)
    m = json.loads((out / "metrics.json").read_text())
    return {"command": _shown(args, out),
            "wall_seconds": wall, "stages": m["timings"]["stages"], "mfpt": m["mfpt"],
            "mfpt_error": {k: v.get("mfpt_error_restricted", v["mfpt_error"])
                           for k, v in m["models"].items()},
            "sde_mfpt": {k: v["sde"]["mfpt"] for k, v in m["models"].items() if "sde" in v},
            "routes_rel_diff": {k: v["routes_rel_diff"] for k, v in m["mfpt"].items()
                                if "routes_rel_diff" in v},
            "plan": m["plan"], "verdicts": m["verdicts"],
            "recommendation": m["recommendation"], "warnings": m["warnings"],
            "load_average": os.getloadavg()}


def transient(scene: str, start: str, times: str, extra: list[str], work: Path) -> dict:
    out = work / "transient"
    args = ["transient", scene, "--start", start, "--times", times, "--out", str(out),
            "--quiet", *extra]
    wall, _ = _run(args)
    m = json.loads((out / "metrics.json").read_text())
    return {"command": _shown(args, out),
            "wall_seconds": wall, "stages": m["timings"]["stages"],
            "relaxation": m["relaxation"], "verdicts": m["verdicts"],
            "snapshots": {k: [{"t": r["t"], "L1": r["fpk"]["L1"],
                               "L1_err": r["fpk"].get("L1_err"),
                               "L1_floor": r["fpk"].get("L1_floor"), "ks": r["fpk"]["ks"]}
                              for r in v["snapshots"]] for k, v in m["models"].items()},
            "load_average": os.getloadavg()}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="paper-base")
    ap.add_argument("--thresholds", default="")
    ap.add_argument("--start", default="stationary", help="passage start")
    ap.add_argument("--transient-start", default="")
    ap.add_argument("--times", default="")
    ap.add_argument("--extra", default="", help="more options for every command")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "timedomain.json"))
    a = ap.parse_args()
    extra = a.extra.split()
    out = Path(a.out)
    doc = json.loads(out.read_text()) if out.is_file() else {}
    runs = doc.setdefault(a.scene, {})
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for t in filter(None, a.thresholds.split(",")):
            runs[f"passage {t} {a.start}"] = r = passage(a.scene, t, ["--start", a.start,
                                                                     *extra], work)
            print(json.dumps({k: r[k] for k in ("command", "wall_seconds", "mfpt_error")},
                             indent=1), flush=True)
        if a.transient_start:
            runs[f"transient {a.transient_start}"] = r = transient(
                a.scene, a.transient_start, a.times, extra, work)
            print(json.dumps({k: r[k] for k in ("command", "wall_seconds", "relaxation")},
                             indent=1), flush=True)
    out.write_text(json.dumps(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
