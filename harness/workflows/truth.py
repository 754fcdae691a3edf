"""The check's truth without sampling noise (issue 46 item 3): the original system's own FPK.

Where it applies (white noise: harness/door/original.py), ``vifpk check`` measures each
model's error against the FPK's law as well as against the Monte Carlo, and decides the
tolerance verdicts and the recommendation on the FPK: its error is its discretisation error
(Richardson's estimate, vifpk/fpk2d), not a noise floor, so two models whose errors are within
one Monte Carlo floor of each other are told apart wherever their difference exceeds it.

The Monte Carlo is still run, as the FPK's independent cross-check: the two must agree, on
p(A), p(x1) and p(x2), within AGREE_FLOORS x the Monte Carlo's L1 noise floor plus the FPK's
discretisation error (the floor is the expected L1 of the noise alone, compare.py; the rule
tests/test_walls_mc.py and tests/test_fpk2d.py hold the Monte Carlo to against exact laws).
Where they do not, the run says so loudly (a warning, the verdicts and the report), and the
verdicts and the recommendation stay the Monte Carlo's.
"""

from __future__ import annotations

import math
from typing import Any

from vifpk.harness.request.tolerance import Tolerance
from vifpk.harness.workflows.compare import compare
from vifpk.harness.workflows.tolerance import tolerance_verdict

from vifpk.core.defaults import DENSITY_OBSERVABLES

#: the FPK and the Monte Carlo agree where L1 <= AGREE_FLOORS x floor + the FPK's error
AGREE_FLOORS = 3.0


def truth_metrics(fp: Any, mc: Any, closed: dict[str, Any], models: tuple[str, ...],
                  why_not: str | None) -> dict[str, Any]:
    """metrics.json's ``truth``: the FPK's discretisation error and grid, each model's
    distances to it (``models``), its agreement with the Monte Carlo (``cross_check``,
    ``agrees``), a verdict line (``line``) and, where they disagree, the warning (``words``).
    ``fp`` None: the FPK does not apply (``why``)."""
    if fp is None:
        return {"solver": None, "why": why_not}
    disc = fp.info["discretisation_error"]
    err = {o: float(disc.get(f"L1_{o}", 0.0)) for o in DENSITY_OBSERVABLES}
    per = {m: {o: {**compare(closed[m].data[o], fp.data[o]), "L1_truth_err": err[o]}
               for o in DENSITY_OBSERVABLES} for m in models}
    cross = {o: compare(fp.data[o], mc.data[o]) for o in DENSITY_OBSERVABLES}
    bad = [o for o in DENSITY_OBSERVABLES
           if not cross[o]["L1"] <= AGREE_FLOORS * cross[o]["L1_floor"] + err[o]]
    grid = fp.info["grid"]["cells"]
    rates = {"fpk": fp.info.get("impacts_per_time"),
             "montecarlo": mc.info.get("events", {}).get("impacts_per_time")}
    errs = ", ".join(f"{m} {per[m]['A']['L1']:.4f}" for m in models)
    agree = ", ".join(f"p({o}) L1 {cross[o]['L1']:.4f} = "
                      f"{_ratio(cross[o]):.1f} x floor" for o in DENSITY_OBSERVABLES)
    head = (f"original system's FPK (no sampling noise; discretisation error L1(A) "
            f"~{err['A']:.1g}, {grid[0]} x {grid[1]} cells): L1(A) against it: {errs}")
    out: dict[str, Any] = {
        "solver": "original-fpk", "error": err["A"], "discretisation_error": disc,
        "grid": fp.info["grid"], "models": per, "cross_check": cross, "agrees": not bad,
        "rule": f"L1(FPK, MC) <= {AGREE_FLOORS:g} x the MC's L1 floor + the FPK's "
                "discretisation error, on p(A), p(x1), p(x2)",
        "impacts_per_time": rates}
    if bad:
        worst = max(bad, key=lambda o: _ratio(cross[o]))
        out["words"] = (
            f"THE ORIGINAL SYSTEM'S FPK AND ITS MONTE CARLO DISAGREE on "
            f"{', '.join(f'p({o})' for o in bad)} (p({worst}): L1 {cross[worst]['L1']:.4f} = "
            f"{_ratio(cross[worst]):.1f} x the Monte Carlo's floor "
            f"{cross[worst]['L1_floor']:.4f}; allowed {AGREE_FLOORS:g} x the floor + "
            f"{err[worst]:.1g}): one of the two is wrong on this scene, so the verdicts and the "
            "recommendation are the Monte Carlo's alone; please report the scene")
        out["line"] = f"{head}; {out['words']}"
    else:
        out["line"] = (f"{head}; the Monte Carlo of the original system agrees with it "
                       f"({agree}): the tolerance verdicts and the recommendation are decided "
                       "on the FPK")
    return out


def _ratio(e: dict[str, float]) -> float:
    return e["L1"] / e["L1_floor"] if e["L1_floor"] > 0 else math.inf


def truth_verdicts(metrics: dict[str, Any], tol: Tolerance) -> dict[str, dict[str, Any]]:
    """{model: the tolerance verdict against the FPK}: the distance with no noise floor, its
    error bar the FPK's discretisation error carried to the metric (L1: itself; KS <= L1 / 2;
    Hellinger <= sqrt(L1 / 2), H^2 <= TV; W1 <= L1 x the observable's range), normal
    quantiles. The bar is an estimate of the error's size, not a standard error."""
    out = {}
    k, o = tol.metric, tol.observable
    for m, entry in metrics["models"].items():
        e = entry.get("truth_error", {}).get(o)
        if e is None or k not in e:
            continue
        disc = e["L1_truth_err"]
        span = _span(metrics, o)
        bar = {"L1": disc, "ks": disc / 2, "hellinger": math.sqrt(disc / 2),
               "w1": disc * span}.get(k, 0.0)
        v = tolerance_verdict({k: e[k], f"{k}_floor": 0.0, f"{k}_err": bar}, tol)
        v["truth"] = "original-fpk"
        out[m] = v
    return out


def _span(metrics: dict[str, Any], o: str) -> float:
    g = metrics.get("truth", {}).get("grid", {})
    if o == "x1":
        return float(g["x"][1] - g["x"][0]) if "x" in g else 0.0
    if o == "x2":
        return float(g["v"][1] - g["v"][0]) if "v" in g else 0.0
    return float(g.get("A_max", 0.0))
