"""The time domain's requests: one typed, frozen request per workflow, built and checked once.

:class:`PassageRequest` (``vifpk passage``) and :class:`TransientRequest` (``vifpk transient``)
are built by :func:`passage_request` and :func:`transient_request` from a concrete scene (the
``--set`` and Monte Carlo options applied: ``prepare.concrete``, ``prepare.with_mc_options``)
and the workflow's values, by every front end alike: the command line (harness/cli/
timedomain.py), ``vifpk.passage`` / ``vifpk.transient`` (vifpk/api.py), the sweep points
(harness/sweeps/timesweep.py) and the testing API (harness/testing.py). A bad value is refused
here, before any work, in one line naming the option by its command-line flag and the allowed
range (InputError: exit 2 on the command line, BadInput from the Python API); the same bad input
gets the same line from every front end.

The step of every time-domain run is the door's one rule (``door.timedomain.time_step``):
the scene's montecarlo.dt, or for "auto" the field's default step; the request's scene carries
it resolved. :func:`with_quadratures` adds the averaged models' MFPTs (the Pontryagin
quadrature, milliseconds) that price a run; the workflow reuses them instead of computing them
again.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from vifpk.harness.request import validate
from vifpk.harness.request.errors import InputError

from vifpk.core.defaults import CHECK_MODELS
from vifpk.core.scene import Scene, no_noise

#: the two-parameter relaxation fit a(t) = a_inf + (A0 - a_inf) exp(-t / tau) needs at least
#: three snapshot times (two parameters and one degree of freedom to judge the fit)
MIN_FIT_TIMES = 3
METHODS = ("auto", "direct", "splitting")
#: the most independent groups a splitting run may use (door.timedomain.passage_splitting's
#: max_groups: its sequential stop adds groups up to this many)
SPLITTING_MAX_GROUPS = 400
TIMES_ALLOWED = f"at least {MIN_FIT_TIMES} times > 0 in strictly increasing order"
#: the time domain's default precision (issue 39 item 5; harness/workflows/precision.py says
#: why, docs/passage.md "Precision" measures it): the target relative standard error of the
#: original system's MFPT (passage) and of its relaxation time (transient), and the paths cap
#: as a multiple of the first unit (the scene's montecarlo.paths)
REL_SE_MFPT = 0.045  # 0.1 / (2 x 1.1): a +/-10% error is 2 error bars (precision.py)
REL_SE_RELAXATION = 0.045
MAX_PATHS_FACTOR = 16
REL_SE_ALLOWED = "a number 0 < R < 1"  # --rel-se's range, as the errors and the help say it


@dataclass(frozen=True)
class PassageRequest:
    """First passage out of A < threshold (harness/workflows/passage.py), checked.

    ``scene``: concrete, montecarlo.dt resolved (time_step); ``models``: registered names or
    objects with the averaged-model protocol, once each; ``horizon``, ``paths``: None for the
    plan's defaults; ``at``: mission times T at which R(T) is reported (``--at``);
    ``particles``, ``groups``: splitting's replicas per AMS run and independent repetitions
    (None: the door's defaults, 200 and 20); ``quadratures``: {model label: fpk.mfpt's
    record} once priced (:func:`with_quadratures`); ``rel_se``, ``max_paths``: the target
    relative standard error of the original system's MFPT and the paths cap the paths grow to
    (harness/workflows/precision.py; both None: exactly ``paths`` or the scene's paths)."""

    scene: Scene
    threshold: float
    start: float | str = "stationary"
    models: tuple[Any, ...] = CHECK_MODELS
    horizon: float | None = None
    paths: int | None = None
    sde: bool = True
    method: str = "auto"
    at: tuple[float, ...] = ()
    particles: int | None = None
    groups: int | None = None
    rel_se: float | None = None
    max_paths: int | None = None
    quadratures: Mapping[str, Any] | None = field(default=None, compare=False)

    @property
    def dt(self) -> float:
        return float(self.scene.montecarlo.dt)


@dataclass(frozen=True)
class TransientRequest:
    """The law of A at ``times`` from a start at amplitude ``start``
    (harness/workflows/transient.py), checked; fields as :class:`PassageRequest`'s."""

    scene: Scene
    start: float
    times: tuple[float, ...]
    models: tuple[Any, ...] = CHECK_MODELS
    paths: int | None = None
    sde: bool = True
    rel_se: float | None = None
    max_paths: int | None = None

    @property
    def dt(self) -> float:
        return float(self.scene.montecarlo.dt)


# ------------------------------------------------------------------------------- helpers
def real(option: str, value: Any, allowed: str) -> float:
    """``value`` as a float, or InputError naming the option (the Python API passes values as
    they come: a text or a list where a number belongs is refused, not a TypeError)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{option} {value!r}: not a number; allowed: {allowed}")
    return float(value)


def flag(option: str, value: Any) -> bool:
    """A true/false option (``sde``): a bool, nothing else ("no" is not False)."""
    if not isinstance(value, bool):
        raise InputError(f"{option} {value!r}: not true or false; allowed: True, False")
    return value


#: the smallest non-zero amplitude a time-domain question may name: the 1e-100 of every
#: physical number (request/validate.py MAGNITUDE)
TINY_AMPLITUDE = validate.MAGNITUDE[0]


def amplitude_ok(scene: Scene, option: str, value: float) -> None:
    """A finite amplitude > 0 inside the oscillation domain: the restoring force g(A) > 0 on
    (0, A] (a softening spring's potential well ends where g turns back), and U(A) finite."""
    import numpy as np
    from vifpk.harness.door.solvers import potential_energy, restoring_force

    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{option} {value:g}: out of range; allowed: a finite amplitude > 0")
    if value < TINY_AMPLITUDE:
        raise InputError(f"{option} {value:g}: out of range; allowed: an amplitude >= "
                         f"{TINY_AMPLITUDE:g} (the magnitude rule of every length: below it "
                         "the averaged drift and diffusion over- or underflow)")
    with np.errstate(all="ignore"):
        u = float(potential_energy(scene, value))
    if not math.isfinite(u):
        raise InputError(f"{option} {value:g}: beyond the domain: its energy U(A) overflows a "
                         "double; allowed: an amplitude whose energy is finite")
    grid = np.linspace(value / 1000.0, value, 1000)
    with np.errstate(all="ignore"):
        g = np.asarray(restoring_force(grid, tuple(scene.system.restoring_law)), float)
    if not np.all(np.isfinite(g) & (g > 0)):
        edge = float(grid[np.argmax(~(np.isfinite(g) & (g > 0)))])
        raise InputError(f"{option} {value:g}: beyond the domain of oscillation (the restoring "
                         f"force vanishes near A = {edge:.4g}); allowed: 0 < A < {edge:.4g}")


def time_scene(scene: Scene) -> Scene:
    """The scene with montecarlo.dt resolved by the door's one rule (time_step); a scene
    without noise is a numerical dead end (SolverFailure: nothing passes or relaxes)."""
    from vifpk.harness.door.solvers import SolverFailure
    from vifpk.harness.door.timedomain import time_step

    if scene.montecarlo.dt == "auto":
        scene = scene.with_values({"montecarlo.dt": time_step(scene)})
    if no_noise(scene.system):
        raise SolverFailure(f"{no_noise(scene.system)}; nothing passes or relaxes "
                            "stochastically, nothing to check")
    return scene


def models_of(scene: Scene, models: Any, option: str = "--model") -> tuple[Any, ...]:
    """The models asked for: None gives the check models (those that do not apply are
    reported by the workflow); named ones must be registered and apply to the scene (one line
    otherwise); objects with the averaged-model protocol pass as they are."""
    from vifpk.harness.request.prepare import applicable_models, model_names

    if models is None:
        applicable_models(scene, CHECK_MODELS, chosen=False, option=option)
        return CHECK_MODELS
    if isinstance(models, str) or not isinstance(models, list | tuple):
        model_names(models, option)  # refused: one line
    if len(models) == 0:
        from vifpk.core import registry

        raise InputError(f"{option} {list(models)!r}: no model given; allowed: one or more "
                         f"of {', '.join(registry.model_names())}")
    for m in models:
        if not isinstance(m, str) and not callable(getattr(m, "drift", None)):
            raise InputError(f"{option} {m!r}: not a model; allowed: a registered model's name "
                             "or an object with the averaged-model protocol (drift(A), "
                             "diffusion(A): docs/testing.md)")
    named = tuple(m for m in models if isinstance(m, str))
    if named:
        model_names(list(named), option)
        applicable_models(scene, tuple(dict.fromkeys(named)), chosen=True, option=option)
    return tuple(dict.fromkeys(models))


def _paths(paths: Any) -> int | None:
    if paths is None:
        return None
    if isinstance(paths, bool) or not isinstance(paths, numbers.Integral):
        raise InputError(f"--paths {paths!r}: not a whole number; allowed: a whole multiple "
                         "of montecarlo.blocks")
    return int(paths)


def precision(scene: Scene, *, paths: int | None, rel_se: Any, max_paths: Any,
              default: float) -> tuple[float | None, int | None]:
    """(target relative standard error, paths cap) of a time-domain run
    (harness/workflows/precision.py): with ``paths`` given, (None, None) -- exactly that many
    paths, and ``rel_se`` or ``max_paths`` given with it are refused (one line); else the
    target (default ``default``; allowed 0 < R < 1) and the cap (default MAX_PATHS_FACTOR x the
    scene's montecarlo.paths; allowed: a whole multiple of montecarlo.paths)."""
    unit = int(scene.montecarlo.paths)
    if paths is not None:
        for option, value in (("--rel-se", rel_se), ("--max-paths", max_paths)):
            if value is not None:
                raise InputError(f"{option}: does not apply with --paths (exactly that many "
                                 f"paths, no target); give --paths or {option}, not both")
        return None, None
    r = default if rel_se is None else real("--rel-se", rel_se, REL_SE_ALLOWED)
    if not (0.0 < r < 1.0):
        raise InputError(f"--rel-se {r:g}: out of range; allowed: {REL_SE_ALLOWED} (the "
                         "target relative standard error)")
    if max_paths is None:
        return r, MAX_PATHS_FACTOR * unit
    if isinstance(max_paths, bool) or not isinstance(max_paths, numbers.Integral) \
            or max_paths < unit:
        raise InputError(f"--max-paths {max_paths!r}: out of range; allowed: a whole number "
                         f">= montecarlo.paths = {unit} (the paths come in units of {unit})")
    if max_paths % unit:
        lo = max_paths // unit * unit
        raise InputError(f"--max-paths {max_paths}: not a whole number of units; allowed: a "
                         f"multiple of montecarlo.paths = {unit} (the paths come in units of "
                         f"{unit}; e.g. {lo} or {lo + unit})")
    return r, int(max_paths)


# ------------------------------------------------------------------------------- passage
def passage_values(scene: Scene, *, threshold: Any, start: Any, horizon: Any = None
                   ) -> tuple[float, float | str, float | None]:
    """(threshold, start, horizon) checked (InputError, one line); ``scene`` has its dt
    resolved (:func:`time_scene`)."""
    ac = real("--threshold", threshold, "a finite amplitude > 0")
    if not isinstance(start, str):
        start = real("--start", start, "an amplitude or 'stationary'")
    if horizon is not None:
        horizon = real("--horizon", horizon, "a finite time > 0")
    amplitude_ok(scene, "--threshold", ac)
    if isinstance(start, str):
        if start != "stationary":
            raise InputError(f"--start {start!r}: allowed: an amplitude or 'stationary'")
    elif not math.isfinite(start) or start < 0:
        raise InputError(f"--start {start:g}: out of range; allowed: an amplitude "
                         f"0 <= A0 < Ac = {ac:g}, or 'stationary'")
    elif 0 < start < TINY_AMPLITUDE:
        # issue 45: --start 1e-300 failed after the work ("drift or diffusion is not finite
        # and positive on [2.99e-301, 0.8]") where --start 0 works
        raise InputError(f"--start {start:g}: out of range; allowed: 0 (the rest state) or an "
                         f"amplitude {TINY_AMPLITUDE:g} <= A0 < Ac = {ac:g}, or 'stationary' "
                         "(below it the averaged drift and diffusion over- or underflow)")
    elif start >= ac:
        raise InputError(f"--start {start:g}: at or above the threshold Ac = {ac:g}; the path "
                         "has already passed; allowed: 0 <= A0 < Ac, or 'stationary'")
    if horizon is not None:
        dt = float(scene.montecarlo.dt)
        if not (math.isfinite(horizon) and horizon > 0):
            raise InputError(f"--horizon {horizon:g}: out of range; allowed: a finite time "
                             f"> 0 (at least one step, dt = {dt:g})")
        if horizon < dt:
            raise InputError(f"--horizon {horizon:g}: shorter than one time step; allowed: a "
                             f"finite time >= dt = {dt:g}")
    return ac, start, horizon


def mission_times(at: Any) -> tuple[float, ...]:
    """``--at`` T (one or several): finite times > 0, once each, sorted."""
    if at is None:
        return ()
    values = at if isinstance(at, list | tuple) else (at,)
    out = tuple(real("--at", t, "a finite time > 0") for t in values)
    bad = [t for t in out if not (math.isfinite(t) and t > 0)]
    if bad:
        raise InputError(f"--at {bad[0]:g}: out of range; allowed: a finite time > 0")
    return tuple(sorted(set(out)))


def passage_request(scene: Scene, *, threshold: Any, start: Any = "stationary",
                    models: Any = None, horizon: Any = None, paths: Any = None,
                    sde: Any = True, method: Any = "auto", at: Any = None,
                    particles: Any = None, groups: Any = None, rel_se: Any = None,
                    max_paths: Any = None, methods: tuple[str, ...] = METHODS
                    ) -> PassageRequest:
    """The checked PassageRequest (module docstring); InputError, one line, before any work.
    ``method`` "splitting" estimates the MFPT only, with no horizon and no paths of its own:
    ``horizon``, ``paths`` and ``at`` given with it are refused (they do not apply), as are
    ``particles`` and ``groups`` with "direct". ``methods``: those the front end offers."""
    scene = time_scene(scene)
    if not isinstance(method, str) or method not in methods:
        raise InputError(f"--method {method!r}: allowed: {', '.join(methods)}")
    knobs = {}
    for option, value, lo, hi in (("--particles", particles, 2, math.inf),
                                  ("--groups", groups, 2, SPLITTING_MAX_GROUPS)):
        if value is None:
            continue
        if method == "direct":
            raise InputError(f"{option}: does not apply to --method direct (a splitting "
                             "setting); drop it, or use --method splitting")
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not (
                lo <= value <= hi):
            allowed = f">= {lo}" if hi == math.inf else f"from {lo} to {hi}"
            raise InputError(f"{option} {value!r}: out of range; allowed: a whole number "
                             f"{allowed}")
        knobs[option[2:]] = int(value)
    if method == "splitting":
        for option, value in (("--horizon", horizon), ("--paths", paths), ("--at", at),
                              ("--rel-se", rel_se), ("--max-paths", max_paths)):
            if value is not None:
                raise InputError(f"{option}: does not apply to --method splitting (splitting "
                                 "estimates the MFPT by its own particles and cycles, with no "
                                 "horizon, no paths and no R(t)); drop it, or use --method "
                                 "direct")
    ac, a0, h = passage_values(scene, threshold=threshold, start=start, horizon=horizon)
    times = mission_times(at)
    if h is not None and times and times[-1] > h:
        raise InputError(f"--at {times[-1]:g}: beyond --horizon {h:g} (the original system's "
                         "R(T) is measured up to the horizon only); allowed: 0 < T <= "
                         f"{h:g}, or a longer --horizon")
    n = _paths(paths)
    target, cap = precision(scene, paths=n, rel_se=rel_se, max_paths=max_paths,
                            default=REL_SE_MFPT)
    req = PassageRequest(scene=scene, threshold=ac, start=a0, models=models_of(scene, models),
                         horizon=h, paths=n, sde=flag("sde", sde), method=method,
                         at=times, rel_se=target, max_paths=cap, **knobs)
    if method != "splitting":
        _fits_in_memory(scene, req.paths, req.max_paths)
    return req


def _fits_in_memory(scene: Scene, paths: int | None, max_paths: int | None = None) -> None:
    """Memory is a hard limit for every front end (time is the caller's: the command line's
    cost guard prices it): cost.refuse_oversized at the run's paths, or with a precision
    target at its paths cap (the grown paths are pooled and the averaged SDEs run with them:
    the cap is the most any run holds)."""
    from vifpk.harness.request import cost

    n, option = (paths, "--paths") if paths is not None else (max_paths, "--max-paths")
    if n is not None and n != scene.montecarlo.paths:
        scene = scene.with_values({"montecarlo.paths": n})
    cost.refuse_oversized(scene, option)


def with_quadratures(req: PassageRequest) -> PassageRequest:
    """The request with every applicable model's MFPT by the Pontryagin quadrature
    (door.timedomain.mfpt_averaged): computed here once, read by the plan's price and by the
    workflow (never computed twice). A model whose quadrature fails is left out; the
    workflow meets it again and says so."""
    from vifpk.harness.door import solvers, timedomain

    from vifpk.core import registry

    names = tuple(m for m in req.models if isinstance(m, str))
    kept = set(registry.applicable(req.scene, names)[0])
    out: dict[str, Any] = dict(req.quadratures or {})
    overflows = []
    for m in req.models:
        label = solvers.model_label(m)
        if label in out or (isinstance(m, str) and m not in kept):
            continue
        try:
            out[label] = timedomain.mfpt_averaged(req.scene, m, threshold=req.threshold,
                                                  start=req.start)
        except solvers.SolverFailure as exc:
            if OVERFLOW in str(exc):
                overflows.append(label)
            continue
    if overflows and not out:
        # every model puts the passage beyond 1e308 time units: no method reaches it (the
        # splitting's answer would overflow as well); refused before any R(t) stepping or
        # Monte Carlo, as a price above the hour is (issue 45: exit 3 after the closed forms)
        raise InputError(f"--threshold {req.threshold:g}: the averaged models "
                         f"({', '.join(overflows)}) put the MFPT beyond 1e308 time units "
                         "(it overflows a double): no simulation reaches it; allowed: a lower "
                         "threshold")
    return dataclasses.replace(req, quadratures=out)


#: the words of fpk/passage.py's failure when the MFPT overflows a double
OVERFLOW = "the MFPT overflows"


# ----------------------------------------------------------------------------- transient
def transient_values(scene: Scene, *, start: Any, times: Any) -> tuple[float, tuple[float, ...]]:
    """(start, times) checked (InputError, one line); ``scene`` has its dt resolved."""
    a0 = real("--start", start, "an amplitude > 0")
    amplitude_ok(scene, "--start", a0)
    if isinstance(times, str | bytes) or not hasattr(times, "__iter__"):
        raise InputError(f"--times {times!r}: not a list of times; allowed: {TIMES_ALLOWED}, "
                         "e.g. [10, 20, 40]")
    t = tuple(real("--times", x, TIMES_ALLOWED) for x in times)
    shown = ",".join(f"{x:g}" for x in t)
    if not all(math.isfinite(x) for x in t):
        raise InputError(f"--times {shown}: not finite; allowed: {TIMES_ALLOWED}")
    if t and min(t) <= 0:
        raise InputError(f"--times: {min(t):g} is not > 0; allowed: {TIMES_ALLOWED} "
                         "(t = 0 is the start itself)")
    if any(b <= a for a, b in zip(t, t[1:], strict=False)):
        raise InputError(f"--times {shown}: not increasing; allowed: {TIMES_ALLOWED}")
    if len(t) < MIN_FIT_TIMES:
        raise InputError(f"--times {shown or '(none)'}: {len(t)} time{'s' * (len(t) != 1)}; "
                         f"allowed: {TIMES_ALLOWED} (the relaxation fit a(t) = a_inf + "
                         "(A0 - a_inf) exp(-t/tau) has two parameters)")
    dt = float(scene.montecarlo.dt)  # the simulation snapshots at whole steps: say so
    for x in t:
        k = round(x / dt)
        if k < 1 or abs(k * dt - x) > 1e-9 * x:
            near = ", ".join(f"{v:g}" for v in sorted({max(k, 1) * dt, (max(k, 1) + 1) * dt}))
            raise InputError(f"--times: {x:g} is not a whole number of steps of dt = {dt:g} "
                             "(the simulation takes its snapshots at whole steps); nearest "
                             f"valid: {near}")
    return a0, t


def transient_request(scene: Scene, *, start: Any, times: Any, models: Any = None,
                      paths: Any = None, sde: Any = True, rel_se: Any = None,
                      max_paths: Any = None) -> TransientRequest:
    """The checked TransientRequest (module docstring); InputError, one line, before any work.
    ``rel_se``, ``max_paths``: the relaxation time's target and the paths cap
    (:func:`precision`)."""
    scene = time_scene(scene)
    a0, t = transient_values(scene, start=start, times=times)
    n = _paths(paths)
    target, cap = precision(scene, paths=n, rel_se=rel_se, max_paths=max_paths,
                            default=REL_SE_RELAXATION)
    req = TransientRequest(scene=scene, start=a0, times=t, models=models_of(scene, models),
                           paths=n, sde=flag("sde", sde), rel_se=target, max_paths=cap)
    _fits_in_memory(scene, req.paths, req.max_paths)
    return req


def output(out: Any, option: str = "out") -> str | None:
    """An output folder given to the Python API: a path text or None, checked as ``--out``."""
    from pathlib import Path

    if out is None:
        return None
    if not isinstance(out, str | Path):
        raise InputError(f"{option} {out!r}: not a folder path; give a folder path or None")
    validate.output_folder(str(out), option, replaced=True)
    return str(out)
