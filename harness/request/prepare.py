"""One request: what a front end -- the command line, ``import vifpk``, a sweep point, the
testing API -- asks of a workflow, checked once, before any work, with the same one-line
messages whichever door it came in by (issue 27).

:func:`prepare_solve` and :func:`prepare_check` build a frozen :class:`Request` from plain
values (a scene source, ``--set`` texts or a mapping of dotted values, the Monte Carlo options
by the names of their command-line flags, the models). Everything refused here is a
:class:`~vifpk.core.result.BadInput` (exit 2 at the command line): an unknown option, a value
out of range, a model that does not apply to the scene, a list-valued scene where one value is
needed. The request carries the concrete scene: overrides applied and Monte Carlo options
applied (a step not given is "auto", MonteCarloSettings.dt's default), so the door to the solvers
(``harness/door/solvers.py``) receives settings and never has to re-read a file to know what was
asked.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from vifpk.harness.request import validate

from vifpk.core import registry
from vifpk.core.defaults import CHECK_MODELS
from vifpk.core.scene import Scene, SceneError, check_value, load_scene, no_noise

#: the Monte Carlo options every workflow takes, by the names of their flags (``--paths``...),
#: each the [montecarlo] field of the same name
MC_OPTIONS = tuple(validate.MC_OPTIONS)
#: the most cells per axis ``--grid`` may ask of the original system's FPK: 640^2 took 15 s and
#: ~2.5 GB in its sparse LU (docs/fpk2d.md); 1280^2 took 120 s and 10 GB
ORIGINAL_FPK_MAX_CELLS = 1280
WHOLE = ("paths", "seed")  # options that take a whole number


@dataclass(frozen=True, kw_only=True)
class Request:
    """A validated request: the concrete scene and what to run on it."""

    workflow: str
    scene: Scene
    solver: str | None = None
    model: str | None = None
    models: tuple[str, ...] = ()
    grid: int | None = None
    joint: bool = False
    #: the Monte Carlo options given, by flag name (provenance, messages)
    given: tuple[str, ...] = ()
    #: models asked for that do not apply to the scene, and why (reported, not run)
    skipped: Mapping[str, str] = field(default_factory=dict)
    #: check: the tolerance question (harness.request.tolerance.Tolerance)
    tolerance: Any = None


def _whole(option: str, value: Any) -> int:
    """A whole number given as an int, or a float / text that is whole ("1e6"), as the
    command line reads it; else one line naming the option."""
    if isinstance(value, bool):
        raise validate.InputError(f"--{option} {value!r}: not a whole number")
    if isinstance(value, int):
        return value
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if not (math.isfinite(v) and v == int(v)):
        raise validate.InputError(f"--{option} {value!r}: not a whole number")
    return int(v)


def mc_values(options: Mapping[str, Any]) -> dict[str, Any]:
    """{"montecarlo.<field>": value} for the Monte Carlo options given (flag names), each
    checked against its field's range (one line naming the option)."""
    out = {}
    for k, v in options.items():
        if v is None:
            continue
        if k in WHOLE:
            v = _whole(k, v)
        elif k == "dt" and v == "auto":
            pass
        elif isinstance(v, bool) or not isinstance(v, int | float):
            raise validate.InputError(f"--{k} {v!r}: not a number"
                                      + (" or 'auto'" if k == "dt" else ""))
        out[f"montecarlo.{validate.MC_OPTIONS[k]}"] = check_value(f"--{k}", "montecarlo",
                                                                  validate.MC_OPTIONS[k], v)
    return out


def parse_override(text: str) -> tuple[str, Any]:
    """``section.key=value`` of a ``--set``: the value read as TOML ("0.02", "[1, 0, 2]",
    "true"), else kept as text."""
    import tomllib

    key, sep, value = text.partition("=")
    if not sep or "." not in key:
        raise SceneError(f"--set {text}: expected section.key=value, e.g. noise.D=0.02")
    try:
        parsed = tomllib.loads(f"v = {value}")["v"]
    except tomllib.TOMLDecodeError:
        parsed = value
    return key.strip(), parsed


def concrete(source: Scene | str | Path, overrides: Sequence[str] = (),
             values: Mapping[str, Any] | None = None) -> Scene:
    """The one scene a request runs on: a Scene, a scene file or a shipped scene's name, with
    ``--set`` texts (``overrides``) or dotted ``values`` applied. A scene that still varies a
    parameter (a list of values) is refused: choose one value."""
    from vifpk.core.provenance import overridden_name

    if isinstance(source, Scene):
        scene = source
    elif isinstance(source, str | Path):
        scene = load_scene(source)
    else:
        raise validate.InputError(f"scene {source!r}: not a scene; give a Scene, a scene file's "
                                  "path or the name of a shipped scene (vifpk.scene)")
    if overrides:
        validate.duplicate_overrides(overrides)
        scene = scene.with_values(dict(parse_override(o) for o in overrides))
        # titled with its overrides, and never written into the base scene's default folder
        scene = replace(scene, name=overridden_name(scene.name, overrides),
                        description=f"{scene.description} With --set "
                                    f"{', '.join(overrides)}.".lstrip())
    if values:
        scene = scene.with_values(dict(values))
    if scene.sweep is not None:
        sw = scene.sweep
        vals = ", ".join(f"{v:g}" for v in sw.values)
        where = scene.source or scene.name
        raise SceneError(f"{where}: {sw.path} varies over [{vals}]; choose one value "
                         f"with --set {sw.path}=VALUE")
    return scene


def with_mc_options(scene: Scene, options: Mapping[str, Any], *, mc: bool) -> Scene:
    """The scene with the Monte Carlo options applied and every check
    of the scene made (magnitudes, a stationary density; with ``mc`` the Monte Carlo settings
    too, naming the options given)."""
    given = [k for k in MC_OPTIONS if options.get(k) is not None]
    values = mc_values({k: options[k] for k in given})
    scene = scene.with_values(values) if values else scene
    validate.scene_magnitudes(scene)
    validate.stationary_density(scene)
    if mc:
        validate.montecarlo_settings(scene, {k: f"--{k}" for k in given})
        if options.get("budget") is not None and scene.montecarlo.floor <= 0:
            raise validate.InputError(f"--budget {options['budget']:g}: does not apply without "
                                      "a target floor (--floor F > 0 or montecarlo.floor): the "
                                      "budget limits the time spent reaching the floor")
    return scene


def model_names(models: Any, option: str = "--model") -> tuple[str, ...]:
    """Registered model names from a sequence of names (a single string is refused: it is
    not a list of models), once each in order; one line listing the registered ones for an
    unknown name."""
    if isinstance(models, str) or not isinstance(models, Sequence):
        raise validate.InputError(f"{option} {models!r}: give a list of model names, e.g. "
                                  "('exact', 'corrected')")
    names = registry.model_names()
    for m in models:
        if m not in names:
            raise validate.InputError(f"{option} {m!r}: not a registered model; registered: "
                                      f"{', '.join(names)} (vifpk models lists them; "
                                      "docs/plugins.md adds one)")
    return tuple(dict.fromkeys(models))


def applicable_models(scene: Scene, models: tuple[str, ...], *, chosen: bool,
                      option: str = "--model") -> tuple[tuple[str, ...], dict[str, str]]:
    """The models that apply to the scene (each model's own ``applies``). Models named by the
    user (``chosen``) that do not apply are refused in one line; of a default list they are
    skipped. Nothing left to run is refused either way."""
    kept, refused = registry.applicable(scene, models)
    if chosen and refused:
        name, why = next(iter(refused.items()))
        allowed = ", ".join(m for m in registry.model_names()
                            if registry.model_applies(m, scene) is None)
        raise validate.InputError(f"{option} {name}: does not apply to this scene: {why}; "
                                  f"allowed here: {allowed}")
    if not models:
        raise validate.InputError(f"{option}: no model given; give at least one of "
                                  f"{', '.join(registry.model_names())}")
    if not kept:
        raise validate.InputError(f"{option}: none of {', '.join(models)} applies to this "
                                  f"scene ({'; '.join(refused.values())})")
    return kept, refused


# ------------------------------------------------------------------------------ workflows
def prepare_solve(source: Scene | str | Path, *, solver: str = "averaging",
                  model: str | None = None, grid: int | None = None, joint: bool = False,
                  overrides: Sequence[str] = (), values: Mapping[str, Any] | None = None,
                  allow_unequilibrated: bool = False, **mc: Any) -> Request:
    """``vifpk solve``'s request. ``mc``: the Monte Carlo options by flag name (paths, dt,
    time, seed, floor, budget); anything else is refused naming it."""
    unknown = sorted(set(mc) - set(MC_OPTIONS))
    if unknown:
        raise validate.InputError(f"{unknown[0]}: not an option of solve; allowed: solver, "
                                  f"model, grid, joint, {', '.join(MC_OPTIONS)}")
    if solver not in registry.solver_names():
        raise validate.InputError(f"--solver {solver!r}: not a solver; allowed: "
                                  f"{', '.join(registry.solver_names())}")
    given = [k for k in MC_OPTIONS if mc.get(k) is not None]
    fpk2d = solver == registry.ORIGINAL_FPK
    if fpk2d:
        validate.refuse_options([k for k, v in (("model", model),) if v is not None] + given
                                + (["allow_unequilibrated"] if allow_unequilibrated else []),
                                "to --solver original-fpk (it solves the original system's "
                                "own FPK: no model, no sampling)")
    elif solver == registry.ORIGINAL:
        validate.refuse_options([k for k, v in (("grid", grid), ("model", model))
                                 if v is not None],
                                "to --solver montecarlo (it simulates the original system)")
    else:
        validate.refuse_options(given + (["allow_unequilibrated"] if allow_unequilibrated
                                         else []),
                                f"to --solver {solver} (Monte Carlo options apply to "
                                "--solver montecarlo)")
        if solver == registry.CLOSED_FORM and grid is not None:
            validate.refuse_options(["grid"], "to --solver averaging (its grid is "
                                    "averaging.points; --grid sets the FPK's cells)")
    if grid is not None:
        grid = _whole("grid", grid)
        low, high = (8, ORIGINAL_FPK_MAX_CELLS) if fpk2d else (4, None)
        if grid < low or (high is not None and grid > high):
            raise validate.InputError(
                f"--grid {grid}: out of range; allowed: a whole number >= {low}"
                + (f" and <= {high} (cells per axis of the original system's FPK: its LU "
                   "grows as cells^3)" if fpk2d else " (cells of the FPK)"))
    scene = with_mc_options(concrete(source, overrides, values), mc,
                            mc=solver == registry.ORIGINAL)
    if not fpk2d:
        validate.law_in_reach(scene)
    if fpk2d:
        from vifpk.harness.door.original import original_fpk_problem

        problem = original_fpk_problem(scene)
        if problem is not None:
            raise validate.InputError(f"--solver original-fpk: {problem}")
    elif solver != registry.ORIGINAL:
        if model is None:  # the first of the check models that applies (paper, then exact)
            model = registry.applicable(scene, CHECK_MODELS)[0][0]
        else:
            model = model_names([model])[0]
            applicable_models(scene, (model,), chosen=True)
    if solver == registry.ORIGINAL and joint and not scene.observables.joint:
        scene = scene.with_values({"observables.joint": True})
    return Request(workflow="solve", scene=scene, solver=solver, model=model, grid=grid,
                   joint=joint, given=tuple(given))


def prepare_check(source: Scene | str | Path, *, models: Sequence[str] | None = None,
                  overrides: Sequence[str] = (), values: Mapping[str, Any] | None = None,
                  tolerance: float | None = None, tolerance_metric: str = "L1",
                  tolerance_observable: str = "A", confidence: float | None = None,
                  **mc: Any) -> Request:
    """``vifpk check``'s request: the models (default CHECK_MODELS, those that apply; models
    named by the user must apply), the tolerance question (harness/workflows/tolerance.py; defaults
    there) and the Monte Carlo options by flag name."""
    from vifpk.harness.request.tolerance import Tolerance

    from vifpk.core.defaults import TOLERANCE, TOLERANCE_CONFIDENCE

    unknown = sorted(set(mc) - set(MC_OPTIONS))
    if unknown:
        raise validate.InputError(f"{unknown[0]}: not an option of check; allowed: models, "
                                  "out, quiet, tolerance, tolerance_metric, "
                                  f"tolerance_observable, confidence, {', '.join(MC_OPTIONS)}")
    tol = Tolerance(value=TOLERANCE if tolerance is None else tolerance, metric=tolerance_metric,
                    observable=tolerance_observable,
                    confidence=TOLERANCE_CONFIDENCE if confidence is None else confidence)
    chosen = models is not None
    names = model_names(models, "--model") if chosen else CHECK_MODELS
    scene = with_mc_options(concrete(source, overrides, values), mc, mc=True)
    if no_noise(scene.system):
        from vifpk.harness.door.solvers import SolverFailure

        raise SolverFailure(f"{no_noise(scene.system)}; nothing to cross-check")
    _, skipped = applicable_models(scene, names, chosen=chosen)
    validate.law_in_reach(scene)
    # the whole list goes on: the check reports why a default model does not apply
    return Request(workflow="check", scene=scene, models=names, skipped=skipped, tolerance=tol,
                   given=tuple(k for k in MC_OPTIONS if mc.get(k) is not None))
