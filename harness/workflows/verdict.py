"""The check's verdicts: how large each model's error is, what causes it, which model to trust.

The classes of an L1 (indistinguishable < 2 x floor <= small < SMALL_L1 <= moderate <
LARGE_L1 <= large), the dominant cause of an error (a part of the decomposition 3 x every
other: DOMINANCE), the sampling check of an averaged SDE, and the recommendation
(docs/report.md). Split from check.py (issue 27).
"""

from __future__ import annotations

import math
from typing import Any

from vifpk.harness.workflows.assumptions import ADVISORY, WALL_MAX

from vifpk.core.result import WarningRecord

SAMPLING_FACTOR = 2.5


SMALL_L1 = 0.1  # at most 5% of the probability mass misplaced
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

    Class: "not an estimate" when the Monte Carlo has not converged or an averaging assumption
    fails (the distance is then not an approximation error); else the worst class among the
    observables (p(A), p(x1), p(x2)), each "indistinguishable" when L1 < 2 x its noise floor,
    "small" when L1 < 0.1, "moderate" when L1 < 0.3, "large" above. Cause: what the
    decomposition of that worst observable says the distance comes from (the averaged model
    itself when its averaging error is 3 x the FPK discretisation and the sampling errors and
    floors), naming the observable when it is not p(A).
    """
    conv = convergence or {}
    if conv.get("equilibrated") is False or entry.get("sampling_ok") is False:
        return "not an estimate", "the Monte Carlo has not converged"
    failing = [w for w in warnings if w.kind not in ADVISORY]
    if failing:
        names = [w.title for w in failing]
        return "not an estimate", "failing averaging assumptions (" + ", ".join(names) + ")"
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
    conv = convergence or {}
    if cls == "not an estimate" and (conv.get("equilibrated") is False
                                     or entry.get("sampling_ok") is False):
        line += (" -- the simulation has not converged, so this is NOT an estimate of the "
                 "averaging error: " + (conv.get("reason") or entry.get("sampling_reason")
                                        or "the averaged-SDE check failed"))
    elif cls == "not an estimate":
        line += (" -- NOT an estimate of an approximation error: the averaging assumptions do "
                 "not hold here (see warnings)")
    elif cls == "indistinguishable":
        line += " -- indistinguishable from the original system at this sample size"
    else:
        line += f"; dominant cause: {cause}"
    return line


# ------------------------------------------------------------------ which model to trust
#: the order of preference between models whose errors agree within the noise (the derived
#: O(eps) terms first); any checked model whose error is measured is a candidate
RECOMMENDABLE = ("corrected", "exact")


def recommend(metrics: dict[str, Any], warnings: list[WarningRecord], val: dict[str, Any], *,
              convergence: dict[str, Any] | None = None) -> tuple[str, str]:
    """(model, one line): the averaged model to trust for this scene and why, or "none".

    The recommendation follows the tolerance verdict (harness/workflows/tolerance.py; the question
    is
    ``metrics["tolerance"]``, default L1(A) <= 0.02 at 95%): (1) the Monte Carlo of the original
    system must have converged, else "none"; a model whose averaged-SDE check failed is no
    candidate; (2) of the models checked (plugins and ``paper`` included: the measured error
    decides, not the name), the ones INSIDE the tolerance at the stated confidence are
    candidates, and the one with the lowest error estimate (noise removed) is recommended;
    models within the noise floor of the lowest are tied, and a tie goes to the model with the
    most derived terms (RECOMMENDABLE's order: ``corrected``, then ``exact``), except that
    ``corrected`` yields to ``exact`` where its wall-energy term is outside its derivation over
    the bulk of p(E) (delta / E above WALL_MAX at the 10% energy); (3) "none" only when no model
    is inside, saying which are undecided (a longer run decides) and which outside; with no
    model inside, the best undecided one whose P(error <= tolerance) is at least 1/2 is
    recommended *provisionally* (the line says so: more likely within than not, not yet at the
    confidence). Warnings no longer veto a model whose measured error is small: they are named
    as advice (the assumptions that fail here, so the measured error holds for this scene, not
    as a trend). The line names the tolerance used.
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
    failing = [w for w in warnings if w.kind not in ADVISORY]
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
    if not inside and likely:
        pick = min(likely, key=lambda m: tv[m]["error_estimate"])
        return pick, (head + f"{pick} -- provisionally: no model is within the {used} at this "
                      f"sample size, and {pick}'s error is more likely within it than not "
                      f"(error estimates with the noise removed: {desc}; floor {floor:.3f}); "
                      f"a longer run (a smaller floor) decides{advice}")
    if not inside:
        undecided = [m for m in cand if tv[m]["class"] == "undecided"]
        more = (f"; {' and '.join(undecided)} undecided: a longer run (a smaller floor) "
                "decides" if undecided else "")
        return "none", (head + f"none -- no model is within the {used} (error estimates with "
                        f"the noise removed: {desc}; floor {floor:.3f}){more}{advice}")
    wall = (val.get("wall") or [0.0])[0]  # at the 10% energy, where delta / E is largest
    est = {m: tv[m]["error_estimate"] for m in inside}
    best = min(est.values())
    tied = {m for m in inside if est[m] - best <= floor}  # equal within the noise
    if {"exact", "corrected"} <= tied:
        if wall > WALL_MAX:
            pick = "exact"
            why = (f"exact and corrected are both within the {used} and agree within the "
                   f"noise ({desc}; floor {floor:.3f}); corrected's energy-at-the-wall term is "
                   f"outside its derivation here (delta/E = {wall:.2f} at the 10% energy > "
                   f"{WALL_MAX:g})")
        else:
            pick = "corrected"
            why = (f"exact and corrected are both within the {used} and agree within the "
                   f"noise ({desc}; floor {floor:.3f}); corrected keeps the derived O(eps) "
                   "impact terms")
    else:
        # within the noise of each other, a model with the derived O(eps) terms first
        pick = min(tied, key=lambda m: (RECOMMENDABLE.index(m) if m in RECOMMENDABLE
                                        else len(RECOMMENDABLE), est[m]))
        why = (f"within the {used}, lowest error estimate with the noise removed ({desc}; "
               f"floor {floor:.3f})" if len(tied) == 1 else
               f"within the {used}; {', '.join(sorted(tied))} agree within the noise "
               f"({desc}; floor {floor:.3f}) and {pick} keeps the most derived terms")
        if pick == "exact" and "corrected" in cand and wall > WALL_MAX:
            why += (f"; corrected's energy-at-the-wall term is outside its derivation here "
                    f"(delta/E = {wall:.2f} at the 10% energy > {WALL_MAX:g})")
    return pick, head + f"{pick} -- {why}{advice}"
