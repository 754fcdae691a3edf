"""What accuracy costs in time: work-precision of every solver for one scene.

Each solver family runs a ladder of settings. Each run is timed the way DiffEqDevTools does it:
one warm-up call (its extra time over the warm minimum is reported as first-call/compile
overhead), then the minimum of ``repeats`` calls. A failed run is recorded as NaN, not raised.
Each run is scored by the L1 distance of p(A) from a high-accuracy reference **of the same
model**: the closed form on a very fine grid for the averaged models (and for their FPK and
averaged-SDE Monte Carlo), and a long Monte Carlo run for the original system.

For the Monte Carlo of the original system the error is split into a bias (the time step)
and a variance (the samples). The variance part is the L1 noise floor, which scales as
K / sqrt(seconds x dt) at fixed dt. The bias part is sqrt(L1^2 - floor^2) on a dt ladder, fitted by
C dt^p. The best dt for a budget B minimises sqrt((C dt^p)^2 + K^2 / (B dt)).
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from vifpk.harness.door.solvers import SolverFailure
from vifpk.harness.workflows.compare import compare

from vifpk.core.guard import PluginError
from vifpk.core.protocols import Ref, WorkflowSpec

TARGETS = (1e-2, 1e-3, 1e-4)


@dataclass(frozen=True)
class Failed:
    """A run of the ladder whose solver failed (SolverFailure or a plugin's PluginError): a
    NaN point of the table, with the reason."""

    reason: str

    def __str__(self) -> str:
        return self.reason


def timed(fn: Callable[[], Any], *, repeats: int) -> tuple[Any, float, float]:
    """(result, seconds of the warm-up call, min seconds of the repeats); (Failed, NaN, NaN)
    when the solver failed. Any other exception is a bug and propagates."""
    try:
        t0 = time.perf_counter()
        out = fn()
        first = time.perf_counter() - t0
        best = first if repeats == 0 else math.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            out = fn()
            best = min(best, time.perf_counter() - t0)
        return out, first, best
    except (SolverFailure, PluginError) as exc:  # a failed run is a NaN point, not a crash
        return Failed(str(exc)), math.nan, math.nan


def _with(scene: Any, **sections: dict[str, Any]) -> Any:
    return replace(scene, **{k: replace(getattr(scene, k), **v) for k, v in sections.items()})


def _ladders(quick: bool) -> dict[str, list[dict[str, Any]]]:
    if quick:
        return {
            "closed form (paper)": [{"points": n} for n in (33, 65, 129)],
            "closed form (exact)": [{"points": 65, "theta_nodes": 8, "harmonics": 4},
                                    {"points": 129, "theta_nodes": 16, "harmonics": 8}],
            "FPK direct (paper)": [{"cells": n} for n in (25, 50, 100)],
            "FPK py-pde BDF (paper), cells": [{"cells": 50, "rtol": 1e-6}],
            "MC averaged SDE (paper)": [{"paths": 32, "time": 50.0}, {"paths": 64, "time": 100.0}],
            "MC original system": [{"paths": 32, "time": 50.0}, {"paths": 64, "time": 100.0}],
        }
    return {
        "closed form (paper)": [{"points": n} for n in (33, 65, 129, 257, 513, 1025, 2049)],
        "closed form (exact)": [{"points": p, "theta_nodes": t, "harmonics": h} for p, t, h in
                                ((65, 8, 4), (129, 16, 6), (257, 24, 8), (513, 32, 12),
                                 (801, 64, 24), (1601, 96, 32))],
        "FPK direct (paper)": [{"cells": n} for n in (25, 50, 100, 200, 400, 800, 1600)],
        "FPK py-pde BDF (paper), cells": [{"cells": n, "rtol": 1e-9}
                                          for n in (50, 100, 200, 400, 800)],
        "FPK py-pde BDF (paper), tolerance": [{"cells": 400, "rtol": t, "steady": t}
                                              for t in (1e-3, 1e-4, 1e-5, 1e-7, 1e-9)],
        "MC averaged SDE (paper)": [{"paths": p, "time": t} for p, t in
                                    ((64, 250.0), (128, 500.0), (256, 1000.0), (512, 2000.0))],
        "MC original system": [{"paths": p, "time": t} for p, t in
                               ((64, 250.0), (128, 500.0), (256, 1000.0), (512, 2000.0),
                                (1024, 2000.0))],
    }


def _amplitude_only(scene: Any, model: str) -> Any:
    """p(A) of an averaged model, and nothing else (the score is on p(A))."""
    from vifpk.harness.door.solvers import amplitude_density

    amp = amplitude_density(scene, model)

    class _R:
        data = {"A": {"x": amp.A, "p": amp.p}}

    return _R()


def run_workprecision(scene: Any, *, quick: bool = False, repeats: int = 3,
                      log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """The work-precision data of every solver family (see module docstring)."""
    from vifpk.harness.door.solvers import (
        averaged_model,
        averaged_sde_solution,
        closed_form,
        fpk_stationary,
        montecarlo_solution,
    )

    say = log or (lambda s: None)
    fine = 2049 if quick else 12801
    say("references (closed forms on fine grids)")
    ref_paper = closed_form(_with(scene, averaging={"points": fine}), model="paper")
    ref_exact = closed_form(_with(scene, averaging={"points": 801 if quick else 3201,
                                                    "theta_nodes": 128, "harmonics": 48}),
                            model="exact")
    model = averaged_model(scene, "paper")
    lo, hi = 0.0, float(ref_paper.data["A"]["x"][-1])
    edges = {"edges_A": np.linspace(0.0, 1.1 * hi, scene.montecarlo.bins + 1),
             "edges_x": np.linspace(0.0, 1.1 * hi, scene.montecarlo.bins + 1),
             "edges_v": np.linspace(-2.0 * hi, 2.0 * hi, scene.montecarlo.bins + 1)}
    ladders = _ladders(quick)
    solvers: dict[str, list[dict[str, Any]]] = {}

    def record(name: str, setting: dict[str, Any], out: Any, first: float, best: float,
               ref: Any, key: str = "A") -> None:
        if isinstance(out, Failed) or not math.isfinite(best):
            point = {"setting": setting, "seconds": math.nan, "error": math.nan,
                     "failure": str(out)}
        else:
            m = compare(ref.data[key], out.data[key])
            raw, ref_floor = m["L1"], reference_floor(ref.data[key])
            point = {"setting": setting, "seconds": best, "error": run_error(raw, ref_floor),
                     "error_raw": raw, "reference_floor": ref_floor,
                     "error_floor": m.get("L1_floor", 0.0),
                     "first_call_overhead": max(first - best, 0.0)}
        solvers.setdefault(name, []).append(point)

    for name, ladder in ladders.items():
        say(name)
        for st in ladder:
            reps = repeats
            if name.startswith("closed form"):
                which = "paper" if "paper" in name else "exact"

                def fn(st=st, which=which):
                    return _amplitude_only(_with(scene, averaging=st), which)
                ref = ref_paper if which == "paper" else ref_exact
            elif name.startswith("FPK direct"):
                def fn(st=st):
                    return fpk_stationary(model.drift, model.diffusion, cells=st["cells"],
                                          method="direct", lo=lo, hi=hi)
                ref = ref_paper
            elif name.startswith("FPK py-pde"):
                reps = 1

                def fn(st=st):
                    return fpk_stationary(model.drift, model.diffusion, cells=st["cells"],
                                          method="stepping", lo=lo, hi=hi, rtol=st["rtol"],
                                          steady=st.get("steady", 1e-9))
                ref = ref_paper
            elif name.startswith("MC averaged SDE"):
                reps = 1

                def fn(st=st):
                    return averaged_sde_solution(scene, model, edges=edges,
                                                 seed=scene.montecarlo.seed + 1,
                                                 paths=st["paths"], blocks=16, time=st["time"])
                ref = ref_paper
            else:
                continue
            out, first, best = timed(fn, repeats=reps)
            record(name, st, out, first, best, ref)

    # the original system: a long reference run, the paths x time ladder and the dt ladder
    say("MC original system (reference run)")
    ref_set = {"paths": 256, "time": 400.0} if quick else {"paths": 4096, "time": 4000.0}

    def mc_run(paths: int, time_: float, dt: float, seed: int) -> Any:
        sc = _with(scene, montecarlo={"paths": paths, "time": time_, "dt": dt, "seed": seed,
                                      "blocks": 16},
                   observables={"A": True, "x1": False, "x2": False, "joint": False,
                                "moments": True, "events": False})
        return montecarlo_solution(sc, progress=False, **edges)

    dt0 = scene.montecarlo.dt
    ref_mc = mc_run(ref_set["paths"], ref_set["time"], dt0 / 2, scene.montecarlo.seed + 99)
    name = "MC original system"
    say(name)
    for st in ladders[name]:
        out, first, best = timed(lambda st=st: mc_run(st["paths"], st["time"], dt0,
                                                     scene.montecarlo.seed), repeats=0)
        record(name, st, out, first, best, ref_mc)
    say("MC original system: time-step ladder (bias and variance)")
    split = _bias_variance(mc_run, ref_mc, dt0, quick, scene.montecarlo.seed)
    # the dt ladder's runs are runs of the same solver: they count toward "seconds to reach"
    solvers[DT_LADDER] = [
        {"setting": {"paths": split["paths"], "time": split["time"], "dt": r["dt"]},
         "seconds": r["seconds"], "error": r.get("error", math.nan),
         "error_raw": r.get("L1", math.nan), "reference_floor": r.get("reference_floor", 0.0),
         "error_floor": r.get("floor", 0.0)} for r in split["ladder"]]
    return {"scene": scene.to_dict(), "solvers": solvers, "mc_bias_variance": split,
            "references": {"paper": f"closed form, {fine} points",
                           "exact": "closed form, 3201 points, 128 nodes, 48 harmonics",
                           "original": f"Monte Carlo, {ref_set['paths']} paths x "
                                       f"{ref_set['time']:g} time, dt = {dt0 / 2:g}"},
            "seconds_to_reach": seconds_to_reach(solvers),
            "timing": f"DiffEqDevTools-style: warm-up call, then min of {repeats} repeats "
                      "(1 for runs of seconds: stepping and Monte Carlo); NaN on failure"}


def _bias_variance(mc_run: Callable[..., Any], ref: Any, dt0: float, quick: bool,
                   seed: int) -> dict[str, Any]:
    paths, time_ = (64, 100.0) if quick else (1024, 2000.0)
    dts = (0.16, 0.04) if quick else (0.32, 0.16, 0.08, 0.04, 0.02)
    rows = []
    for dt in dts:
        out, first, best = timed(lambda dt=dt: mc_run(paths, time_, dt, seed + 7), repeats=0)
        if isinstance(out, Failed):
            rows.append({"dt": dt, "seconds": math.nan, "L1": math.nan})
            continue
        m = compare(ref.data["A"], out.data["A"])
        mean = out.info["moments"]["A"]["mean"]
        rmean = ref.info["moments"]["A"]["mean"]
        ref_floor = reference_floor(ref.data["A"])
        rows.append({"dt": dt, "seconds": best, "L1": m["L1"], "floor": m["L1_floor"],
                     "reference_floor": ref_floor, "error": run_error(m["L1"], ref_floor),
                     "bias_L1": math.sqrt(max(m["L1"] ** 2 - m["L1_floor"] ** 2, 0.0)),
                     "mean_A_bias": mean["value"] - rmean["value"],
                     "mean_A_bias_err": math.hypot(mean["err"], rmean["err"])})
    good = [r for r in rows if math.isfinite(r.get("L1", math.nan))]
    # variance: floor = K / sqrt(seconds * dt)
    K = float(np.median([r["floor"] * math.sqrt(r["seconds"] * r["dt"]) for r in good])) \
        if good else math.nan
    # bias: C dt^p on the points whose bias clears the floor
    fit = [r for r in good if r["bias_L1"] > r["floor"]]
    if len(fit) >= 2:
        p, logC = np.polyfit(np.log([r["dt"] for r in fit]), np.log([r["bias_L1"] for r in fit]),
                             1)
        C = math.exp(logC)
    else:
        p, C = math.nan, math.nan
    best = {}
    for budget in (1.0, 10.0, 100.0, 1000.0):
        grid = np.geomspace(1e-3, 0.5, 200)
        if math.isfinite(C) and math.isfinite(K):
            err = np.sqrt((C * grid**p) ** 2 + K**2 / (budget * grid))
            i = int(np.argmin(err))
            best[f"{budget:g} s"] = {"dt": float(grid[i]), "predicted_L1": float(err[i])}
        else:
            best[f"{budget:g} s"] = {"dt": math.nan, "predicted_L1": math.nan}
    return {"ladder": rows, "paths": paths, "time": time_,
            "variance_constant_K": K, "bias_fit": {"C": C, "order": p},
            "best_dt_for_budget": best,
            "model": "L1 ~ sqrt((C dt^p)^2 + K^2 / (budget dt))"}


DT_LADDER = "MC original system, dt ladder"


def reference_floor(d: dict[str, Any]) -> float:
    """The L1 noise a Monte Carlo reference histogram alone brings into a comparison:
    sum sqrt(2/pi) se_i w_i (the mean of |N(0, se_i)| per bin; compare.py), 0 for a smooth
    reference."""
    if d.get("err") is None or "edges" not in d:
        return 0.0
    w = np.diff(np.asarray(d["edges"], float))
    return float(math.sqrt(2 / math.pi) * np.sum(np.asarray(d["err"], float) * w))


def run_error(l1: float, ref_floor: float) -> float:
    """The run's own L1 error: the reference's noise removed in quadrature,
    sqrt(max(L1^2 - floor_ref^2, 0)) (independent noises add in quadrature, to first order).
    The run's own noise stays in: it is part of what the run costs to beat."""
    return math.sqrt(max(l1 * l1 - ref_floor * ref_floor, 0.0))


def seconds_to_reach(solvers: dict[str, list[dict[str, Any]]]) -> dict[str, dict[str, float]]:
    """Cheapest measured run of each family reaching each target (NaN: not reached)."""
    out = {}
    for name, pts in solvers.items():
        row = {}
        for t in TARGETS:
            ok = [p["seconds"] for p in pts if math.isfinite(p["error"]) and p["error"] <= t]
            row[f"{t:g}"] = min(ok) if ok else math.nan
        out[name] = row
    return out


def plot(data: dict[str, Any], path: Any) -> None:
    from vifpk.core.io import figures

    plt = figures()

    fig, ax = plt.subplots(figsize=(8, 5.5))
    floors = []
    for name, pts in data["solvers"].items():
        xs = [p["seconds"] for p in pts if math.isfinite(p["seconds"])]
        ys = [p["error"] for p in pts if math.isfinite(p["seconds"])]
        if xs:
            ax.loglog(xs, ys, "o-", ms=4, label=name)
        floors += [(p["seconds"], p.get("error_floor", 0.0)) for p in pts
                   if p.get("error_floor", 0.0) > 0 and "original" in name]
    if floors:
        fx, fy = zip(*sorted(floors), strict=True)
        ax.loglog(fx, fy, "k:", lw=1, label="MC sampling floor (original system)")
    for t in TARGETS:
        ax.axhline(t, color="grey", lw=0.5)
    ax.set_xlabel("seconds (warm, min of repeats)")
    ax.set_ylabel("L1 error of p(A) against a reference of the same model")
    ax.set_title("Work-precision: " + str(data["scene"]["name"]))
    ax.legend(fontsize=7)
    fig.tight_layout()
    try:
        fig.savefig(path, dpi=110)
    finally:
        plt.close(fig)


def table_markdown(data: dict[str, Any]) -> str:
    lines = ["Seconds to reach an L1 error of p(A) (cheapest measured run; Monte Carlo errors "
             "with the reference's noise removed, as in the split table below):", "",
             "| solver | L1 = 1e-2 | L1 = 1e-3 | L1 = 1e-4 |", "|---|---|---|---|"]
    for name, row in data["seconds_to_reach"].items():
        cells = [f"{v:.3g} s" if math.isfinite(v) else "not reached" for v in row.values()]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    bv = data["mc_bias_variance"]
    lines += ["", "Monte Carlo of the original system, error split (L1 of p(A)):", "",
              f"({bv.get('paths', '?')} paths x time {bv.get('time', '?')}; L1 against the "
              "reference run; error = the run's own error, the reference's noise floor removed "
              "in quadrature: the number the table above counts as reached)", "",
              "| dt | seconds | L1 | noise floor (both runs) | reference floor | error | "
              "bias part | mean-A bias |", "|---|---|---|---|---|---|---|---|"]
    for r in bv["ladder"]:
        if not math.isfinite(r.get("L1", math.nan)):
            lines.append(f"| {r['dt']:g} | failed | | | | | | |")
            continue
        lines.append(f"| {r['dt']:g} | {r['seconds']:.2f} | {r['L1']:.4f} | {r['floor']:.4f} | "
                     f"{r.get('reference_floor', 0.0):.4f} | {r.get('error', r['L1']):.4f} | "
                     f"{r['bias_L1']:.4f} | {r['mean_A_bias']:+.4f} ± {r['mean_A_bias_err']:.4f} |")
    fit = bv["bias_fit"]
    K = bv["variance_constant_K"]
    k_text = (f"variance constant K = {K:.3g} (floor = K / sqrt(seconds x dt))"
              if math.isfinite(K) else "variance constant K: not determined (no finished run)")
    if not (math.isfinite(fit["C"]) and math.isfinite(fit["order"])):
        # never a table of nan: say why there is no fit
        lines += ["", "Bias fit: not determined: fewer than two time steps have a bias above "
                  "their noise floor (the bias is within the noise at these sizes; --quick "
                  f"ladders are a smoke test); {k_text}. No best dt per budget without it."]
        return "\n".join(lines) + "\n"
    lines += ["", f"Bias fit: L1 bias = {fit['C']:.3g} dt^{fit['order']:.2f}; {k_text}.", "",
              "| budget | best dt | predicted L1 |", "|---|---|---|"]
    for b, v in bv["best_dt_for_budget"].items():
        lines.append(f"| {b} | {v['dt']:.3g} | {v['predicted_L1']:.3g} |")
    return "\n".join(lines) + "\n"


def log_stderr(msg: str) -> None:
    print(f"workprecision: {msg} ...", file=sys.stderr, flush=True)


# ------------------------------------------------------------------ the workflow's record
#: ``vifpk workprecision`` (vifpk.core.protocols.Workflow), registered in pyproject.toml's
#: ``vifpk.workflows``. Its command line (harness/cli) is named by Ref, imported when
#: used: the registry does not depend on the layers above this one.
SPEC = WorkflowSpec(
    "workprecision", "what accuracy costs in time, for every solver",
    add_arguments=Ref("vifpk.harness.cli.arguments:workprecision_arguments"),
    command=Ref("vifpk.harness.cli.commands:cmd_workprecision"))
