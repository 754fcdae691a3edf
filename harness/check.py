"""The three-way cross-check of one scene: how wrong is each averaged model, and why.

For each averaged model M (``paper``, ``exact``, ``corrected``) on the observables A, x1, x2:

    discretisation_error  FPK(M) against the closed form of M         (numerics of the FPK)
    sampling_error        MC of M's averaged SDE against M's closed form (MC noise + bias)
    averaging_error       MC of the ORIGINAL system against M's closed form (the answer)

Every metric against an MC histogram carries its noise floor and error bar (compare.py).
**The simulation of the original system does not know which models are checked** (issue 29):
its histogram ranges come from its own scale pilot (montecarlo.simulate, the range every
``solve --solver montecarlo`` uses), its burn-in from its own relaxation pilot, its extensions
from its own equilibration certificate, so the same seed gives the same numbers for a model
whatever else is checked. The averaged SDEs' runs share its edges (bin by bin comparisons);
each is seeded from the root seed and the model's *name* (:func:`sde_seed`) and extended on its
own evidence only.
"""

from __future__ import annotations

import math
import sys
import time
import zlib
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from vifpk.core import registry
from vifpk.core.defaults import CHECK_MODELS, DENSITY_OBSERVABLES, FPK_CELLS
from vifpk.core.result import WarningRecord

from .compare import compare
from .run import (
    averaged_sde_solution,
    closed_form,
    energy_rates,
    fpk_solution,
    montecarlo_solution,
    validity,
)
from .tolerance import Tolerance, model_verdicts
from .tolerance import line as tolerance_line

OBSERVABLES = DENSITY_OBSERVABLES


def models_of(scene: Any, models: tuple[str, ...] = CHECK_MODELS
              ) -> tuple[tuple[str, ...], dict[str, str]]:
    """Of ``models`` (registered names; default CHECK_MODELS), the ones that apply to the
    scene's system, and why each other one does not (each model's own ``applies``:
    vifpk.core.registry.applicable)."""
    return registry.applicable(scene, tuple(models))


@dataclass(frozen=True)
class CheckResult:
    scene: Any
    solutions: dict[str, Any]  # name -> Result(data, info)
    metrics: dict[str, Any]
    warnings: list[WarningRecord]
    verdicts: list[str]
    provenance: dict[str, Any] | None = None  # harness.provenance.collect(); set by the writer
    recommendation: str = ""  # one line: the model to trust here and why (recommend())
    models: tuple[str, ...] = CHECK_MODELS  # the averaged models checked, in report order
    tolerance_lines: tuple[str, ...] = ()  # per model: the tolerance verdict (tolerance.line)


class _Stages:
    """Progress on the terminal: one line a stage, with its time."""

    def __init__(self, total: int, quiet: bool):
        self.total, self.quiet, self.i = total, quiet, 0
        self.t = self.start = time.perf_counter()
        self.name = ""
        self.label = ""
        self.seconds: dict[str, float] = {}  # stage -> wall seconds (metrics.json "timings")

    def _end(self, now: float) -> None:
        """The stage's time; on a terminal the label is written again from the line's start
        ("\r"), since a progress bar drawn on the same line (the Monte Carlo's) erases it
        when it closes."""
        again = f"\r{self.label}" if sys.stderr.isatty() else ""
        print(f"{again} {now - self.t:.1f} s", file=sys.stderr, flush=True)

    def __call__(self, name: str) -> None:
        now = time.perf_counter()
        if self.i:
            self.seconds[self.name] = self.seconds.get(self.name, 0.0) + now - self.t
            if not self.quiet:
                self._end(now)
        self.i += 1
        self.t, self.name = now, name
        self.label = f"[{self.i}/{self.total}] {name} ..."
        if not self.quiet:
            print(self.label, end="", file=sys.stderr, flush=True)

    def done(self) -> None:
        now = time.perf_counter()
        if self.i:
            self.seconds[self.name] = self.seconds.get(self.name, 0.0) + now - self.t
        if not self.quiet and self.i:
            self._end(now)


def mc_edges_of(mc: Any) -> dict[str, np.ndarray]:
    """The histogram edges of a Monte Carlo run of the original system (its own, from its
    scale pilot: they depend on the scene, the step and the seed, never on a model), for the
    averaged SDEs' runs that are compared with it bin by bin."""
    return {"edges_A": np.asarray(mc.data["A"]["edges"]),
            "edges_x": np.asarray(mc.data["x1"]["edges"]),
            "edges_v": np.asarray(mc.data["x2"]["edges"])}


def sde_seed(root: int, model: str) -> int:
    """The root seed of the Monte Carlo of ``model``'s averaged SDE: the first word of
    numpy.random.SeedSequence([root, crc32(name)]), so a function of the scene's seed and the
    model's name alone, never of its place in the list of models checked."""
    ss = np.random.SeedSequence([int(root), zlib.crc32(model.encode())])
    return int(ss.generate_state(1, dtype=np.uint32)[0])


#: The kinds of warning check writes (WarningRecord.kind): code acts on the kind (the
#: sweep's flags, advisory or not), people read the text.
#: Of them, the averaging assumptions that fail (assumption_warnings; the sweep's map flags);
#: "outside_range" is a diagnostic of the run, not of the model.
ASSUMPTION_KINDS = ("strong_damping", "narrow_band", "sticking", "strong_noise",
                    "correlated_noise")
WARNING_KINDS = (*ASSUMPTION_KINDS, "outside_range")


#: advisory kinds: the averaging assumptions hold, but the measured O(eps) remainder of the
#: averaged models is beyond the target there (docs/report.md, "Warnings"); the verdicts stay
#: estimates and check still recommends a model
ADVISORY = ("correlated_noise",)


def mean_amplitude(scene: Any, closed: dict[str, Any], mc_info: dict[str, Any]) -> float:
    """The mean amplitude the warnings are evaluated at: the simulation's measured one when
    there is a simulation (the truth, and the same whatever models are checked), else the
    exact averaged model's (computed here when it is not among ``closed``), else 1."""
    mean = mc_info.get("moments", {}).get("A", {}).get("mean", {}).get("value")
    if mean is not None and math.isfinite(mean) and mean > 0:
        return float(mean)
    if "exact" in closed:
        return float(closed["exact"].info["summary"]["mean"])
    try:
        return float(closed_form(scene, model="exact", tail_mass=False).info["summary"]["mean"])
    except Exception:  # noqa: BLE001 - no exact density here: the warnings' scale is then 1
        return 1.0


def assumption_warnings(scene: Any, closed: dict[str, Any], mc_info: dict[str, Any],
                        val: dict[str, Any] | None = None) -> list[WarningRecord]:
    """Records (kind, sentence) naming each averaging assumption that clearly fails here.

    Stochastic averaging needs (i) weak damping and weak noise relative to the restoring
    force (quasi-conservative: the energy changes little over one period), (ii) a noise
    correlation time short against the relaxation of the amplitude (wide-band noise), and
    (iii) motion that oscillates rather than sticks, at the mean amplitude
    (:func:`mean_amplitude`). ``val``: the scene's validity numbers
    over the bulk of p(E) (run.validity); the narrow-band test uses alpha1 / Omega(E) there
    (at the mean amplitude without them). Thresholds: docs/report.md, "Warnings".
    """
    n = scene.noise
    out = []
    A = mean_amplitude(scene, closed, mc_info)
    rates = energy_rates(scene, A)
    T, E = rates["T"], rates["E"]
    w = 2 * math.pi / T
    # the energy rate of each effect in magnitude: on a limit cycle the linear feed and the
    # cubic damping cancel on average, yet each changes the energy within the cycle
    parts = {k: rates.get(k, 0.0) for k in ("linear damping", "cubic damping",
                                             "velocity damping", "impacts", "friction")}
    rate = sum(parts.values()) / E
    if rate * T > 0.5:
        main = max(parts, key=lambda k: parts[k])
        out.append(WarningRecord(
            "strong_damping",
            f"strong damping: at the mean amplitude {A:.3g} the energy changes by "
            f"{rate * T:.2f} of itself per period (mostly {main}), so the energy is not "
            "nearly conserved over one cycle, which averaging assumes"))
    band = (val or {}).get("band")
    if n.kind == "ou" and band is not None and min(band) < BAND_MIN:
        lo, hi = min(band), max(band)
        out.append(WarningRecord(
            "narrow_band",
            f"narrow-band noise: bandwidth alpha1 = {n.alpha1:g} is {lo:.2g}-{hi:.2g} x "
            "the oscillation frequency over the bulk of p(E) (10%-90% energies), below "
            f"{BAND_MIN:g}; the noise is not wide-band against the oscillation, which the "
            "Stratonovich-Khasminskii limit requires"))
    elif n.kind == "ou" and band is None and n.alpha1 < BAND_MIN * w:
        out.append(WarningRecord(
            "narrow_band",
            f"narrow-band noise: bandwidth alpha1 = {n.alpha1:g} is below {BAND_MIN:g} x "
            f"the oscillation frequency ({w:.3g}) at the mean amplitude; the noise is not "
            "wide-band against the oscillation, which the Stratonovich-Khasminskii limit "
            "requires"))
    corr = (val or {}).get("correlation")
    if corr is not None and corr[1] > CORRELATION_MAX:
        out.append(WarningRecord(
            "correlated_noise",
            f"correlated noise: over one correlation time 1/alpha1 the noise changes the "
            f"energy by {100 * math.sqrt(corr[1]):.0f}% (rms) at the median energy "
            f"(sigma_E^2 / (alpha1 E^2) = {corr[1]:.3f} > {CORRELATION_MAX:g}); there the "
            "better of exact and corrected was measured at L1(A) = 0.017-0.066, against at "
            "most 0.028 below the threshold (docs/report.md)"))
    stuck = mc_info.get("events", {}).get("stuck_fraction", {}).get("value", 0.0)
    if stuck > 0.1:
        out.append(WarningRecord(
            "sticking",
            f"sticking-dominated motion: the mass is stuck {100 * stuck:.0f}% of the time "
            "in the simulation; averaging over free oscillations does not describe it"))
    if A > 0:
        ratio = rates["sigma2_E"] * T / E**2
        if ratio > 0.5:
            out.append(WarningRecord(
                "strong_noise",
                f"strong noise: over one period the noise changes the energy by "
                f"{100 * math.sqrt(ratio):.0f}% (rms) at the mean amplitude; averaging "
                "assumes it changes little"))
    return out


def cross_check(scene: Any, *, quiet: bool = False, fpk: bool = True, sde: bool = True,
                tail_mass: bool = True, models: tuple[str, ...] = CHECK_MODELS,
                tolerance: Tolerance | None = None) -> CheckResult:
    """Run every solver on a concrete scene and compute the error decomposition.

    ``models``: registered averaged models (vifpk.core.registry), in report order (those that
    do not apply to the scene are named in ``models_absent``); the Monte Carlo of model i's
    averaged SDE is seeded with the scene's seed + 1 + i. A model with no closed form (a
    plugin giving only drift and diffusion) has the FPK direct solve as its reference
    density (harness.run.closed_form), so no FPK is measured against it (no
    ``discretisation_error``; its entry holds ``reference`` instead).

    ``fpk=False`` skips the FPK of each model (no ``discretisation_error``): a sweep point
    needs only the averaging error, and the FPK is the costliest part of a check.
    ``sde=False`` skips the Monte Carlo of each averaged SDE (no ``sampling_error``, and
    ``sampling_ok`` is None): it checks the closed forms and the Monte Carlo machinery against
    each other, not the averaging error, so a sweep makes it at a few sampled points only
    (harness/sweep.py); without it only the equilibration certificate can ask for an
    extension. ``tail_mass=False`` skips the closed forms' measurement of the mass beyond
    their grids (a diagnostic of the closed form, about half its cost). ``tolerance``: the
    question of the tolerance verdict (harness/tolerance.py; default Tolerance(): L1 of p(A)
    <= 0.02 at 95%): each model's entry gets ``tolerance`` (its estimate with the noise
    removed, interval, P(error <= tolerance), class), and the recommendation follows it.
    """
    tol = tolerance if tolerance is not None else Tolerance()
    models, absent = models_of(scene, models)
    # closed forms, the original system's Monte Carlo and the metrics; FPK and SDE per model
    stages = _Stages(3 + len(models) * (int(fpk) + int(sde)), quiet)
    sol: dict[str, Any] = {}
    closed = {}
    stages("averaged models (closed forms)")
    for m in models:
        closed[m] = closed_form(scene, model=m, tail_mass=tail_mass)
        sol[f"closed:{m}"] = closed[m]
    # the FPK of a model measured against its closed form (none: nothing to measure against)
    with_fpk = [m for m in models if fpk and closed[m].info.get("closed_form", True)]
    stages.total -= len(models) - len(with_fpk) if fpk else 0
    for m in with_fpk:
        stages(f"FPK of the {m} model")
        sol[f"fpk:{m}"] = fpk_solution(scene, model=m, cells=FPK_CELLS)
    # the original system's simulation: its ranges, burn-in and extensions are its own
    t_mc = time.perf_counter()
    budget = scene.montecarlo.budget or math.inf
    extensions = 0
    run_scene = scene
    while True:
        stages("Monte Carlo of the original system" + (f" (extended x{2 ** extensions})"
                                                       if extensions else ""))
        mc = montecarlo_solution(replace(run_scene, observables=replace(
            run_scene.observables, A=True, x1=True, x2=True, events=True, moments=True)),
            progress=not quiet)
        st = mc.info["settings"]
        bad = _evidence(mc.info.get("convergence", {}), {})
        spent = time.perf_counter() - t_mc
        # extend (twice the burn-in and the sampled time) while the certificate says the run
        # is too short and the budget allows another run of twice the cost
        if not bad or extensions >= 3 or spent * 3 > budget - spent:
            break
        extensions += 1
        stages.total += 1
        mcs = run_scene.montecarlo
        run_scene = replace(run_scene, montecarlo=replace(
            mcs, time=2 * st["time"], burn_in=2 * st["burn_in"], dt=st["dt"], floor=0.0))
    sol["mc:original"] = mc
    edges = mc_edges_of(mc)
    sde_extensions = {}
    for m in models if sde else ():
        sol[f"mc:{m}"], sde_extensions[m] = _sde_run(
            scene, m, closed[m], edges, st, run_scene.montecarlo.burn_in, budget, stages)
    stages("metrics")
    metrics: dict[str, Any] = {"models": {}}
    if absent:
        metrics["models_absent"] = dict(absent)
    for m in models:
        cf = closed[m].data
        entry: dict[str, Any] = {}
        for kind, key in (("discretisation_error", f"fpk:{m}"), ("sampling_error", f"mc:{m}"),
                          ("averaging_error", "mc:original")):
            if key in sol:
                entry[kind] = {o: compare(cf[o], sol[key].data[o]) for o in OBSERVABLES}
        entry["sampling_ok"] = (_sampling_ok(entry["sampling_error"]["A"])
                                if "sampling_error" in entry else None)
        if m in sde_extensions:
            entry["sampling_extensions"] = sde_extensions[m]
        if not closed[m].info.get("closed_form", True):
            entry["reference"] = closed[m].info["method"]
        metrics["models"][m] = entry
    conv = dict(mc.info.get("convergence", {}))
    conv["extensions"] = extensions
    if bad:
        conv["equilibrated"] = False
        conv["reason"] = "; ".join(bad)
    val = validity(scene)
    warnings = assumption_warnings(scene, closed, mc.info, val)
    outside = mc.info.get("events", {}).get("outside_fraction", {})
    worst = max(outside.values(), default=0.0)
    if worst > 1e-3:
        warnings.append(WarningRecord(
            "outside_range",
            f"the simulation of the original system puts {100 * worst:.1f}% of its "
            "samples outside the range where the averaged models hold their mass "
            "(not converged, or a different state altogether); its densities there "
            "are not shown and count toward L1 as one cell beyond the range"))
    verdicts = [verdict(m, metrics["models"][m], warnings, convergence=conv) for m in models]
    verdicts += [f"{m} model: not checked, {why}" for m, why in absent.items()]
    for m in models:
        cls, cause = verdict_class(metrics["models"][m], warnings, convergence=conv)
        metrics["models"][m]["verdict_class"] = cls
        metrics["models"][m]["verdict_cause"] = cause
        metrics["models"][m]["verdict_by_observable"] = observable_classes(metrics["models"][m])
    metrics["tolerance"] = tol.record()
    tverdicts = model_verdicts(metrics, tol)
    for m, v in tverdicts.items():
        metrics["models"][m]["tolerance"] = v
    stages.done()
    rec_model, rec_line = recommend(metrics, warnings, val, convergence=conv)
    metrics["recommended_model"] = rec_model
    metrics["recommendation"] = rec_line
    metrics["validity"] = val
    metrics["verdicts"] = verdicts
    metrics["warnings"] = [w.text for w in warnings]
    metrics["warning_kinds"] = [w.kind for w in warnings]
    metrics["monte_carlo"] = {k: mc.info[k] for k in ("settings", "effects", "events", "L1_floor",
                                                     "seed", "atoms", "relaxation")
                              if k in mc.info}
    metrics["monte_carlo"]["convergence"] = conv
    # everything that depends on the machine's speed lives under "timings" only, so that the
    # rest of metrics.json is a function of (scene, settings, seed) alone (issue 11.5)
    metrics["timings"] = {
        "wall_seconds": time.perf_counter() - stages.start,
        "stages": stages.seconds,
        "steps_per_second": {name: s.info["steps_per_second"] for name, s in sol.items()
                             if "steps_per_second" in s.info},
        "solutions": {name: s.info["seconds"] for name, s in sol.items()
                      if "seconds" in s.info},
        "threads": mc.info.get("threads"),
    }
    metrics["tolerance_verdicts"] = [tolerance_line(m, v) for m, v in tverdicts.items()]
    return CheckResult(scene=scene, solutions=sol, metrics=metrics, warnings=warnings,
                       verdicts=verdicts, recommendation=rec_line, models=models,
                       tolerance_lines=tuple(metrics["tolerance_verdicts"]))


def _sde_run(scene: Any, model: str, closed: Any, edges: dict[str, np.ndarray],
             st: dict[str, Any], burn_in: Any, budget: float, stages: _Stages
             ) -> tuple[Any, int]:
    """The Monte Carlo of ``model``'s averaged SDE on the original system's edges and sample
    plan (its own step, from its relaxation time: montecarlo.averaged_sde), seeded by
    :func:`sde_seed`; doubled (sampled time and burn-in) while it is off its closed form beyond
    SAMPLING_FACTOR x its floor, at most 3 times and while the budget allows a run of twice
    the cost. Returns (result, extensions): a function of the scene and this model alone."""
    t0 = time.perf_counter()
    ext, time_ = 0, st["time"]
    while True:
        stages(f"Monte Carlo of the {model} averaged SDE"
               + (f" (extended x{2 ** ext})" if ext else ""))
        res = averaged_sde_solution(
            scene, model, edges=edges, seed=sde_seed(scene.montecarlo.seed, model), phase=True,
            paths=st["paths"], blocks=st["blocks"], dt="auto", time=time_, burn_in=burn_in,
            sample_every=st["sample_every"])
        spent = time.perf_counter() - t0
        if (_sampling_ok(compare(closed.data["A"], res.data["A"])) or ext >= 3
                or spent * 3 > budget - spent):
            return res, ext
        ext += 1
        stages.total += 1
        time_ = 2 * res.info["settings"]["time"]
        burn_in = 2 * res.info["settings"]["burn_in"]


def output_problems(result: CheckResult) -> list[str]:
    """What is wrong with a cross-check's output, in words (empty: nothing): a non-finite or
    negative density; a histogram whose mass (the atom of p(x2) at rest counted) is outside
    [0.99, 1] (its mass is 1 minus the samples outside its edges; the report warns from 0.1%
    outside, this bound is loose: its job is finite and normalised); a smooth density whose
    trapezoid mass is off 1 by more than 1e-9; a non-finite metric. Used by
    tests/test_hard_scenes.py and benchmarks/validate_hard_scenes.py."""
    out = []
    for name, sol in result.solutions.items():
        for obs in ("A", "x1", "x2"):
            d = sol.data[obs]
            p = np.asarray(d["p"])
            if not (np.all(np.isfinite(p)) and np.min(p) >= 0):
                out.append(f"{name} {obs}: density not finite or negative")
                continue
            if "edges" in d:
                mass = float(np.sum(p * np.diff(d["edges"]))) + float(d.get("atom_weight", 0))
                if not 0.99 <= mass <= 1.0 + 1e-9:
                    out.append(f"{name} {obs}: histogram mass {mass:.4f}")
            elif abs(np.trapezoid(p, d["x"]) - 1) > 1e-9:
                out.append(f"{name} {obs}: mass {np.trapezoid(p, d['x']):.12f}")
    for m, entry in result.metrics["models"].items():
        for kind in ("discretisation_error", "sampling_error", "averaging_error"):
            for o, e in entry.get(kind, {}).items():
                if not all(math.isfinite(v) for v in e.values()):
                    out.append(f"{m} {kind} {o}: not finite")
    return out


SAMPLING_FACTOR = 2.5


def _sampling_ok(e: dict[str, float]) -> bool:
    """The averaged-SDE Monte Carlo of a model is within its noise of the model's closed form:
    L1 <= 2.5 x the L1 noise floor (the floor is the expected L1 of noise alone; the SDE's own
    weak bias at dt = 0.01 is far below it, docs/montecarlo.md)."""
    return bool(e["L1"] <= SAMPLING_FACTOR * e["L1_floor"])


def _evidence(conv: dict[str, Any], sampling: dict[str, dict[str, float]]) -> list[str]:
    """Reasons, from the runs' own evidence, to think the Monte Carlo is too short."""
    out = []
    if conv.get("equilibrated") is False:
        out.append(conv.get("reason") or "the equilibration certificate failed")
    for m, e in sampling.items():
        if not _sampling_ok(e):
            out.append(f"the Monte Carlo of the {m} averaged SDE is off its closed form by "
                       f"L1 = {e['L1']:.3f}, beyond {SAMPLING_FACTOR} x its noise floor "
                       f"{e['L1_floor']:.3f}")
    return out


# Verdict classes of the averaging error L1(A) (docs/report.md, "Verdict classes").
# L1 runs from 0 (identical densities) to 2 (disjoint); L1 / 2 is the total-variation
# distance, the largest difference in probability the two densities give to any event.
INDISTINGUISHABLE_FACTOR = 2.0  # L1 < 2 x noise floor: cannot be told from zero
SMALL_L1 = 0.1  # at most 5% of the probability mass misplaced
LARGE_L1 = 0.3  # at least 15% of the probability mass misplaced
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
    # a sweep point runs no FPK (cross_check(fpk=False)): no discretisation part then
    disc = entry.get("discretisation_error", {}).get(o, {"L1": 0.0})["L1"]
    # without the averaged SDE's Monte Carlo (a sweep point, cross_check(sde=False)) the noise
    # is the floor of the simulation of the original system alone
    samp = entry.get("sampling_error", {}).get(o, {"L1": 0.0, "L1_floor": 0.0})
    noise = max(samp["L1"], samp["L1_floor"], floor)
    cls = observable_class(e)
    where = "" if o == "A" else f" (on p({o}), the worst observable)"
    if cls == "indistinguishable":
        return cls, "Monte Carlo noise (the distance is at its floor)"
    if l1 >= DOMINANCE * max(disc, noise):
        cause = (f"the averaged model itself (FPK numerics {disc:.1e}, Monte Carlo noise "
                 f"{noise:.1e})")
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
                 "averaging error: " + (conv.get("reason") or "the averaged-SDE check failed"))
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
BAND_MIN = 0.5  # narrow-band warning: alpha1 / Omega(E) below this anywhere in the bulk
WALL_MAX = 0.2  # corrected trusted only while delta / E <= this at the 10% energy
CORRELATION_MAX = 0.045  # advisory: sigma_E^2 / (alpha1 E^2) at the median energy


def recommend(metrics: dict[str, Any], warnings: list[WarningRecord], val: dict[str, Any], *,
              convergence: dict[str, Any] | None = None) -> tuple[str, str]:
    """(model, one line): the averaged model to trust for this scene and why, or "none".

    The recommendation follows the tolerance verdict (harness/tolerance.py; the question is
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
    from .tolerance import Tolerance, tolerance_verdict

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
