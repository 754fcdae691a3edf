"""The headline numbers of README.md and docs/report.md, regenerated from a fresh run.

    python docs/scripts/doc_numbers.py            # run `vifpk check scenes/paper-base.toml`, write
                                              # docs/numbers.json, rewrite the marked blocks
                                              # (first cold: numba's cache empty, then warm)
    python docs/scripts/doc_numbers.py --from DIR --seconds S   # reuse a report folder of that run
    python docs/scripts/doc_numbers.py --render   # rewrite the blocks from the recorded files
    python docs/scripts/doc_numbers.py --check    # exit 1 if a marked block differs from what
                                              # docs/numbers.json renders (no run)

The L1 table of docs/paper.md is the block ``figures``, rendered from docs/img/figures.json,
which `vifpk figures --out docs/img` writes (run it first; it takes minutes).

A marked block is the text between ``<!-- numbers:NAME -->`` and ``<!-- /numbers:NAME -->``;
it is written by this script only, so a number in it cannot drift from the run recorded in
docs/numbers.json. tests/test_docs_numbers.py checks the blocks against that file and the
file's numbers against a fresh small run, within the stated noise.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
NUMBERS = ROOT / "docs" / "numbers.json"
FILES = (ROOT / "README.md", ROOT / "docs" / "report.md", ROOT / "docs" / "paper.md")
FIGURES = ROOT / "docs" / "img" / "figures.json"  # written by `vifpk figures --out docs/img`
SCENE = "scenes/paper-base.toml"
BLOCK = re.compile(
    r"(<!-- numbers:(?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /numbers:(?P=name) -->)", re.S)


def collect(metrics: dict[str, Any], seconds: float, load: float | None,
            cpu: float | None = None, cold: tuple[float, ...] | None = None
            ) -> dict[str, Any]:
    """The recorded numbers: per model the averaging error of p(A) with its error bar, floor
    and class; the ranges of the discretisation and sampling errors; the verdict lines."""
    models = {}
    disc, samp, ratio = [], [], []
    for m, entry in metrics["models"].items():
        e = entry["averaging_error"]["A"]
        models[m] = {"L1": e["L1"], "L1_err": e["L1_err"], "L1_floor": e["L1_floor"],
                     "ks": e["ks"], "mean_diff": e["mean_diff"],
                     "verdict_class": entry.get("verdict_class")}
        for o in ("A", "x1", "x2"):
            disc.append(entry["discretisation_error"][o]["L1"])
            s = entry["sampling_error"][o]
            samp.append(s["L1"])
            ratio.append(s["L1"] / s["L1_floor"])
    return {"scene": SCENE, "command": f"vifpk check {SCENE}",
            "date": datetime.now(UTC).strftime("%Y-%m-%d"), "seconds": seconds,
            "cpu_seconds": cpu,
            **({"cold_seconds": cold[0], "cold_cpu_seconds": cold[1]} if cold else {}),
            **({"cold_load_average_1min": cold[2]} if cold and len(cold) > 2 else {}),
            "cpus": os.cpu_count(), "load_average_1min": load,
            "models": models, "discretisation_L1": [min(disc), max(disc)],
            "sampling_L1": [min(samp), max(samp)],
            "sampling_over_floor_max": max(ratio), "verdicts": metrics["verdicts"]}


def render(n: dict[str, Any]) -> dict[str, str]:
    """The text of every marked block, from the recorded numbers."""
    p, e = n["models"]["paper"], n["models"]["exact"]
    v = "\n".join(f"    {line}" for line in n["verdicts"])
    load = n["load_average_1min"]
    cpu = n.get("cpu_seconds")
    run = (f"{n['seconds']:.0f} s wall" + (f" ({cpu:.0f} s CPU)" if cpu is not None else "")
           + f" on {n['cpus']} cores"
           + (f" (load average {load:.1f} at its end)" if load is not None else ""))
    blocks = {
        "finding": (
            f"First finding (docs/montecarlo.md): at the paper's base scene the printed averaged "
            f"model is\noff by L1 = {p['L1']:.2f} in p(A) against the simulated original system "
            f"(noise floor {p['L1_floor']:.3f}),\nalmost all of it because it drops the sgn(y) "
            f"factor of the transformed excitation; the same\naveraging done on the exact orbit "
            f"with that factor kept is off by {e['L1']:.2f} (`vifpk check`, {n['date']}).\n"),
        "check-time": (f"The main job below took {run} (docs/scripts/doc_numbers.py).\n"
                       + (f"The first run after an install took {n['cold_seconds']:.0f} s "
                          f"wall ({n['cold_cpu_seconds']:.0f} s CPU"
                          + (f", load average {n['cold_load_average_1min']:.1f} at its end"
                             if n.get("cold_load_average_1min") is not None else "")
                          + "): it compiles the numba "
                          "kernels (cached afterwards). A\nmachine shared with other work "
                          "takes longer. vifpk needs Python >= 3.11.\n"
                          if n.get("cold_seconds") is not None else
                          "The first run after an install also compiles the numba kernels "
                          "(cached afterwards), and a\nmachine shared with other work takes "
                          "longer. vifpk needs Python >= 3.11.\n")),
        "verdicts": f"\n{v}\n\n",
        "base": (
            f"The base scene ({n['date']}, default settings, `{n['command']}`, {run}):\n\n{v}\n\n"
            f"Discretisation errors are {n['discretisation_L1'][0]:.0e} to "
            f"{n['discretisation_L1'][1]:.0e}, and sampling errors "
            f"{n['sampling_L1'][0]:.3f}–{n['sampling_L1'][1]:.3f}, at most "
            f"{n['sampling_over_floor_max']:.2f} × their noise floors.\n"),
    }
    if FIGURES.exists():  # the L1 table of `vifpk figures`, as that command wrote it
        from vifpk.harness.workflows.figures import render_table

        doc = json.loads(FIGURES.read_text())
        table = {k: v for k, v in doc.items() if k.startswith("figure")}
        prov = doc.get("provenance") or {}
        head = (f"Measured {prov['created'][:10]} by `{prov.get('command', 'vifpk figures')}` "
                f"(run {prov.get('run_id', '?')}).\n\n" if prov.get("created") else "")
        blocks["figures"] = head + render_table(table)
    return blocks


def rewrite(text: str, blocks: dict[str, str]) -> str:
    def sub(m: re.Match[str]) -> str:
        name = m.group("name")
        if name not in blocks:
            raise KeyError(f"no generator for block {name!r}")
        return m.group(1) + blocks[name] + m.group(4)

    return BLOCK.sub(sub, text)


def stale(numbers: dict[str, Any]) -> list[str]:
    """Files whose marked blocks differ from what the numbers render."""
    blocks = render(numbers)
    return [str(f.relative_to(ROOT)) for f in FILES
            if rewrite(f.read_text(encoding="utf-8"), blocks) != f.read_text(encoding="utf-8")]


def run_check(env: dict[str, str] | None = None
              ) -> tuple[dict[str, Any], float, float, float]:
    import resource

    # as a newcomer's python: .pyc files written on the first run (PYTHONDONTWRITEBYTECODE,
    # set in some sandboxes, made every run compile vifpk's modules from source: 0.3-0.5 s CPU)
    env = {k: v for k, v in (env or os.environ).items() if k != "PYTHONDONTWRITEBYTECODE"}
    with tempfile.TemporaryDirectory() as tmp:
        ru = resource.getrusage(resource.RUSAGE_CHILDREN)
        c0 = ru.ru_utime + ru.ru_stime
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "vifpk", "check", SCENE, "--out", tmp,
                        "--quiet"], cwd=ROOT, check=True, stdout=subprocess.DEVNULL,
                       env=env)
        seconds = time.perf_counter() - t0
        load = os.getloadavg()[0]
        ru = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = ru.ru_utime + ru.ru_stime - c0
        return json.loads((Path(tmp) / "metrics.json").read_text()), seconds, load, cpu


def run_cold_then_warm() -> tuple[dict[str, Any], float, float, float,
                                  tuple[float, float, float]]:
    """A newcomer's two runs (issue 44): the first with an empty numba cache (a fresh clone:
    every kernel compiled), then the same again on the cache it filled. Returns the warm
    run's (metrics, seconds, load, CPU) and the cold one's (seconds, CPU, load)."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "NUMBA_CACHE_DIR": cache}
        _, cold_s, cold_load, cold_cpu = run_check(env)
        return (*run_check(env), (cold_s, cold_cpu, cold_load))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true",
                    help="only check that the marked blocks match docs/numbers.json")
    ap.add_argument("--render", action="store_true",
                    help="rewrite the marked blocks from docs/numbers.json and "
                         "docs/img/figures.json, without a run")
    ap.add_argument("--from", dest="src", metavar="DIR",
                    help="read DIR/metrics.json of a `vifpk check` of the base scene instead "
                         "of running it (default: run it)")
    ap.add_argument("--seconds", type=float,
                    help="with --from: the wall seconds that run took (required)")
    ap.add_argument("--no-cold", action="store_true",
                    help="skip the first run with an empty numba cache (the cold start)")
    args = ap.parse_args(argv)
    if args.check:
        bad = stale(json.loads(NUMBERS.read_text()))
        for f in bad:
            print(f"{f}: numbers differ from docs/numbers.json; run docs/scripts/doc_numbers.py")
        return 1 if bad else 0
    if args.render:
        blocks = render(json.loads(NUMBERS.read_text()))
        for f in FILES:
            f.write_text(rewrite(f.read_text(encoding="utf-8"), blocks), encoding="utf-8")
        return 0
    if args.src:
        if args.seconds is None:
            ap.error("--from needs --seconds")
        metrics = json.loads((Path(args.src) / "metrics.json").read_text())
        seconds, load, cpu, cold = args.seconds, None, None, None
    elif args.no_cold:
        (metrics, seconds, load, cpu), cold = run_check(), None
    else:
        metrics, seconds, load, cpu, cold = run_cold_then_warm()
    numbers = collect(metrics, seconds, load, cpu, cold)
    NUMBERS.write_text(json.dumps(numbers, indent=1) + "\n", encoding="utf-8")
    blocks = render(numbers)
    for f in FILES:
        f.write_text(rewrite(f.read_text(encoding="utf-8"), blocks), encoding="utf-8")
    print(f"wrote {NUMBERS.relative_to(ROOT)} and the blocks of "
          + ", ".join(str(f.relative_to(ROOT)) for f in FILES))
    return 0


if __name__ == "__main__":
    sys.exit(main())
