"""Every input checked before any work (issue 11): one pass over the scene, the command-line
options and their combinations, and the output paths, run by the CLI before any computation.

A problem raises :class:`InputError` (a :class:`~vifpk.core.scene.SceneError`): one line that
names the option or field and the allowed range, or the nearest valid values where the code
would otherwise round (paths to whole batches, time to whole samples). The CLI prints it and
exits with code 2; nothing has been computed or written by then.

The checks, and where each bound comes from:

- options that do not apply to the chosen solver or command are refused, not ignored;
- Monte Carlo (the arithmetic of ``montecarlo.plan``, asked through ``run.montecarlo_plan``
  so that it is never restated here): ``paths`` a whole multiple of ``blocks``; ``dt`` a whole
  fraction of ``sample_every`` and below the splitting's linear stability limit
  ``dt omega0 < 2`` (Stormer-Verlet on x'' = -omega0^2 x); ``burn_in`` and ``time`` whole
  numbers of steps and of sampling windows;
- scene magnitudes: a non-zero physical parameter must lie within ``[1e-100, 1e100]`` in
  magnitude; products and squares of such numbers (the averaged coefficients are built from
  them) stay inside double precision (1e-308 .. 1e308), outside it they over- or underflow;
- search ranges inside the parameter's own valid box, finite, LO < HI; repeats >= 1;
- output paths: a file option must not name a directory, a folder option must not name a
  file, and the nearest existing folder must accept a new file (probed with a temporary file
  that is removed at once, the way the atomic writers create theirs);
- cost: a lower-bound estimate of the run's wall time from its size (measured rates); above
  an hour the run is refused unless ``--yes``. An automatic burn-in counts at its minimum up
  front; :func:`run_cost_limit` hands the same hour to the Monte Carlo, which prices the run
  again once its relaxation pilot has measured the burn-in (vifpk.core.result.CostRefused,
  worded by :func:`priced_burn_in`, exit 2);
- physics: a scene whose energy grows without bound at large amplitude has no stationary
  density (:func:`stationary_density`, vifpk.core.scene.energy_balance).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from vifpk.harness.request import cost
from vifpk.harness.request.cost import numba_threads_available
from vifpk.harness.request.errors import InputError

# the output paths' checks (outpaths.py), re-exported: validate.output_file, ...
from vifpk.harness.request.outpaths import (  # noqa: F401
    NAME_BYTES,
    PATH_BYTES,
    STDOUT,
    output_file,
    output_folder,
    outputs_apart_from_inputs,
    run_inputs,
)

from vifpk.core.protocols import show as shown
from vifpk.core.scene import Scene, declared_params
from vifpk.core.scene import section_fields as fields_of

MAGNITUDE = (1e-100, 1e100)  # allowed |value| of a non-zero physical parameter (module doc)


#: the physical numbers of the fixed sections; the noise kind's and the walls' laws' come
#: from their declarations (vifpk.core.protocols.Param.physical)
PHYSICAL = {"system": ("c1", "c2", "omega0", "alpha", "mu", "f"),
            "parametric": ("stiffness", "damping")}


REL = 1e-9  # relative slack of "a whole number" tests (far above rounding, far below any step)


# the Monte Carlo options of the CLI and the scene fields they set
MC_OPTIONS = {"paths": "paths", "dt": "dt", "time": "time", "seed": "seed", "floor": "floor",
              "budget": "budget"}


MAX_STEPS_PER_SAMPLE = 1e9  # time steps between two samples of a path (dt >= sample_every/1e9)


def observables(scene: Scene) -> None:
    """At least one observable of the simulation switched on."""
    from dataclasses import fields

    obs = scene.observables
    if not obs.names():  # the schema's own list (energy included), not a copy of it
        raise InputError("observables: every observable is off, so the simulation would "
                         "compute nothing; allowed: at least one of " + ", ".join(
                             f"observables.{f.name}" for f in fields(obs)) + " = true")


def environment() -> None:
    """Environment variables the solvers read: NUMBA_NUM_THREADS a whole number >= 1."""
    env = os.environ.get("NUMBA_NUM_THREADS")
    if env is not None and not (env.strip().isdigit() and int(env) >= 1):
        raise InputError(f"NUMBA_NUM_THREADS={env}: out of range; allowed: a whole number >= 1 "
                         "(or unset: every core)")


def threads(scene: Scene) -> None:
    """montecarlo.threads within what numba can start (0: all of them)."""
    n, most = scene.montecarlo.threads, numba_threads_available()
    if n > most:
        raise InputError(f"montecarlo.threads = {n} is out of range; allowed: 0 (all) to "
                         f"{most} (the threads numba may start here: NUMBA_NUM_THREADS or the "
                         "cores)")


# --------------------------------------------------------------------------------------------
# options that do not apply
def refuse_options(given: Iterable[str], why: str) -> None:
    """Raise naming the first of ``given`` (option names without dashes); ``why`` says when
    they would apply."""
    names = [g for g in given]
    if names:
        opts = ", ".join(f"--{n.replace('_', '-')}" for n in names)
        raise InputError(f"{opts}: does not apply {why}")


def duplicate_overrides(overrides: Sequence[str]) -> None:
    """``--set`` given twice for the same key is refused (the last would silently win), and so
    are two ``--set`` that reach one coefficient of a law under different spellings
    (``system.alpha`` and ``system.restoring[1]``, or a whole ``system.restoring`` and any of
    its coefficients): a scene file refuses both spellings of one law the same way."""
    from vifpk.core.scene import shared_term

    seen: dict[str, str] = {}
    for text in overrides:
        key = text.partition("=")[0].strip()
        if key in seen:
            raise InputError(f"--set {key}: given twice ({seen[key]!r} and {text!r}); give each "
                             "key once")
        seen[key] = text
    clash = shared_term(list(seen))
    if clash is not None:
        earlier, key, law = clash
        raise InputError(f"--set {key}: sets the {law} law's coefficient that {seen[earlier]!r} "
                         "already sets (two spellings of one term); give it once")


# --------------------------------------------------------------------------------------------
# scene magnitudes
def scene_magnitudes(scene: Scene) -> None:
    """Non-zero physical parameters within MAGNITUDE (see the module docstring)."""
    lo, hi = MAGNITUDE
    for sec, key, v in _physical(scene):
        if v != 0.0 and not lo <= abs(v) <= hi:
            if "_wall." in key:  # a wall's position or yield speed (0 is the wall at 0)
                raise InputError(f"{sec}.{key} = {shown(v)} is out of range; allowed: "
                                 f"{'0 or ' * key.endswith('.at')}{lo:g} <= "
                                 f"|{key.split('.')[-1]}| <= {hi:g} (beyond, the "
                                 "model's coefficients over- or underflow double precision)")
            if "[" in key:
                raise InputError(f"{sec}.{key} = {v:g} is out of range; allowed: 0 or "
                                 f"{lo:g} <= |coefficient| <= {hi:g} (beyond, the model's "
                                 "coefficients over- or underflow double precision)")
            zero = _field(scene, sec, key).metadata["check"](0.0) is None  # 0 allowed?
            raise InputError(f"{sec}.{key} = {v:g} is out of range; allowed: "
                             f"{'0 or ' if zero else ''}{lo:g} <= "
                             f"|{key.rpartition('.')[2]}| <= {hi:g} "
                             "(beyond, the model's coefficients over- or underflow double "
                             "precision)")


def stationary_density(scene: Scene) -> None:
    """A scene whose energy grows without bound has no stationary density: refused before any
    work, naming the fields (vifpk.core.scene.energy_balance derives the large-amplitude
    balance; a tie of gains and losses at the top degree is left to the solvers)."""
    from vifpk.core.scene import energy_balance

    bal = energy_balance(scene.system, scene.parametric)
    if not bal.grows:
        return
    bounds = bal.tail.bounds if bal.tail is not None else {}
    for key, top in bounds.items():  # vifpk.core.energy: each intensity's bound, the other held
        value = getattr(scene.parametric, key.split(".")[1])
        raise InputError(f"{key} = {value:g} is out of range for this scene; allowed: 0 <= "
                         f"{key} < {top:.4g} (above it {bal.text})")
    if bal.gains:
        allowed = (f"a loss of a degree above A^{bal.degree} (e.g. a positive damping or "
                   "velocity_damping term of higher degree), or no gain at that degree")
    else:
        allowed = ("a damping or velocity_damping law whose leading term is > 0, "
                   "system.mu > 0, or system.r < 1 with the barrier")
    raise InputError(f"system: no stationary density: {bal.text}; allowed: {allowed}")


def law_in_reach(scene: Scene) -> None:
    """A parametric scene whose averaged law has a power-law tail (vifpk.core.energy
    ``parametric_tail``: wall-free or one wall) is solved only where that law falls by e^60
    before A = 1e4: the closed form's scan stops there and the FPK's domain ends there, and
    the Monte Carlo's paths follow the tail to amplitudes where its step is unstable (issue
    45: paper-base with D_k = 0.08, kappa = 1.03, failed in all three after work). The
    request asks the door for the closed form's own scan of the exact model's law
    (``door.reach.law_reach``), before any solver runs, and refuses in one line naming the
    intensity that breaks it: each intensity set to 0 alone, the one whose removal lets the
    law fall (both when neither alone does). It covers both ways to fail: a law that exists
    but whose tail E^-kappa is too heavy for the grid (kappa > 1 is not enough: paper-base
    needs D_k < ~0.025 against kappa > 1's 1/12), and no stationary law strictly (the noise
    outgrows every loss beyond a crossover energy) with no metastable law below the
    crossover either (the law does not fall by e^60 before it: systems/quintic with D_k =
    0.01); where it does (systems/offset-parametric) the scene is solved as metastable, the
    cut-off stated (vifpk.core.energy.tail_note)."""
    from vifpk.harness.door.reach import law_reach

    from vifpk.core.energy import KEYS, parametric_tail

    tail = parametric_tail(scene.system, scene.parametric)
    if tail is None:
        return
    found = law_reach(scene)
    if found is None or found[0]:
        return
    keys = [k for k in KEYS.values() if getattr(scene.parametric, k.split(".")[1])]
    blamed = [k for k in keys if len(keys) == 1
              or (law_reach(scene.with_values({k: 0.0})) or (True,))[0]] or keys
    named = " with ".join(f"{k} = {getattr(scene.parametric, k.split('.')[1]):g}"
                          for k in blamed)
    law = f"the averaged energy's law decays as E^-{tail.kappa:.3g} at large E"
    allowed = f"a smaller {' or '.join(blamed)}"
    if tail.normalisable:
        why = (f"{law}: a law exists, but its tail is too heavy for the solvers: it falls by "
               f"only e^{found[1]:.3g} of the e^60 the closed form's and the FPK's grids need "
               "before A = 1e4")
        # the fall over the tail scales with its slope in ln A, beta = q (kappa - 1) + 1: the
        # slope that makes e^60 of e^fall, and the intensity whose kappa gives it (an estimate)
        beta = tail.q * (tail.kappa - 1) + 1
        top = (tail.bound(blamed[0], 1 + (beta * 60 / found[1] - 1) / tail.q)
               if len(blamed) == 1 and found[1] > 0 and tail.q else None)
        if top is not None and 0 < top < getattr(scene.parametric, blamed[0].split(".")[1]):
            allowed = (f"0 <= {blamed[0]} < ~{top:.2g} (estimated: where the tail's slope in "
                       f"ln A, q (kappa - 1) + 1, is 60 / {found[1]:.3g} times today's)")
    else:
        where = f"beyond E ~ {tail.crossover:.3g}" if tail.crossover else "at large amplitude"
        why = (f"no stationary law: the parametric noise outgrows every loss {where} ({law}), "
               f"and the law below that energy falls by only e^{found[1]:.3g} before it, so "
               "it is no metastable law either (the closed form needs e^60)")
    raise InputError(f"{named} is out of range for this scene: {why}; allowed: {allowed}")


def _physical(scene: Scene) -> list[tuple[str, str, float]]:
    """(section, key, value) of every physical number the scene gives: the PHYSICAL keys it
    sets and each coefficient of a law given as a list ("restoring[2]")."""
    out = []
    for sec, keys in PHYSICAL.items():
        obj = getattr(scene, sec)
        for key in keys:
            v = getattr(obj, key)
            if v is not None:
                out.append((sec, key, float(v)))
    for law in ("restoring", "damping", "velocity_damping"):
        for i, c in enumerate(getattr(scene.system, law)):
            out.append(("system", f"{law}[{i}]", float(c)))
    for w in getattr(scene.system, "walls", ()):  # a wall's position is a length like any
        out.append(("system", f"{w.side}_wall.at", float(w.at)))
    out += [(sec, key, value) for sec, key, param, value in declared_params(scene)
            if param.physical]
    return out


def _field(scene: Scene, sec: str, key: str) -> Any:
    found = [p for s, k, p, _ in declared_params(scene) if (s, k) == (sec, key)]
    return found[0] if found else fields_of(sec)[key]


def finite_result(result: Any, scene: Scene) -> None:
    """Never report NaN as a result: every density and summary number of a solver result
    must be finite, else SolverFailure naming the scene's most extreme magnitude."""
    import numpy as np
    from vifpk.harness.door.solvers import SolverFailure

    for key, d in result.data.items():
        p = d.get("p") if isinstance(d, dict) else None
        if p is not None and not np.all(np.isfinite(np.asarray(p, dtype=float))):
            raise SolverFailure(f"the density of {key} is not finite: the solver failed "
                                f"numerically; likely cause: {most_extreme(scene)}")
    summary = result.info.get("summary", {}) if isinstance(result.info, dict) else {}
    bad = [k for k, v in summary.items() if isinstance(v, float) and not math.isfinite(v)]
    if bad:
        raise SolverFailure(f"the {bad[0]} of the density is not finite: the solver failed "
                            f"numerically; likely cause: {most_extreme(scene)}")


def most_extreme(scene: Scene) -> str:
    """'noise.D = 1e-90 (the scene's most extreme magnitude)': the field to look at first
    when a run fails numerically (farthest from 1 in log10 among the non-zero parameters)."""
    best, name, value = -1.0, "", 0.0
    for sec, key, v in _physical(scene):
        if v != 0.0 and abs(math.log10(abs(v))) > best:
            best, name, value = abs(math.log10(abs(v))), f"{sec}.{key}", v
    return f"{name} = {value:g} (the scene's most extreme magnitude)"


# --------------------------------------------------------------------------------------------
# Monte Carlo settings
def _name(field: str, options: Mapping[str, str]) -> str:
    """'--paths (montecarlo.paths)' when the value came from an option, else the field."""
    opt = options.get(field)
    return f"{opt} (montecarlo.{field})" if opt else f"montecarlo.{field}"


def _whole(ratio: float) -> bool:
    k = round(ratio)
    return k >= 1 and abs(ratio - k) <= REL * max(ratio, 1.0)


def _g(v: float) -> str:
    return f"{v:.10g}"


def montecarlo_settings(scene: Scene, options: Mapping[str, str] | None = None) -> None:
    """The Monte Carlo settings the simulation would otherwise round or fail on.

    ``options``: scene field -> the option that set it (for the message)."""
    from vifpk.harness.door.solvers import montecarlo_plan

    options = options or {}
    mc = scene.montecarlo
    if mc.paths < mc.blocks or mc.paths % mc.blocks:
        lo = max(mc.paths // mc.blocks, 2) * mc.blocks
        near = sorted({lo, lo + mc.blocks} if mc.paths > 2 * mc.blocks else {lo})
        raise InputError(f"{_name('paths', options)} = {mc.paths} must be a whole multiple of "
                         f"montecarlo.blocks = {mc.blocks} (the batches of the error bars); "
                         f"nearest valid: {' or '.join(str(n) for n in near)}")
    if mc.paths < 2 * mc.blocks:
        raise InputError(f"{_name('paths', options)} = {mc.paths} is too few for montecarlo."
                         f"blocks = {mc.blocks}; allowed: paths >= 2 x blocks = {2 * mc.blocks} "
                         "(the equilibration check's R-hat compares at least two paths of each "
                         "starting amplitude)")
    observables(scene)
    threads(scene)
    if mc.dt != "auto" and 0 < float(mc.dt) < mc.sample_every / MAX_STEPS_PER_SAMPLE:
        raise InputError(f"{_name('dt', options)} = {_g(float(mc.dt))} is too small; allowed: "
                         f"dt >= montecarlo.sample_every / {MAX_STEPS_PER_SAMPLE:g} = "
                         f"{_g(mc.sample_every / MAX_STEPS_PER_SAMPLE)}")
    plan = montecarlo_plan(scene)
    h = plan.dt
    w0 = math.sqrt(scene.system.restoring_law[0])  # the small-amplitude frequency
    if h * w0 >= 2.0:
        raise InputError(f"{_name('dt', options)} = {_g(h)} is too large for this scene; "
                         f"allowed: dt < 2 / omega0 = {_g(2.0 / w0)} (the splitting's "
                         "stability limit)")
    ratio = mc.sample_every / h
    if not _whole(ratio):
        k = math.floor(ratio)
        near = [mc.sample_every / n for n in (k + 1, k) if n >= 1]
        raise InputError(f"{_name('dt', options)} = {_g(h)} must divide montecarlo."
                         f"sample_every = {_g(mc.sample_every)} into whole steps; nearest valid: "
                         + " or ".join(_g(v) for v in near))
    step_bias_within(scene, h, options)
    if mc.burn_in != "auto":
        b = float(mc.burn_in) / h
        if b > 0 and not _whole(b):
            k = math.floor(b)
            raise InputError(f"montecarlo.burn_in = {_g(float(mc.burn_in))} is not a whole "
                             f"number of steps of dt = {_g(h)}; nearest valid: "
                             f"{_g(k * h)} or {_g((k + 1) * h)}")
    step = plan.sample_interval
    if mc.time < step * (1 - REL):
        raise InputError(f"{_name('time', options)} = {_g(mc.time)} is shorter than one "
                         f"sampling interval; allowed: time >= {_g(step)}")
    if mc.floor <= 0 and abs(plan.sampled_time - mc.time) > REL * mc.time:
        near = " or ".join(_g(v) for v in plan.nearest_times)
        raise InputError(f"{_name('time', options)} = {_g(mc.time)} would sample "
                         f"{_g(plan.sampled_time)} (whole windows of whole samples every "
                         f"{_g(step)}); nearest valid: {near}")
    if mc.floor > 0 and mc.budget > 0:
        least = cost._montecarlo_least_seconds(scene)
        if mc.budget < least:
            raise InputError(f"{_name('budget', options)} = {_g(mc.budget)} s cannot cover the "
                             "pilots, the burn-in and the first sampling windows (at least "
                             f"{least:.2g} s here, a lower bound from their path-steps); "
                             f"allowed: at least {least:.2g} s, or 0 for no limit")
    refuse_unreachable_floor(scene, options)


def step_bias_within(scene: Scene, h: float, options: Mapping[str, str]) -> None:
    """A step given (not "auto") whose bias by the step rule's model (montecarlo/tuning.py
    ``predicted_bias``, asked through the door) reaches SMALL_L1, the bound of the smallest
    error class a check reports, is refused: the Monte Carlo's own L1 bias of p(A) would be
    of the size of the model errors it judges (issue 45: --dt 0.5 on bilateral-duffing,
    predicted 0.23, reported the step's bias as "exact model: LARGE +124%" in a passage
    whose error at dt 0.01 is -7% +- 10%). The model is the envelope of the bias curves
    measured on unlike scenes; a scene's own bias may be smaller, so the refusal sits at a
    bias the check would call moderate, not at the floor."""
    from vifpk.harness.door.reach import step_bias, step_limit

    from vifpk.core.defaults import SMALL_L1

    if scene.montecarlo.dt == "auto":
        return
    bias = step_bias(scene, h)
    if bias >= SMALL_L1:
        top = step_limit(scene, SMALL_L1, h)
        raise InputError(f"{_name('dt', options)} = {_g(h)} is too coarse for this scene: the "
                         f"step rule's model puts the Monte Carlo's own L1 bias of p(A) at "
                         f"{bias:.2g}, at least {SMALL_L1:g} (an error a check would blame on "
                         f"the models); allowed: dt < {top:.3g} (montecarlo/tuning.py)")


def search_range(vary: str, lo: float, hi: float, field: Any) -> None:
    """``--range LO HI``: finite, LO < HI, both inside the parameter's valid box."""
    check = field.metadata["check"]
    for name, v in (("LO", lo), ("HI", hi)):
        problem = check(v)
        if problem is not None:
            raise InputError(f"--range {_g(lo)} {_g(hi)}: {name} = {_g(v)} is outside the valid "
                             f"values of system.{vary}; allowed: {problem}")
    if not lo < hi:
        raise InputError(f"--range {_g(lo)} {_g(hi)}: LO must be below HI")


def at_least(option: str, value: int | float | None, lo: float, hi: float = math.inf) -> None:
    """A whole-number option in [lo, hi] (InputError naming it and the range)."""
    if value is not None and not (math.isfinite(value) and lo <= value <= hi):
        allowed = f">= {lo:g}" if hi == math.inf else f"from {lo:g} to {hi:g}"
        raise InputError(f"{option} {value}: out of range; allowed: a whole number {allowed}")


def refuse_unreachable_floor(scene: Scene, options: Mapping[str, str] | None = None) -> None:
    """A target floor the budget cannot reach even at the fastest rate is refused up front
    (the run would stop at its budget, the floor not reached)."""
    from vifpk.harness.door.solvers import montecarlo_plan

    mc = scene.montecarlo
    if not (mc.floor > 0 and mc.budget > 0):
        return
    cores = mc.threads or min(numba_threads_available(), os.cpu_count() or 1)
    h = montecarlo_plan(scene).dt
    seconds = mc.paths * cost.floor_time(scene) / h / (cost.MC_STEPS_PER_CORE * cores)
    if seconds > mc.budget:
        names = options or {}
        raise InputError(f"{_name('floor', names)} = {mc.floor:g}: needs at least {seconds:.3g}"
                         f" s of sampling at dt = {h:g}, more than {_name('budget', names)} = "
                         f"{mc.budget:g} s allows; "
                         "raise the floor or the budget (0: no limit, then the cost limit "
                         "applies)")
