"""The check's verdicts: how large each model's error is, what causes it, which model to trust.

The classes of an L1 (indistinguishable < 2 x floor <= small < SMALL_L1 <= moderate <
LARGE_L1 <= large), the dominant cause of an error (a part of the decomposition 3 x every
other: DOMINANCE), the sampling check of an averaged SDE, and the recommendation
(docs/report.md). Split from check.py (issue 27).
"""

from __future__ import annotations

import math
from typing import Any

from vifpk.harness.workflows.assumptions import ADVISORY, ASSUMPTION_KINDS, WALL_MAX

from vifpk.core.result import WarningRecord

SAMPLING_FACTOR = 2.5


from vifpk.core.defaults import SMALL_L1  # noqa: E402  (at most 5% of the mass misplaced)

LARGE_L1 = 0.3  # at least 15% of the probability mass misplaced


def _sampling_ok(e: dict[str, float]) -> bool:
    """The averaged-SDE Monte Carlo of a model is within its noise of the model's closed form:
    L1 <= 2.5 x the L1 noise floor (the floor is the expected L1 of noise alone; the SDE's own
    weak bias at dt = 0.01 is far below it, docs/montecarlo.md)."""
    return bool(e["L1"] <= SAMPLING_FACTOR * e["L1_floor"])


def sampling_failures(errors: dict[str, dict[str, float]]) -> list[str]:
    """The observables (of p(A), p(x1), p(x2), in ``errors``' order) on which an averaged SDE's
    Monte Carlo is off the model's closed form beyond its noise (:func:`_sampling_ok`): every
    observable the check compares, not p(A) alone (issue 45: x1 and x2 drawn on the wrong
    orbit carried sampling errors of 0.04-0.22 while p(A) passed)."""
    return [o for o, e in errors.items() if not _sampling_ok(e)]


def sampling_words(model: str, errors: dict[str, dict[str, float]]) -> str:
    """Why the sampling check of ``model`` failed, in words ('' when it did not)."""
    bad = sampling_failures(errors)
    return "; ".join(
        f"the Monte Carlo of the {model} averaged SDE is off its closed form on p({o}) by "
        f"L1 = {errors[o]['L1']:.3f}, beyond {SAMPLING_FACTOR} x its noise floor "
        f"{errors[o]['L1_floor']:.3f}" for o in bad)


def _evidence(conv: dict[str, Any], sampling: dict[str, dict[str, dict[str, float]]]
              ) -> list[str]:
    """Reasons, from the runs' own evidence, to think the Monte Carlo is too short:
    ``sampling`` maps a model to its sampling errors by observable."""
    out = []
    if conv.get("equilibrated") is False:
        out.append(conv.get("reason") or "the equilibration certificate failed")
    for m, errors in sampling.items():
        if words := sampling_words(m, errors):
            out.append(words)
    return out


# Verdict classes of the averaging error L1(A) (docs/report.md, "Verdict classes").
# L1 runs from 0 (identical densities) to 2 (disjoint); L1 / 2 is the total-variation
# distance, the largest difference in probability the two densities give to any event.
INDISTINGUISHABLE_FACTOR = 2.0  # L1 < 2 x noise floor: cannot be told from zero


DOMINANCE = 3.0  # a cause dominates when it is 3 x every other part of the decomposition


RANK = {"indistinguishable": 0, "small": 1, "moderate": 2, "large": 3}


def observable_class(e: dict[str, Any]) -> str:
    """The class of one observable's averaging error (thresholds above; no convergence or
    assumption test: see :func:`verdict_class`)."""
    l1, floor = e["L1"], e["L1_floor"]
    if l1 < INDISTINGUISHABLE_FACTOR * floor:
        return "indistinguishable"
    return "small" if l1 < SMALL_L1 else ("moderate" if l1 < LARGE_L1 else "large")


def observable_classes(entry: dict[str, Any]) -> dict[str, str]:
    """{observable: class} for every observable the check measured (p(A), p(x1), p(x2))."""
    return {o: observable_class(e) for o, e in entry["averaging_error"].items()}


def worst_observable(entry: dict[str, Any]) -> str:
    """The observable with the worst class (ties: the largest L1 relative to its floor; p(A)
    first when still tied): the one the headline verdict speaks for."""
    errs = entry["averaging_error"]
    per = observable_classes(entry)

    def key(o: str) -> tuple[int, float, bool]:
        e = errs[o]
        ratio = e["L1"] / e["L1_floor"] if e["L1_floor"] > 0 else math.inf
        return RANK[per[o]], ratio, o == "A"

    return max(errs, key=key)


def verdict_class(entry: dict[str, Any], warnings: list[WarningRecord], *,
                  convergence: dict[str, Any] | None = None) -> tuple[str, str]:
    """(class, dominant cause) of one model's averaging error, over EVERY observable measured.

    Class: "not an estimate" only when the distance is not measured (:func:`unmeasured`: the
    Monte Carlo has not converged, or its own checks say the distance is the run's); else the
    worst class among the observables (p(A), p(x1), p(x2)), each "indistinguishable" when
    L1 < 2 x its noise floor, "small" when L1 < 0.1, "moderate" when L1 < 0.3, "large" above.
    A failing averaging assumption does NOT change the class (issue 45: the distance measured
    is the model's error on that scene; independent simulations of three wall scenes agreed
    with it): :func:`assumptions_failing` names it beside the class. Cause: what the
    decomposition of that worst observable says the distance comes from (the averaged model
    itself when its averaging error is 3 x the FPK discretisation and the sampling errors and
    floors), naming the observable when it is not p(A).
    """
    why = unmeasured(entry, warnings, convergence)
    if why:
        return "not an estimate", why
    o = worst_observable(entry)
    e = entry["averaging_error"][o]
    l1, floor = e["L1"], e["L1_floor"]
    # no discretisation part where no FPK was measured: a sweep point (cross_check(fpk=False))
    # or a model without a closed form, whose reference IS its FPK solve; the cause then says
    # "not computed", never a 0 nobody measured (issue 28: "FPK numerics 0.0e+00")
    disc_rec = entry.get("discretisation_error", {}).get(o)
    disc = disc_rec["L1"] if disc_rec else 0.0
    fpk_part = f"FPK numerics {disc:.1e}" if disc_rec else "FPK numerics not computed"
    # without the averaged SDE's Monte Carlo (a sweep point, cross_check(sde=False)) the noise
    # is the floor of the simulation of the original system alone
    samp = entry.get("sampling_error", {}).get(o, {"L1": 0.0, "L1_floor": 0.0})
    noise = max(samp["L1"], samp["L1_floor"], floor)
    cls = observable_class(e)
    where = "" if o == "A" else f" (on p({o}), the worst observable)"
    if cls == "indistinguishable":
        return cls, "Monte Carlo noise (the distance is at its floor)"
    if l1 >= DOMINANCE * max(disc, noise):
        cause = f"the averaged model itself ({fpk_part}, Monte Carlo noise {noise:.1e})"
    elif disc >= DOMINANCE * noise:
        cause = f"the FPK discretisation ({disc:.1e})"
    elif noise >= DOMINANCE * disc:
        cause = f"Monte Carlo noise ({noise:.1e}) as much as the model"
    else:
        cause = "none dominant"
    return cls, cause + where


#: warnings of the run, not of the model, that leave the distance unmeasured (assumptions.py)
RUN_KINDS = ("outside_range", "dt_bias")


def unmeasured(entry: dict[str, Any], warnings: list[WarningRecord],
               convergence: dict[str, Any] | None = None) -> str:
    """Why this model's distance is NOT a measurement of its error ('' when it is): the Monte
    Carlo of the original system has not converged (its certificate), the model's averaged
    SDE is off its closed form (its sampling check: the closed form or the machinery is in
    doubt), the simulation puts its mass outside the range (not converged, or another state),
    or its step check found a bias (the distance would be the step's). Nothing else: a failing
    averaging assumption leaves the distance measured (:func:`assumption_words`)."""
    conv = convergence or {}
    if conv.get("equilibrated") is False:
        return "the simulation has not converged: " + (conv.get("reason")
                                                        or "the certificate failed")
    if entry.get("sampling_ok") is False:
        return "the simulation has not converged: " + (entry.get("sampling_reason")
                                                        or "the averaged-SDE check failed")
    run = [w for w in warnings if w.kind in RUN_KINDS]
    if run:
        return "the run's own check failed (" + ", ".join(w.title for w in run) + ")"
    return ""


def assumptions_failing(warnings: list[WarningRecord]) -> list[WarningRecord]:
    """The averaging assumptions that fail here (the warnings that are not ADVISORY, nor
    diagnostics of the run): said beside a verdict's class, never instead of it."""
    return [w for w in warnings if w.kind in ASSUMPTION_KINDS and w.kind not in ADVISORY]


def assumption_words(warnings: list[WarningRecord]) -> str:
    """'' or the words said beside a class where an averaging assumption fails."""
    failing = assumptions_failing(warnings)
    if not failing:
        return ""
    what = ("an averaging assumption fails" if len(failing) == 1
            else "averaging assumptions fail")
    return (f"measured where {what} (" + ", ".join(w.title for w in failing)
            + ", see warnings): this is the model's error on this scene, not a trend beyond it")


def verdict(model: str, entry: dict[str, Any], warnings: list[WarningRecord], *,
            convergence: dict[str, Any] | None = None) -> str:
    """One line: the class (the worst over the observables), the averaging error of p(A) with
    its error bar, what it means against the noise floor and against the 0..2 scale of L1,
    every other observable's error and class, and the dominant cause."""
    e = entry["averaging_error"]["A"]
    cls, cause = verdict_class(entry, warnings, convergence=convergence)
    ratio = e["L1"] / e["L1_floor"] if e["L1_floor"] > 0 else math.inf
    line = (f"{model} model: {cls.upper()} -- L1(A) = {e['L1']:.3f} +/- {e['L1_err']:.3f} "
            f"against the original system, {ratio:.1f} x its MC noise floor "
            f"{e['L1_floor']:.3f}; on the 0-2 scale of L1, {50 * e['L1']:.1f}% of the "
            f"probability mass is misplaced (KS {e['ks']:.3f}, mean shift "
            f"{e['mean_diff']:+.3f})")
    per = observable_classes(entry)
    others = []
    for o, eo in entry["averaging_error"].items():
        if o == "A":
            continue
        r = eo["L1"] / eo["L1_floor"] if eo["L1_floor"] > 0 else math.inf
        others.append(f"p({o}) {per[o]} (L1 {eo['L1']:.3f}, {r:.1f} x floor)")
    if others:
        line += f"; p(A) {per['A']}, " + ", ".join(others)
    if cls == "not an estimate":
        line += (" -- NOT an estimate of the averaging error: "
                 + unmeasured(entry, warnings, convergence))
    elif cls == "indistinguishable":
        line += " -- indistinguishable from the original system at this sample size"
    else:
        line += f"; dominant cause: {cause}"
    if cls != "not an estimate" and (words := assumption_words(warnings)):
        line += f" -- {words}"
    return line


# ------------------------------------------------------------------ which model to trust
#: the order of preference between models a paired comparison cannot tell apart (the derived
#: O(eps) terms first), said as such; any checked model whose error is measured is a candidate
RECOMMENDABLE = ("corrected", "exact")

#: said of every recommendation: it reads the stationary densities only (issue 45: corrected's
#: MFPT far in the tail can be off where its p(A) is the best, docs/passage.md)
STATIONARY = ("; this is about the stationary law (p(A), p(x1), p(x2)): first-passage times "
              "and transients are checked by vifpk passage and vifpk transient")


def pair(metrics: dict[str, Any], a: str, b: str) -> dict[str, Any]:
    """The paired comparison of models a and b (compare.paired: metric(a) - metric(b) against
    the same Monte Carlo sample, with the error bar of the DIFFERENCE) from
    ``metrics["paired"]``; without it (canned or older metrics) the two distances' own bars
    combined as if independent, which overstates the bar where both share the noise."""
    tol = metrics.get("tolerance") or {}
    k, o = tol.get("metric", "L1"), tol.get("observable", "A")
    table = metrics.get("paired") or {}
    for pr in table.get("pairs", []) if (table.get("metric"), table.get("observable")) == (
            k, o) else []:
        if (pr["a"], pr["b"]) == (a, b):
            return pr
        if (pr["a"], pr["b"]) == (b, a):
            return {**pr, "a": a, "b": b, "diff": -pr["diff"]}
    ea, eb = (metrics["models"][m]["averaging_error"][o] for m in (a, b))
    return {"a": a, "b": b, "diff": ea[k] - eb[k], "dof": None, "paired": False,
            "diff_err": math.hypot(ea.get(f"{k}_err", 0.0), eb.get(f"{k}_err", 0.0))}


def apart(pr: dict[str, Any], confidence: float) -> bool:
    """Whether the paired difference is told from 0 at the (two-sided) confidence: |diff| >
    t x its error bar (Student's t with the jackknife's dof; normal without). A noise-free
    truth (error bar 0) tells any non-zero difference."""
    from vifpk.harness.workflows.tolerance import _quantile

    z = _quantile(0.5 + confidence / 2, pr.get("dof"))
    return abs(pr["diff"]) > z * pr["diff_err"]


def floor_to_tell(pr: dict[str, Any], floor: float, confidence: float) -> float:
    """The Monte Carlo noise floor at which a difference as large as the one measured would be
    told apart: the error bar and the floor both scale as 1 / sqrt(samples), so the floor
    needed is floor x |diff| / (t x diff_err) (0 when the difference is 0: no floor tells
    identical distances apart)."""
    from vifpk.harness.workflows.tolerance import _quantile

    z = _quantile(0.5 + confidence / 2, pr.get("dof"))
    if pr["diff_err"] <= 0 or pr["diff"] == 0:
        return 0.0
    return floor * abs(pr["diff"]) / (z * pr["diff_err"])


def _pair_words(pr: dict[str, Any]) -> str:
    k = "paired" if pr.get("paired", True) else "unpaired (bars combined)"
    return f"{pr['a']} - {pr['b']} = {pr['diff']:+.4f} +/- {pr['diff_err']:.4f} ({k})"


def recommend(metrics: dict[str, Any], warnings: list[WarningRecord], val: dict[str, Any], *,
              convergence: dict[str, Any] | None = None) -> tuple[str, str]:
    """(model, one line): the averaged model to trust for this scene and why, or "none".

    The recommendation follows the tolerance verdict (harness/workflows/tolerance.py; the
    question is ``metrics["tolerance"]``, default L1(A) <= 0.02 at 95%): (1) the Monte Carlo of
    the original system must have converged, else "none"; a model whose averaged-SDE check
    failed is no candidate; (2) of the models checked (plugins and ``paper`` included: the
    measured error decides, not the name), the ones INSIDE the tolerance at the stated
    confidence are the candidates; with none inside, the undecided ones more likely within than
    not (P >= 1/2) are, *provisionally* (a longer run decides); "none" when neither exists;
    (3) between candidates the lowest error wins only where a PAIRED comparison on the same
    Monte Carlo sample tells it from the others (:func:`pair`, :func:`apart`: the difference
    of their distances with the jackknife bar of the difference, at the tolerance's
    confidence); the candidates it cannot tell from the best are a tie, and the line says so,
    with the floor that would tell them apart (:func:`floor_to_tell`); the model then named is
    by the declared order (RECOMMENDABLE: ``corrected``, then ``exact``; ``exact`` where
    corrected's wall term is outside its derivation, delta / E > WALL_MAX at the 10% energy),
    said as an order, not as a measured preference. Failing assumptions are advice, not a
    veto. Every line names the tolerance and says it is about the stationary law.
    """
    from vifpk.harness.request.tolerance import Tolerance
    from vifpk.harness.workflows.tolerance import tolerance_verdict

    conv = convergence or {}
    head = "recommended model: "
    models = metrics["models"]
    tol = Tolerance(**metrics["tolerance"]) if "tolerance" in metrics else Tolerance()
    used = f"tolerance {tol.words()}"
    if conv.get("equilibrated") is False:
        return "none", (head + f"none -- the Monte Carlo has not converged, so no model's error "
                        f"is measured here ({used})")
    measured = [m for m in models if tol.observable in models[m].get("averaging_error", {})]
    cand = [m for m in measured if models[m].get("sampling_ok") is not False]
    if not cand:
        why = ("the averaged-SDE check of every model failed" if measured
               else "no model's averaging error was measured")
        return "none", (head + f"none -- {why}, so no model's error is measured here "
                        f"({used})")
    tv = {m: models[m].get("tolerance") or tolerance_verdict(
        models[m]["averaging_error"][tol.observable], tol) for m in cand}
    desc = ", ".join(f"{m} {tv[m]['error_estimate']:.3f} (P = "
                     f"{tv[m]['p_within_tolerance']:.2f}, {tv[m]['class']})" for m in cand)
    floor = max(tv[m]["floor"] for m in cand)
    failing = assumptions_failing(warnings)
    advisory = [w for w in warnings if w.kind in ADVISORY]
    advice = ""
    if failing:
        advice = ("; advice: " + ", ".join(w.title for w in failing) + " -- the averaging "
                  "assumptions fail here, so this measured error holds for this scene, not as "
                  "a trend beyond it (see warnings)")
    if advisory:
        advice += ("; expect the error to grow in the correlated-noise regime (see warnings)")
    inside = [m for m in cand if tv[m]["class"] == "inside"]
    likely = [m for m in cand if tv[m]["class"] == "undecided"
              and tv[m]["p_within_tolerance"] >= 0.5]
    pool = inside or likely
    if not pool:
        undecided = [m for m in cand if tv[m]["class"] == "undecided"]
        more = (f"; {' and '.join(undecided)} undecided: a longer run (a smaller floor) "
                "decides" if undecided else "")
        return "none", (head + f"none -- no model is within the {used} (error estimates with "
                        f"the noise removed: {desc}; floor {floor:.3f}){more}{advice}"
                        f"{STATIONARY}")
    est = {m: tv[m]["error_estimate"] for m in pool}
    best = min(pool, key=lambda m: (est[m], tv[m]["measured"]))
    pairs = {m: pair(metrics, best, m) for m in pool if m != best}
    tied = [best] + [m for m in pool if m != best and not apart(pairs[m], tol.confidence)]
    wall = (val.get("wall") or [0.0])[0]  # at the 10% energy, where delta / E is largest
    if len(tied) == 1:
        pick = best
        vs = ("; nearer than " + ", ".join(
            f"{m} by a paired comparison on the same sample ({_pair_words(pairs[m])})"
            for m in pairs)) if pairs else ""
    else:
        # a tie: the declared order names one, and the line says that it is the order
        pick = min(tied, key=lambda m: (RECOMMENDABLE.index(m) if m in RECOMMENDABLE
                                        else len(RECOMMENDABLE), est[m]))
        order = f"{pick} keeps the most derived terms"
        if {"exact", "corrected"} <= set(tied) and wall > WALL_MAX:
            pick = "exact"
            order = (f"corrected's energy-at-the-wall term is outside its derivation here "
                     f"(delta/E = {wall:.2f} at the 10% energy > {WALL_MAX:g})")
        elif pick == "corrected":
            order = "corrected keeps the derived O(eps) impact terms"
        need = max(floor_to_tell(pairs[m], floor, tol.confidence) for m in tied if m != best)
        tell = (f"a noise floor of about {need:.2g} (now {floor:.3f}, "
                f"{(floor / need) ** 2:.0f} x the samples) would tell a difference that large "
                "apart" if need > 0 else "their distances are equal, so no floor tells them "
                "apart")
        vs = (f"; {' and '.join(tied)} cannot be told apart on this sample: they agree within "
              "the noise of a paired comparison ("
              + "; ".join(_pair_words(pairs[m]) for m in tied if m != best)
              + f"); {tell}; {pick} is named by the declared order ({order}), not by a "
              "measured difference")
    if pick == "exact" and "corrected" in cand and wall > WALL_MAX and len(tied) == 1:
        vs += (f"; corrected's energy-at-the-wall term is outside its derivation here "
               f"(delta/E = {wall:.2f} at the 10% energy > {WALL_MAX:g})")
    if inside:
        why = (f"within the {used} (error estimates with the noise removed: {desc}; floor "
               f"{floor:.3f}){vs}")
    else:
        why = (f"provisionally: no model is within the {used} at this sample size, and "
               f"{pick}'s error is more likely within it than not (error estimates with the "
               f"noise removed: {desc}; floor {floor:.3f}){vs}; a longer run (a smaller "
               "floor) decides")
    return pick, head + f"{pick} -- {why}{advice}{STATIONARY}"
