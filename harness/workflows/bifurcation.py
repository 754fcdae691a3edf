"""Stochastic P-bifurcation: where the section of the joint PDF at x1 = 0 turns into a crater.

The section is p(0, x2) = 2 p(y, y')|_{y=0} = 2 exp(h(A)) with h = log(p_E / T) and
A = U^{-1}(x2^2 / 2) increasing in |x2|. So the section has a single peak at x2 = 0 exactly
when h decreases on all of A > 0, and a crater (a ring of maxima at |x2| > 0, with or without a
central spike from friction) when h rises somewhere. The **shape criterion** is

    F(parameter) = max_{A > 0} h'(A)        (< 0: one peak;  > 0: crater)

and the critical value is the root of F, found by Brent's method. For the exact model
h' = 2 m_d g / sigma_E^2: a crater appears where the deterministic energy balance m_d turns
positive somewhere, whatever the noise intensity. With alpha = 0 both models give the
closed form mu_c = (pi w0 c / 6) sqrt(4 c / (3 c2)) with c = c1 - (1 - r^2) w0 / pi (exact law)
or c1 - 2 (1 - r) w0 / pi (paper): tests/test_bifurcation.py checks the finder against it.

The Monte Carlo of the original system is then run on both sides of each critical value: its
A-histogram gives h = log(p_A / (g T)) bin by bin with error bars, and the shape is "crater"
when h rises by more than 3 combined standard errors between two bins.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
from vifpk.harness.door.solvers import (
    amplitude_density,
    montecarlo_solution,
    orbit_period,
    restoring_force,
)

from vifpk.core import registry
from vifpk.core.defaults import BIFURCATION_MODELS
from vifpk.core.protocols import Ref, WorkflowSpec

VARIABLES = {"mu": ("system", "mu", (0.0, 0.05)), "r": ("system", "r", (0.9, 1.0))}
PAPER_CLAIMS = {
    "mu": "mu near 0.038 at r = 0.975 (section 5.2; its own Figure 5 spans mu = 0.001-0.008, "
          "so 0.0038 may be meant)",
    "r": "r near 0.968 at mu = 0.001 (section 5.2)",
}
# the parameter each claim holds fixed, and at which value
PAPER_CLAIM_FIXED = {"mu": {"r": 0.975}, "r": {"mu": 0.001}}


def vary_problem(scene: Any, vary: str) -> str | None:
    """None when ``vary`` moves the scene's physics, else why not: ``r`` is the restitution
    of the paper's wall at x = 0, so on a scene whose walls are tables (issue 37) or that has
    no wall (barrier = false) varying it changes nothing (every point is the same system)."""
    system = scene.system
    if vary != "r" or (system.r is not None and system.barrier):
        return None
    walls = ", ".join(f"system.{w.side}_wall" for w in system.walls) or "none: barrier = false"
    return (f"--vary r: r is the restitution of the paper's wall at x = 0 and this scene's "
            f"walls are not that wall ({walls}), so every r would be the same system; "
            "allowed here: --vary mu (or a sweep over system.lower_wall.r)")


def with_param(scene: Any, vary: str, value: float) -> Any:
    section, key, _ = VARIABLES[vary]
    return replace(scene, **{section: replace(getattr(scene, section), **{key: value})})


def shape_index(scene: Any, model: str) -> float:
    """F = max over the support of h'(A) (finite differences of h on the model's grid)."""
    amp = amplitude_density(scene, model)
    slope = np.diff(amp.log_h) / np.diff(amp.A)
    return float(np.max(slope[np.isfinite(slope)]))


def critical_value(scene: Any, model: str, vary: str, lo: float, hi: float, *,
                   xtol: float = 1e-6) -> float | None:
    """Root of the shape criterion in [lo, hi], or None when it does not change sign."""
    def F(v: float) -> float:
        return shape_index(with_param(scene, vary, v), model)

    f_lo, f_hi = F(lo), F(hi)
    if not (math.isfinite(f_lo) and math.isfinite(f_hi)) or f_lo * f_hi > 0:
        return None
    from scipy.optimize import brentq  # here: the command line imports this module to list it

    return float(brentq(F, lo, hi, xtol=xtol))


def mc_shape(scene: Any, *, z: float = 3.0) -> dict[str, Any]:
    """The section's shape in the Monte Carlo of the original system (from p_A)."""
    sc = replace(scene, observables=replace(scene.observables, A=True, x1=False, x2=False,
                                            joint=False, moments=False, events=True))
    res = montecarlo_solution(sc, progress=False)
    d = res.data["A"]
    A, p, err = d["x"], d["p"], d["err"]
    ok = (p > 5 * err) & (A > 0)
    g = restoring_force(A[ok], scene.system.restoring_law)
    T = orbit_period(A[ok], scene.system.restoring_law)
    h = np.log(p[ok] / (g * T))
    se = err[ok] / p[ok]
    # the largest significant rise h_j - h_i (i < j), in units of the combined error
    best = -math.inf
    for i in range(h.size - 1):
        rise = (h[i + 1:] - h[i]) / np.sqrt(se[i + 1:] ** 2 + se[i] ** 2)
        best = max(best, float(np.max(rise)))
    return {"shape": "crater" if best > z else "single peak", "max_rise_in_se": best,
            "bins_used": int(ok.sum())}


def bifurcation(scene: Any, vary: str, *, lo: float | None = None, hi: float | None = None,
                models: tuple[str, ...] | None = None, mc: bool = True,
                offset: float = 0.1) -> dict[str, Any]:
    """Critical values for each model and, optionally, the MC shape on both sides of each.
    ``models``: by default BIFURCATION_MODELS, without ``paper`` outside the paper model's
    family (System.paper_family_problem)."""
    if models is None:
        models = registry.applicable(scene, BIFURCATION_MODELS)[0]
    if vary not in VARIABLES:
        raise ValueError(f"--vary must be one of {sorted(VARIABLES)}")
    if vary_problem(scene, vary) is not None:
        from vifpk.core.result import BadInput

        raise BadInput(vary_problem(scene, vary))
    d_lo, d_hi = VARIABLES[vary][2]
    lo = d_lo if lo is None else lo
    hi = d_hi if hi is None else hi
    out: dict[str, Any] = {"vary": vary, "range": [lo, hi], "critical": {},
                           "criterion": "max_{A>0} d/dA log p(y, y') = 0",
                           "paper_claim": PAPER_CLAIMS[vary]}
    other = "r" if vary == "mu" else "mu"
    out["fixed"] = {other: getattr(scene.system, other),
                    **{k: v for k, v in scene.system.to_dict().items()
                       if k not in (*VARIABLES, "barrier")},
                    "D": scene.noise.D, "alpha1": scene.noise.alpha1, "noise": scene.noise.kind}
    claim_at = PAPER_CLAIM_FIXED[vary]
    out["paper_claim_fixed"] = claim_at
    outside = scene.system.paper_family_problem()
    if outside is not None:  # the claim is about the paper's system only: not shown here
        out.update(paper_claim=None, paper_claim_comparable=False,
                   paper_claim_note=f"the paper's claim is about its own system; this scene is "
                                    f"outside it ({outside})")
        claim_at = {}
    differs = {k: v for k, v in claim_at.items()
               if not isinstance(out["fixed"].get(k), float)
               or not math.isclose(out["fixed"][k], v)}
    out["paper_claim_comparable"] = not differs and outside is None
    if differs:
        out["paper_claim_note"] = (
            "the paper's claim holds " + ", ".join(f"{k} = {v:g}" for k, v in differs.items())
            + ", this run holds " + ", ".join(
                f"{k} = {out['fixed'][k]:g}" if isinstance(out["fixed"].get(k), float)
                else f"{k} not set (a law given as a list)" for k in differs)
            + ": the two critical values answer different questions (compare with --set "
            + " ".join(f"system.{k}={v:g}" for k, v in differs.items()) + ")")
    for m in models:
        out["critical"][m] = critical_value(scene, m, vary, lo, hi)
    if mc:
        out["mc_check"] = [_mc_check(scene, vary, v, models) for v in
                           check_points(list(out["critical"].values()), lo, hi, offset)]
        bad = [c for c in out["mc_check"] if not all(c["agrees"].values())]
        if bad:
            out["mc_disagreement"] = (
                "the Monte Carlo of the original system DISAGREES with a model's side at "
                + "; ".join(_disagreement(vary, c) for c in bad)
                + ": that model's critical value is not confirmed")
    return out


def check_points(critical: list[float | None], lo: float, hi: float, offset: float
                 ) -> list[float]:
    """One point on each side of every distinct critical value, at offset x (hi - lo) from it
    but never beyond half the way to an end of the range (so never at an end itself)."""
    span = offset * (hi - lo)
    points: list[float] = []
    for c in sorted(c for c in critical if c is not None):
        for v in (c - min(span, 0.5 * (c - lo)), c + min(span, 0.5 * (hi - c))):
            if v not in (lo, hi) and all(abs(v - q) > 0.25 * span for q in points):
                points.append(v)
    return sorted(points)


def _mc_check(scene: Any, vary: str, v: float, models: tuple[str, ...]) -> dict[str, Any]:
    s = with_param(scene, vary, v)
    pred = {k: ("crater" if shape_index(s, k) > 0 else "single peak") for k in models}
    shape = mc_shape(s)
    agree = [k for k in models if pred[k] == shape["shape"]]
    disagree = [k for k in models if pred[k] != shape["shape"]]
    if not disagree:
        words = f"the Monte Carlo agrees with every model: {shape['shape']}"
    else:
        words = (f"the Monte Carlo shows a {shape['shape']} and DISAGREES with the "
                 + " and ".join(f"{k} model ({pred[k]})" for k in disagree)
                 + (f"; it agrees with the {' and '.join(agree)} model" if agree else ""))
    return {"value": v, "predicted": pred, "monte_carlo": shape, "agrees": {
        k: k in agree for k in models}, "words": words}


def _disagreement(vary: str, chk: dict[str, Any]) -> str:
    wrong = [k for k, ok in chk["agrees"].items() if not ok]
    preds = ", ".join(f"{k} model predicts a {chk['predicted'][k]}" for k in wrong)
    return f"{vary} = {chk['value']:.4g} ({preds}; the MC shows a {chk['monte_carlo']['shape']})"


# ------------------------------------------------------------------ the workflow's record
#: ``vifpk bifurcation`` (vifpk.core.protocols.Workflow), registered in pyproject.toml's
#: ``vifpk.workflows``. Its command line (harness/cli) and sweep point (harness/sweeps) are
#: named by Ref, imported when used: the registry does not depend on the layers above this one.
SPEC = WorkflowSpec(
    "bifurcation", "find the critical mu or r of the P-bifurcation of "
    "each averaged model and check it by Monte Carlo",
    add_arguments=Ref("vifpk.harness.cli.arguments:bifurcation_arguments"),
    command=Ref("vifpk.harness.cli.commands:cmd_bifurcation"),
    sweep_point=Ref("vifpk.harness.sweeps.points:bifurcation_point"))
