"""Sweeps: one workflow run at every point of a parameter grid, on any executor.

A sweep file (TOML, issue 14; docs/maps.md) names a base scene, the workflow, fixed overrides and
the varied parameters::

    scene = "paper-base"          # a shipped scene name or a path (relative to the sweep file)
    workflow = "check"            # "check" | "averaging" (closed forms only) | "bifurcation"
                                  # | "passage" | "transient" (harness/timesweep.py)
    mode = "product"              # or "zip"
    seed = 7                      # optional; default the base scene's montecarlo.seed
    models = ["paper", "mine"]    # optional: registered averaged models (vifpk.core.registry);
                                  # default: the workflow's own (check, averaging: CHECK_MODELS;
                                  # bifurcation: BIFURCATION_MODELS, vifpk.core.defaults)
    tolerance = 0.02              # optional, check only: the tolerance verdict's L1(A); per
                                  # point and model error_estimate(_err), p_within_tolerance,
                                  # tolerance_class (harness/tolerance.py); or a table
                                  # {value, metric, observable, confidence}
    [vary]
    "system.r" = [0.95, 0.96, 0.97, 0.98]
    "system.mu" = {start = 0.0, stop = 0.004, num = 5}
    [set]                         # the same for every point
    "montecarlo.floor" = 0.01
    [bifurcation]                 # only for workflow = "bifurcation"
    find = "mu"                   # the critical parameter found at every point: "mu" or "r"
    range = [0.0, 0.05]           # optional search interval
    mc = true                     # Monte Carlo check on both sides of each critical value

Everything is validated before any computation: every point's scene is built and checked like
a scene file, so a value out of range at any one point is reported (one line, exit 2).

A point is a pure function of (scene, settings, seed): its Monte Carlo seed is

    seed_point = SeedSequence([seed_sweep, *words(sha256(params))]).generate_state(1, uint64) >> 2

(params: the point's varied values, by name, as exact hexadecimal floats), so it depends on the
parameters and not on the point's position in the grid or on the executor. Its record is written
atomically to ``DIR/points/<key>.json`` with ``key = sha256(params)[:16]``; a record whose
fingerprint (sha256 of the workflow and the point's whole scene, seed included) matches is a
finished point, and a sweep started again skips it. Sweeps run the Monte Carlo without a
wall-clock budget (``montecarlo.budget = 0``): a budget would make a point depend on the
machine's speed.

Executors: ``serial``; ``processes:N`` (concurrent.futures, numba threads per worker =
cores // N); ``dask:N`` (a dask.distributed LocalCluster of N workers); ``tcp://HOST:PORT``
(a running dask scheduler). dask's futures carry the points, and dask reschedules a point whose
worker died; the records are written by the process that runs the sweep, once per point.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from vifpk.core.defaults import BIFURCATION_MODELS, CHECK_MODELS, TOLERANCE, TOLERANCE_CONFIDENCE
from vifpk.core.result import BadInput
from vifpk.core.scene import INDEXED, MAX_TERMS, SECTIONS, Scene, SceneError, load_scene

from .check import ASSUMPTION_KINDS
from .request import dt_follows_floor
from .timesweep import SCALARS as TIME_SCALARS

WORKFLOWS = ("check", "averaging", "bifurcation", "passage", "transient")
MODES = ("product", "zip", "adaptive")
TOP_KEYS = ("scene", "workflow", "mode", "seed", "name", "description", "vary", "set",
            "bifurcation", "adaptive", "models", "tolerance", "passage", "transient")
ADAPTIVE_KEYS = ("points", "model", "batch", "resolution")
#: points of an adaptive batch unless [adaptive] batch says otherwise: a property of the sweep
#: file, not of the executor, so that the points do not depend on where they run
ADAPTIVE_BATCH = 8
ADAPTIVE_RESOLUTION = 40  # refine the boundary as finely as a 40 x 40 grid (adaptive.min_edge)
BIFURCATION_KEYS = ("find", "range", "mc")
FIND = {"mu": "system.mu", "r": "system.r"}
#: keys a sweep may not vary or set: the seed comes from the sweep's seed; a wall-clock
#: budget would make a point depend on the machine's speed
RESERVED = {"montecarlo.seed": "set the sweep's seed with the top-level key `seed`",
            "montecarlo.budget": "sweeps run without a wall-clock budget (a budget makes a "
                                 "point depend on the machine's speed); use montecarlo.floor"}
#: warnings of the cross-check as flags: variable name -> the warning's kind (WarningRecord.kind)
WARNING_FLAGS = {f"warn_{kind}": kind for kind in ASSUMPTION_KINDS}
EXTRA_HINT = "pip install 'vifpk[cluster]'"
#: the largest grid a sweep file may ask for: building and validating a point's scene costs
#: ~1-3 ms (measured 2026-11-23: 10000 points in 24 s at load average 10 on 2 cores), so a
#: 1000 x 1000 grid was silent for many minutes before any work
MAX_POINTS = 20_000


class SweepError(SceneError):
    """A sweep file or executor that cannot be used; one line naming the key (exit 2)."""


class WorkerLost(RuntimeError):
    """The executor lost points (not a numerical failure): the finished records are kept and
    the same command resumes the sweep."""


# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, kw_only=True)
class Point:
    """One point: its varied values (in the sweep file's order), seed, key and scene."""

    params: tuple[tuple[str, float], ...]
    seed: int
    key: str
    scene: Scene
    fingerprint: str
    sde: bool = False  # a check point that runs the averaged SDEs' Monte Carlo
    batch: int = 0  # adaptive sweeps: 0 for the initial lattice, then 1, 2, ...

    def label(self) -> str:
        return " ".join(f"{k}={v:g}" for k, v in self.params)


@dataclass(frozen=True, kw_only=True)
class Sweep:
    """A validated sweep file."""

    path: str
    text: str
    name: str
    workflow: str
    mode: str
    seed: int
    vary: tuple[tuple[str, tuple[float, ...]], ...]
    fixed: Mapping[str, Any]
    bifurcation: Mapping[str, Any]
    base: Scene
    points: tuple[Point, ...] = field(repr=False)
    #: mode "adaptive": points, model, batch, resolution ([adaptive]); vary then holds the
    #: ranges as (start, stop), and ``points`` the initial lattice (run_adaptive adds the rest)
    adaptive: Mapping[str, Any] = field(default_factory=dict)
    models: tuple[str, ...] | None = None  # None: the workflow's default models
    tolerance: float = TOLERANCE  # check: the tolerance verdict's value (harness/tolerance.py)
    #: check: the rest of the tolerance question (metric, observable, confidence)
    tolerance_question: tuple[str, str, float] = ("L1", "A", TOLERANCE_CONFIDENCE)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(k for k, _ in self.vary)


def canonical(params: tuple[tuple[str, float], ...]) -> str:
    """The parameters as text, exactly: names sorted, values as hexadecimal floats."""
    return json.dumps(sorted((k, float(v).hex()) for k, v in params))


def point_key(params: tuple[tuple[str, float], ...]) -> str:
    """The record name of a point: 16 hex digits of sha256 of its canonical parameters."""
    return hashlib.sha256(canonical(params).encode()).hexdigest()[:16]


def point_seed(seed: int, params: tuple[tuple[str, float], ...]) -> int:
    """A point's Monte Carlo seed from the sweep's seed and the point's parameters (< 2^62)."""
    import numpy as np

    digest = hashlib.sha256(canonical(params).encode()).digest()
    words = [int.from_bytes(digest[i:i + 4], "little") for i in range(0, 32, 4)]
    state = np.random.SeedSequence([int(seed), *words]).generate_state(1, dtype=np.uint64)
    return int(state[0]) >> 2


def fingerprint(workflow: str, scene: Scene, bifurcation: Mapping[str, Any], *,
                sde: bool = False, models: tuple[str, ...] | None = None,
                tolerance: Any = None) -> str:
    """sha256 of everything a point's result depends on (the scene includes the seed; ``sde``:
    the point runs the averaged SDEs' Monte Carlo, SDE_CHECK_EVERY; the models only when the
    sweep names them, so a sweep without ``models`` keeps its records; the tolerance question
    only when it is not the default one, likewise: a changed tolerance recomputes the points'
    verdicts instead of keeping the old ones)."""
    d = scene.to_dict()
    d.pop("name", None)
    d.pop("description", None)
    what: dict[str, Any] = {"workflow": workflow, "scene": d, "bifurcation": dict(bifurcation)}
    if workflow == "check":
        what["sde_check"] = bool(sde)
    if models is not None:
        what["models"] = list(models)
    if tolerance is not None and workflow == "check":
        from .tolerance import Tolerance

        if tolerance != Tolerance():
            what["tolerance"] = tolerance.record()
    blob = json.dumps(what, sort_keys=True)
    return hashlib.sha256(blob.encode()).hexdigest()


# --------------------------------------------------------------------------------------------
def _field_of(where: str, path: str) -> Any:
    """The dataclass field named by ``section.key``, or a SweepError naming it."""
    import difflib

    from .timesweep import field_of

    if field_of(path) is not None:  # passage.threshold, ...: a workflow's parameter
        return field_of(path)
    section, _, key = path.partition(".")
    if section not in SECTIONS or not key:
        raise SweepError(f"{where} {path!r}: unknown key; use section.key with a section in "
                         f"{sorted(SECTIONS)}")
    known = {f.name: f for f in fields(SECTIONS[section])}
    m = INDEXED.fullmatch(key) if section == "system" else None
    if m and m.group(1) in known and known[m.group(1)].type.startswith("tuple"):
        if int(m.group(2)) >= MAX_TERMS:
            raise SweepError(f"{where} {path!r}: index out of range; allowed: 0 to "
                             f"{MAX_TERMS - 1}")
        return _Coefficient()  # one coefficient of a polynomial law: a number
    if key not in known:
        close = difflib.get_close_matches(key, list(known), n=1, cutoff=0.5)
        hint = f"did you mean '{section}.{close[0]}'?" if close else \
            "allowed: " + ", ".join(f"{section}.{k}" for k in known)
        raise SweepError(f"{where} {path!r}: unknown key; {hint}")
    if path in RESERVED:
        raise SweepError(f"{where} {path!r}: not allowed in a sweep; {RESERVED[path]}")
    return known[key]


class _Coefficient:
    """Stands for the field of one coefficient of a law ("system.restoring[2]")."""

    type = "float"


def _number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _values(where: str, spec: Any) -> tuple[float, ...]:
    """A list of numbers or {start, stop, num} (num values from start to stop inclusive)."""
    import numpy as np

    if isinstance(spec, list):
        if not spec:
            raise SweepError(f"{where}: empty grid (no values)")
        bad = [v for v in spec if not _number(v) or not math.isfinite(v)]
        if bad:
            raise SweepError(f"{where}: {bad[0]!r} is not a finite number")
        vals = tuple(float(v) for v in spec)
    elif isinstance(spec, Mapping):
        extra = sorted(set(spec) - {"start", "stop", "num"})
        if extra:
            raise SweepError(f"{where}.{extra[0]}: unknown key; allowed: start, stop, num")
        missing = [k for k in ("start", "stop", "num") if k not in spec]
        if missing:
            raise SweepError(f"{where}: missing {missing[0]}; a range is "
                             "{start = ..., stop = ..., num = ...}")
        num = spec["num"]
        if not isinstance(num, int) or isinstance(num, bool) or num < 0:
            raise SweepError(f"{where}.num = {num!r}: must be a whole number >= 1")
        if num == 0:
            raise SweepError(f"{where}: empty grid (num = 0)")
        if num > MAX_POINTS:
            raise SweepError(f"{where}.num = {num}: out of range; allowed: 1 to {MAX_POINTS}")
        for k in ("start", "stop"):
            if not _number(spec[k]) or not math.isfinite(spec[k]):
                raise SweepError(f"{where}.{k} = {spec[k]!r}: must be a finite number")
        vals = tuple(float(v) for v in np.linspace(spec["start"], spec["stop"], num))
    else:
        raise SweepError(f"{where}: must be a list of numbers or {{start, stop, num}}")
    if len(set(vals)) != len(vals):
        raise SweepError(f"{where}: a value appears twice")
    return vals


def _resolve_scene(name: Any, sweep_path: Any) -> Scene:
    """The sweep's base scene: a path (relative to the sweep file) must exist; a bare name
    is a scene file ``NAME.toml`` beside the sweep file, else the shipped scene of that name."""
    from vifpk.core.scene import shipped_name

    if not isinstance(name, str) or not name:
        raise SweepError(f"{sweep_path.name}: scene must be a shipped scene name or a path")
    if isinstance(sweep_path, Path):  # a sweep file on disk: paths relative to it
        if not shipped_name(name):
            return load_scene(sweep_path.parent / Path(name).expanduser())
        beside = sweep_path.parent / f"{name}.toml"
        if beside.is_file():
            return load_scene(beside)
    return load_scene(name)


def load_sweep(path: str | Path) -> Sweep:
    """Read and validate a sweep file (a path, or the bare name of a shipped sweep), building
    every point's scene (SweepError on any problem, one line naming the key)."""
    from vifpk.core.scene import (
        is_toml_file,
        read_toml,
        shared_term,
        shipped_name,
        shipped_scenes,
    )

    p: Any = Path(path)
    if not is_toml_file(p, SweepError, "sweep"):
        # a shipped sweep by its bare name: scenes/sweeps/NAME.toml (package data)
        cand = shipped_scenes() / "sweeps" / f"{path}.toml"
        if not shipped_name(str(path)) or "/" in str(path) or not cand.is_file():
            raise SweepError(f"{path}: no such sweep file")
        p = cand
    text, raw = read_toml(p, SweepError)
    src = p.name
    for key in raw:
        if key not in TOP_KEYS:
            import difflib

            close = difflib.get_close_matches(key, TOP_KEYS, n=1, cutoff=0.5)
            hint = f"did you mean '{close[0]}'?" if close else "allowed: " + ", ".join(TOP_KEYS)
            raise SweepError(f"{src}: unknown key '{key}'; {hint}")
    if "scene" not in raw:
        raise SweepError(f"{src}: scene: missing (a shipped scene name or a path)")
    try:
        base = _resolve_scene(raw["scene"], p)
    except SweepError:
        raise
    except SceneError as exc:
        raise SweepError(f"{src}: scene: {exc}") from None
    workflow = raw.get("workflow", "check")
    if workflow not in WORKFLOWS:
        raise SweepError(f"{src}: workflow = {workflow!r}: unknown workflow; allowed: "
                         + ", ".join(WORKFLOWS))
    mode = raw.get("mode", "product")
    if mode not in MODES:
        raise SweepError(f"{src}: mode = {mode!r}: allowed: " + ", ".join(MODES))
    seed = raw.get("seed", base.montecarlo.seed)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise SweepError(f"{src}: seed = {seed!r}: must be a whole number >= 0")
    models = raw.get("models")
    if models is not None:
        from vifpk.core.registry import model_names

        known = model_names()
        if (not isinstance(models, list) or not models
                or not all(isinstance(m, str) for m in models)):
            raise SweepError(f"{src}: models = {models!r}: a list of model names; registered: "
                             + ", ".join(known))
        for m in models:
            if m not in known:
                raise SweepError(f"{src}: models: {m!r} is not a registered model; "
                                 "registered: " + ", ".join(known))
        models = tuple(dict.fromkeys(models))
    tolerance = raw.get("tolerance", TOLERANCE)
    if "tolerance" in raw and workflow != "check":
        raise SweepError(f"{src}: tolerance: only for workflow = \"check\" (the tolerance "
                         "verdict of the averaging error)")
    question: dict[str, Any] = {}
    if isinstance(tolerance, Mapping):  # {value, metric, observable, confidence}
        allowed = ("value", "metric", "observable", "confidence")
        unknown = sorted(set(tolerance) - set(allowed))
        if unknown:
            raise SweepError(f"{src}: tolerance.{unknown[0]}: unknown key; allowed: "
                             + ", ".join(allowed))
        question = {k: tolerance[k] for k in allowed[1:] if k in tolerance}
        tolerance = tolerance.get("value", TOLERANCE)
    if (not isinstance(tolerance, int | float) or isinstance(tolerance, bool)
            or not math.isfinite(tolerance) or tolerance <= 0):
        raise SweepError(f"{src}: tolerance = {tolerance!r}: a number > 0 (the largest "
                         "accepted averaging error)")
    from .tolerance import Tolerance, ToleranceError

    try:
        tol = Tolerance(value=float(tolerance), **question)
    except ToleranceError as exc:
        raise SweepError(f"{src}: tolerance: {exc}") from None
    name = raw.get("name", Path(p.name).stem)
    description = raw.get("description", "")
    if not isinstance(name, str) or not name or not isinstance(description, str):
        raise SweepError(f"{src}: name and description must be strings")

    vary_raw = raw.get("vary")
    if not isinstance(vary_raw, Mapping) or not vary_raw:
        raise SweepError(f"{src}: [vary]: empty grid (name at least one parameter to vary)")
    vary = []
    for key, spec in vary_raw.items():
        f = _field_of(f"{src}: [vary]", key)
        if f.type not in ("float", "float | str", "float | None"):
            raise SweepError(f"{src}: [vary] {key!r}: only numeric parameters can vary")
        vary.append((key, _range(f"{src}: [vary] {key!r}", spec) if mode == "adaptive"
                     else _values(f"{src}: [vary] {key!r}", spec)))
    adaptive = _adaptive_table(src, raw, mode, workflow, len(vary), models or CHECK_MODELS)
    if mode == "zip" and len({len(v) for _, v in vary}) > 1:
        lens = ", ".join(f"{k}: {len(v)}" for k, v in vary)
        raise SweepError(f"{src}: mode = 'zip' needs lists of one length ({lens})")
    fixed_raw = raw.get("set", {})
    if not isinstance(fixed_raw, Mapping):
        raise SweepError(f"{src}: [set] must be a table of section.key = value")
    for key in fixed_raw:
        _field_of(f"{src}: [set]", key)
        if key in vary_raw:
            raise SweepError(f"{src}: [set] {key!r}: also in [vary]; keep one")
    clash = shared_term([*vary_raw, *fixed_raw])
    if clash is not None:  # the rule --set follows (validate.duplicate_overrides)
        earlier, key, law = clash
        where = "[vary]" if key in vary_raw else "[set]"
        raise SweepError(f"{src}: {where} {key!r}: sets the {law} law's coefficient that "
                         f"{earlier!r} already sets (two spellings of one term); give it once")

    from .timesweep import options

    bif = dict(raw.get("bifurcation", {}))
    # the time workflows' table ([passage], [transient]) travels where [bifurcation]'s does
    timeopts = options(src, raw, workflow, vary_raw)
    if workflow != "bifurcation" and bif:
        raise SweepError(f"{src}: [bifurcation]: only for workflow = 'bifurcation'")
    if workflow == "bifurcation":
        for key in bif:
            if key not in BIFURCATION_KEYS:
                raise SweepError(f"{src}: [bifurcation] {key}: unknown key; allowed: "
                                 + ", ".join(BIFURCATION_KEYS))
        find = bif.get("find")
        if find not in FIND:
            raise SweepError(f"{src}: [bifurcation] find = {find!r}: allowed: 'mu', 'r'")
        if FIND[find] in vary_raw or FIND[find] in fixed_raw:
            raise SweepError(f"{src}: [bifurcation] find = {find!r}: {FIND[find]} is searched "
                             "at every point, so it cannot also be varied or set")
        rng = bif.get("range")
        if rng is not None:
            from .bifurcation import VARIABLES

            ok = (isinstance(rng, list) and len(rng) == 2 and all(_number(v) for v in rng)
                  and all(math.isfinite(v) for v in rng) and rng[0] < rng[1])
            _, _, (d_lo, d_hi) = VARIABLES[find]
            if not ok:
                raise SweepError(f"{src}: [bifurcation] range = {rng!r}: must be [lo, hi] "
                                 "of finite numbers with lo < hi")
            bif["range"] = [float(rng[0]), float(rng[1])]
            lo_ok = rng[0] >= 0 if find == "mu" else 0 < rng[0]
            if not lo_ok or (find == "r" and rng[1] > 1):
                raise SweepError(f"{src}: [bifurcation] range = {rng!r}: out of range; "
                                 f"allowed: {'0 <= lo' if find == 'mu' else '0 < lo < hi <= 1'}")
            del d_lo, d_hi
        mc = bif.get("mc", True)
        if not isinstance(mc, bool):
            raise SweepError(f"{src}: [bifurcation] mc = {mc!r}: true or false")
        bif = {"find": find, "range": bif.get("range"), "mc": mc}
    if timeopts:
        bif = timeopts

    if mode == "product":
        import itertools

        size = math.prod(len(v) for _, v in vary)
        if size > MAX_POINTS:
            raise SweepError(f"{src}: [vary]: {' x '.join(str(len(v)) for _, v in vary)} = "
                             f"{size} points; allowed: up to {MAX_POINTS} points a sweep "
                             "(split it, or use mode = \"adaptive\")")
        combos = [tuple(zip([k for k, _ in vary], c, strict=True))
                  for c in itertools.product(*(v for _, v in vary))]
    elif mode == "adaptive":
        from .adaptive import initial_design

        combos = [adaptive_params(vary, u) for u in initial_design(len(vary), adaptive["points"])]
        if len(combos) > adaptive["points"]:
            raise SweepError(f"{src}: [adaptive] points = {adaptive['points']}: at least "
                             f"{len(combos)} (the initial lattice)")
    else:
        combos = [tuple((k, v[i]) for k, v in vary) for i in range(len(vary[0][1]))]
    if mode == "zip" and len({canonical(c) for c in combos}) != len(combos):
        raise SweepError(f"{src}: [vary]: two zipped points have the same values")
    fixed = dict(fixed_raw)
    # the time step follows the floor (request.dt_follows_floor) unless the sweep or the
    # base scene file gives one
    floor = fixed.get("montecarlo.floor", base.montecarlo.floor)
    given = base.given | set(fixed) | set(vary_raw)
    if workflow != "averaging" and dt_follows_floor(given, floor,
                                                     fixed.get("montecarlo.dt",
                                                               base.montecarlo.dt)):
        fixed["montecarlo.dt"] = "auto"
    points = [make_point(base, fixed, seed=seed, workflow=workflow, bifurcation=bif,
                         params=params, first=i == 0, where=src, models=models, tolerance=tol)
              for i, params in enumerate(combos)]
    return Sweep(path=str(p), text=text, name=name, workflow=workflow, mode=mode, seed=seed,
                 vary=tuple(vary), fixed=fixed, bifurcation=bif, base=base,
                 points=tuple(points), adaptive=adaptive, models=models,
                 tolerance=tol.value,
                 tolerance_question=(tol.metric, tol.observable, tol.confidence))


def _range(where: str, spec: Any) -> tuple[float, float]:
    """An adaptive sweep's range {start, stop} (start < stop, finite)."""
    if not isinstance(spec, Mapping) or set(spec) != {"start", "stop"}:
        raise SweepError(f"{where}: an adaptive sweep varies over a range "
                         "{start = ..., stop = ...} (no num: the points are chosen as it runs)")
    for k in ("start", "stop"):
        if not _number(spec[k]) or not math.isfinite(spec[k]):
            raise SweepError(f"{where}.{k} = {spec[k]!r}: must be a finite number")
    if not spec["start"] < spec["stop"]:
        raise SweepError(f"{where}: start must be below stop")
    return float(spec["start"]), float(spec["stop"])


def _adaptive_table(src: str, raw: Mapping[str, Any], mode: str, workflow: str, dims: int,
                    models: tuple[str, ...] = CHECK_MODELS) -> dict[str, Any]:
    """The validated [adaptive] table (empty unless mode = "adaptive")."""
    table = raw.get("adaptive")
    if mode != "adaptive":
        if table is not None:
            raise SweepError(f"{src}: [adaptive]: only for mode = 'adaptive'")
        return {}
    if workflow != "check":
        raise SweepError(f"{src}: mode = 'adaptive' refines the check's verdict; it needs "
                         f"workflow = 'check' (not {workflow!r})")
    if dims not in (1, 2):
        raise SweepError(f"{src}: [vary]: an adaptive sweep varies one or two parameters, "
                         f"not {dims}")
    if not isinstance(table, Mapping):
        raise SweepError(f"{src}: [adaptive]: missing; give points = N and model = NAME")
    for key in table:
        if key not in ADAPTIVE_KEYS:
            raise SweepError(f"{src}: [adaptive] {key}: unknown key; allowed: "
                             + ", ".join(ADAPTIVE_KEYS))
    def whole(key: str, lo: int, default: int | None = None) -> int:
        v = table.get(key, default)
        if v is None:
            raise SweepError(f"{src}: [adaptive] {key}: missing (a whole number >= {lo})")
        if not isinstance(v, int) or isinstance(v, bool) or v < lo:
            raise SweepError(f"{src}: [adaptive] {key} = {v!r}: must be a whole number >= {lo}")
        return v

    model = table.get("model")
    if model not in models:  # one of the models the sweep's checks run
        raise SweepError(f"{src}: [adaptive] model = {model!r}: allowed: " + ", ".join(models))
    return {"points": whole("points", 3), "model": model,
            "batch": whole("batch", 1, ADAPTIVE_BATCH),
            "resolution": whole("resolution", 3, ADAPTIVE_RESOLUTION)}


def adaptive_params(vary: Sequence[tuple[str, tuple[float, float]]], unit: Sequence[float]
                    ) -> tuple[tuple[str, float], ...]:
    """The parameters at unit coordinates ``unit`` of an adaptive sweep's ranges (u = 0 is
    start, u = 1 exactly stop)."""
    return tuple((k, hi if u == 1.0 else lo + u * (hi - lo))
                 for (k, (lo, hi)), u in zip(vary, unit, strict=True))


#: a check sweep runs the Monte Carlo of each averaged SDE against its closed form (a check of
#: the closed forms and the Monte Carlo machinery, not of the averaging error, which is what a
#: map shows) only at sampled points: the sweep's first point and every point whose key,
#: read as a number, is divisible by SDE_CHECK_EVERY (about 1 in 16, chosen by the point's
#: parameters alone, so the choice does not depend on the executor or the order of points)
SDE_CHECK_EVERY = 16


def sde_check_at(key: str, *, first: bool) -> bool:
    """Whether a check point runs the averaged SDEs' Monte Carlo (SDE_CHECK_EVERY)."""
    return first or int(key, 16) % SDE_CHECK_EVERY == 0


def make_point(base: Scene, fixed: Mapping[str, Any], *, seed: int, workflow: str,
               bifurcation: Mapping[str, Any], params: tuple[tuple[str, float], ...],
               first: bool = False, where: str = "sweep",
               models: tuple[str, ...] | None = None, tolerance: Any = None) -> Point:
    """The point of a sweep at ``params`` (varied values by name): its scene (the base scene
    with ``fixed`` and ``params`` set, no wall-clock budget, its own seed), key and
    fingerprint. SweepError (naming the point) when the scene is out of range there."""
    from .timesweep import TIME_PARAMS, point_options

    s = point_seed(seed, params)
    # a budget of 0 means no wall-clock limit (see RESERVED)
    values = {**fixed, "montecarlo.budget": 0.0,
              **{k: v for k, v in params if k not in TIME_PARAMS}, "montecarlo.seed": s}
    try:
        scene = base.with_values(values)
    except SceneError as exc:
        at = ", ".join(f"{k} = {v:g}" for k, v in params)
        msg = str(exc).split(": ", 1)[-1] if ": " in str(exc) else str(exc)
        raise SweepError(f"{where}: at the point {at}: {msg}") from None
    if scene.sweep is not None:
        raise SweepError(f"{where}: scene: {scene.sweep.path} varies in the base scene; set "
                         "it in [set] or vary it in [vary]")
    if workflow in ("passage", "transient"):  # the point's own threshold, start
        bifurcation = point_options(bifurcation, params)
    _validate_point(scene, workflow, bifurcation, where, params)
    scene = _named(scene, f"{base.name}[{', '.join(f'{k}={v:g}' for k, v in params)}]")
    key = point_key(params)
    sde = workflow == "check" and sde_check_at(key, first=first)
    return Point(params=params, seed=s, key=key, scene=scene, sde=sde,
                 fingerprint=fingerprint(workflow, scene, bifurcation, sde=sde, models=models,
                                         tolerance=tolerance))


_CHECKED: set[Any] = set()  # Monte Carlo settings already validated in this process


def _validate_point(scene: Scene, workflow: str, bifurcation: Mapping[str, Any], where: str,
                    params: tuple[tuple[str, float], ...]) -> None:
    """A point's scene checked as `vifpk check` / `solve` check theirs before any work
    (magnitudes; the Monte Carlo settings where the workflow simulates)."""
    from . import validate

    try:
        validate.scene_magnitudes(scene)
        validate.stationary_density(scene)
        if workflow in ("passage", "transient"):
            from .timesweep import check_point

            check_point(workflow, bifurcation)
        if workflow in ("check", "passage", "transient") or (workflow == "bifurcation"
                                                             and bifurcation.get("mc")):
            # with a fixed step the checks depend on [montecarlo] and omega0 only: once each
            mc = scene.montecarlo
            key = (mc, scene.system.restoring_law[0]) if mc.dt != "auto" else None  # k1
            if key is None or key not in _CHECKED:
                validate.montecarlo_settings(scene)
                if key is not None:
                    _CHECKED.add(key)
    except BadInput as exc:  # SceneError, validate.InputError
        at = ", ".join(f"{k} = {v:g}" for k, v in params)
        raise SweepError(f"{where}: at the point {at}: {exc}") from None


def _named(scene: Scene, name: str) -> Scene:
    from dataclasses import replace

    return replace(scene, name=name)


# --------------------------------------------------------------------------------------------
# the point function: runs anywhere (this process, a process pool, a dask worker)
@dataclass(frozen=True, kw_only=True)
class Job:
    """What a worker needs to compute one point (picklable)."""

    key: str
    fingerprint: str
    params: tuple[tuple[str, float], ...]
    seed: int
    workflow: str
    scene: Scene
    bifurcation: Mapping[str, Any]
    sde: bool = True  # check: run the averaged SDEs' Monte Carlo (Point.sde)
    models: tuple[str, ...] | None = None  # None: the workflow's default models
    tolerance: float = TOLERANCE  # check: the tolerance verdict's value
    tolerance_question: tuple[str, str, float] = ("L1", "A", TOLERANCE_CONFIDENCE)


def run_point(job: Job) -> dict[str, Any]:
    """Compute one point; a failure is returned as a record with status "failed"."""
    t0 = time.perf_counter()
    rec: dict[str, Any] = {"key": job.key, "params": dict(job.params), "seed": job.seed,
                           "fingerprint": job.fingerprint, "workflow": job.workflow}
    try:
        result = WORKFLOW_FUNCTIONS[job.workflow](job)
    except Exception as exc:  # noqa: BLE001 - recorded with its message; the sweep goes on
        from vifpk.core.guard import PluginError

        from .run import SolverFailure

        kind = ("numerical" if isinstance(exc, SolverFailure | ArithmeticError | PluginError)
                else "error")
        text = str(exc).splitlines()[0] if str(exc) else ""
        rec.update(status="failed", failure=kind,
                   message=f"{type(exc).__name__}: {text}" if kind == "error" else text)
    else:
        rec.update(status="ok", message="", result=result)
    rec["seconds"] = time.perf_counter() - t0
    return rec


def _models(job: Job, default: tuple[str, ...]) -> tuple[str, ...]:
    return job.models if job.models is not None else default


def _flags(warnings: list[Any]) -> dict[str, bool]:
    kinds = {w.kind for w in warnings}
    return {k: v in kinds for k, v in WARNING_FLAGS.items()}


def _check_point(job: Job) -> dict[str, Any]:
    """The cross-check without the FPK: the averaging error of p(A) of each model."""
    import numpy as np

    from vifpk.core.guard import PluginError

    from .check import cross_check
    from .tolerance import Tolerance

    names, failed = list(_models(job, CHECK_MODELS)), {}
    while True:  # a plugin that fails is dropped, named, and the check run without it
        try:
            res = cross_check(job.scene, quiet=True, fpk=False, sde=job.sde, tail_mass=False,
                              models=tuple(names),
                              tolerance=Tolerance(value=job.tolerance,
                                                  metric=job.tolerance_question[0],
                                                  observable=job.tolerance_question[1],
                                                  confidence=job.tolerance_question[2]))
            break
        except PluginError as exc:
            if exc.model not in names or len(names) == 1:
                raise
            failed[exc.model] = str(exc)
            names.remove(exc.model)
    mc = res.solutions["mc:original"]
    conv = res.metrics["monte_carlo"]["convergence"]
    models = {}
    for m in res.metrics["models"]:
        e = res.metrics["models"][m]["averaging_error"]["A"]
        models[m] = {"averaging_error_A": e["L1"], "averaging_error_A_err": e["L1_err"],
                     "L1_floor_A": e["L1_floor"],
                     "mean_A": res.solutions[f"closed:{m}"].info["summary"]["mean"],
                     "verdict_class": str(res.metrics["models"][m].get("verdict_class", ""))}
        tv = res.metrics["models"][m].get("tolerance")
        if tv is not None:  # the tolerance verdict (issue 29): the error, noise removed
            models[m].update(error_estimate=tv["error_estimate"],
                             error_estimate_err=tv["error_estimate_err"],
                             p_within_tolerance=tv["p_within_tolerance"],
                             tolerance_class=tv["class"])
        if job.sde:  # only where the averaged SDE ran (SDE_CHECK_EVERY); -1 elsewhere
            models[m]["sampling_ok"] = bool(res.metrics["models"][m]["sampling_ok"])
    # the simulation's mean amplitude from its histogram of A with an exactly rounded sum, its
    # batch error from the moments (accumulated per path and summed in path order: the same
    # bits for any thread count and executor, tests/test_sweep.py)
    d = mc.data["A"]
    mean = {"value": math.fsum((d["x"] * d["p"] * np.diff(d["edges"])).tolist()),
            "err": float(mc.info["moments"]["A"]["mean"]["err"])}
    converged = conv.get("equilibrated") is not False and all(
        v.get("sampling_ok", True) for v in models.values())
    models.update({m: {"failure": t} for m, t in failed.items()})
    return {"models": models, "mean_A_simulation": mean["value"],
            "mean_A_simulation_err": mean["err"], "converged": converged,
            "extensions": conv.get("extensions", 0),
            "flags": {**_flags(res.warnings), "warn_not_converged": not converged},
            "recommended_model": res.metrics["recommended_model"],
            "warnings": [w.text for w in res.warnings], "verdicts": res.verdicts}


def _averaging_point(job: Job) -> dict[str, Any]:
    """Closed forms of each model (computed once), the L1 between them, the assumption
    warnings that need no simulation (strong damping, narrow band, strong noise)."""
    from vifpk.core.guard import PluginError

    from .check import assumption_warnings, models_of
    from .compare import compare
    from .run import run_solver
    from .validate import finite_result

    closed, failed = {}, {}
    for m in models_of(job.scene, _models(job, CHECK_MODELS))[0]:
        try:
            closed[m] = run_solver(job.scene, "averaging", model=m)
        except PluginError as exc:  # the plugin's failure; the other models' numbers stay
            failed[m] = str(exc)
    if not closed and failed:
        raise PluginError(next(iter(failed.values())))
    for r in closed.values():  # a point is "ok" only with finite numbers, as `solve` exits 3
        finite_result(r, job.scene)
    warnings = assumption_warnings(job.scene, closed, {})
    flags = _flags(warnings)
    flags.pop("warn_sticking")  # needs the simulation
    out: dict[str, Any] = {"models": {**{m: {"mean_A": r.info["summary"]["mean"]}
                                         for m, r in closed.items()},
                                      **{m: {"failure": t} for m, t in failed.items()}},
                           "flags": flags, "warnings": [w.text for w in warnings]}
    if "paper" in closed and "exact" in closed:
        out["L1_paper_exact_A"] = compare(closed["paper"].data["A"],
                                          closed["exact"].data["A"])["L1"]
    return out


def _bifurcation_point(job: Job) -> dict[str, Any]:
    """Critical mu or r of each model at this point, with the Monte Carlo checks."""
    from .bifurcation import bifurcation

    b = job.bifurcation
    lo, hi = b["range"] if b.get("range") else (None, None)
    res = bifurcation(job.scene, b["find"], lo=lo, hi=hi, mc=b["mc"],
                      models=_models(job, BIFURCATION_MODELS))
    checks = [{"value": c["value"], "crater": c["monte_carlo"]["shape"] == "crater",
               "agrees": c["agrees"]} for c in res.get("mc_check", [])]
    return {"models": {m: {"critical": c} for m, c in res["critical"].items()},
            "range": res["range"], "mc_check": checks}


def _passage_point(job: Job) -> dict[str, Any]:
    from .timesweep import passage_point

    return passage_point(job)


def _transient_point(job: Job) -> dict[str, Any]:
    from .timesweep import transient_point

    return transient_point(job)


WORKFLOW_FUNCTIONS: dict[str, Callable[[Job], dict[str, Any]]] = {
    "check": _check_point, "averaging": _averaging_point, "bifurcation": _bifurcation_point,
    "passage": _passage_point, "transient": _transient_point}


# --------------------------------------------------------------------------------------------
# executors
@dataclass(frozen=True, kw_only=True)
class ExecutorSpec:
    kind: str  # serial | processes | dask | tcp
    workers: int = 1
    address: str = ""

    def __str__(self) -> str:
        return {"serial": "serial", "processes": f"processes:{self.workers}",
                "dask": f"dask:{self.workers}"}.get(self.kind, self.address)


def parse_executor(text: str) -> ExecutorSpec:
    """``serial`` | ``processes:N`` | ``dask:N`` | ``tcp://HOST:PORT`` (SweepError if not)."""
    allowed = "allowed: serial, processes:N, dask:N, tcp://HOST:PORT"
    if text == "serial":
        return ExecutorSpec(kind="serial")
    kind, sep, rest = text.partition(":")
    if kind in ("processes", "dask") and sep:
        cores = os.cpu_count() or 1
        if not rest.isdigit() or not 1 <= int(rest) <= cores:
            # a local pool of more workers than cores only splits the same cores (each worker
            # runs numba on cores // N threads, at least one)
            raise SweepError(f"--executor {text}: N must be a whole number from 1 to the "
                             f"{cores} cores of this machine (a larger cluster: tcp://HOST:PORT)"
                             f"; {allowed}")
        spec = ExecutorSpec(kind=kind, workers=int(rest))
    elif kind == "tcp" and rest.startswith("//"):
        from urllib.parse import urlsplit

        where = urlsplit(text)
        try:
            port = where.port
        except ValueError:  # not a number, or out of range
            port = None
        if not where.hostname or port is None or not 1 <= port <= 65535 or where.path \
                or where.query or where.fragment:
            raise SweepError(f"--executor {text}: expected tcp://HOST:PORT with PORT in "
                             "1-65535 (an IPv6 host in brackets: tcp://[::1]:8786)")
        spec = ExecutorSpec(kind="tcp", address=text)
    else:
        raise SweepError(f"--executor {text}: unknown executor; {allowed}")
    if spec.kind in ("dask", "tcp"):
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise SweepError(f"--executor {text}: dask.distributed is not installed; install "
                             f"the 'cluster' extra: {EXTRA_HINT}") from None
    return spec


def require_output_libraries() -> None:
    """sweep.nc needs xarray and netCDF4 (the `sweep` extra): say so before any work."""
    try:
        import netCDF4  # noqa: F401
        import xarray  # noqa: F401
    except ImportError as exc:
        raise SweepError(f"sweep.nc needs xarray and netCDF4 ({exc.name} is missing); install "
                         "the 'sweep' extra: pip install 'vifpk[sweep]'") from None


def threads_per_worker(workers: int) -> int:
    """numba threads for each of ``workers`` local workers: cores // workers (at least 1)."""
    return max((os.cpu_count() or 1) // workers, 1)


def _die_with_parent() -> None:
    """Linux: this process gets SIGKILL when the process that started it dies, however it
    dies (SIGKILL included): no worker outlives its sweep (prctl PR_SET_PDEATHSIG)."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # 1: SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() == 1:  # the parent died before the call: follow it now
        os._exit(1)


def _init_worker(threads: int) -> None:
    """Process-pool initializer: die with the sweep (:func:`_die_with_parent`); Ctrl-C on
    the terminal's process group is the sweep's to handle (it stops the workers), so the
    worker ignores SIGINT; numba threads per worker (before numba is imported)."""
    import signal

    _die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ["NUMBA_NUM_THREADS"] = str(threads)
    if "numba" in sys.modules:
        import numba

        numba.config.NUMBA_NUM_THREADS = threads
        numba.set_num_threads(threads)


def dask_setup(worker: Any = None) -> None:
    """dask preload of a local cluster's workers (``preload=["vifpk.harness.sweep"]``): Ctrl-C on
    the terminal's process group is the sweep's to handle; the worker ignores it."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextmanager
def _signals_blocked() -> Iterator[None]:
    """SIGINT blocked in this thread while local workers are started: they inherit the mask
    (fork and exec keep it), so Ctrl-C on the terminal's process group reaches only the
    sweep, which stops them (:meth:`Runner.stop`); a Ctrl-C meanwhile waits, then arrives."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


class Runner:
    """An open executor: ``completed(jobs)`` yields records as points finish."""

    def __init__(self, spec: ExecutorSpec, *, connect_timeout: float = 10.0):
        self.spec = spec
        self.stopped = False
        self.client: Any = None
        self.cluster: Any = None
        self.pool: Any = None
        if spec.kind == "processes":
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            self.pool = ProcessPoolExecutor(
                max_workers=spec.workers, mp_context=multiprocessing.get_context("spawn"),
                initializer=_init_worker, initargs=(threads_per_worker(spec.workers),))
        elif spec.kind == "dask":
            from distributed import Client, LocalCluster

            threads = threads_per_worker(spec.workers)
            import logging

            with _signals_blocked():  # Ctrl-C is the sweep's to handle, not the workers'
                self.cluster = LocalCluster(
                    n_workers=spec.workers, threads_per_worker=1, processes=True,
                    # any free port for its HTTP server: two clusters on one machine do not
                    # collide on 8787 (and warn about it)
                    dashboard_address=":0", host="127.0.0.1", silence_logs=logging.ERROR,
                    env={"NUMBA_NUM_THREADS": str(threads)}, preload=["vifpk.harness.sweep"])
            self.client = Client(self.cluster)
        elif spec.kind == "tcp":
            import socket
            from urllib.parse import urlsplit

            from distributed import Client

            try:
                # a plain TCP probe first: a refused connection is known at once, whereas
                # dask's Client retries it until its timeout runs out
                where = urlsplit(spec.address)
                socket.create_connection((where.hostname, where.port),
                                         timeout=connect_timeout).close()
                self.client = Client(spec.address, timeout=connect_timeout)
            except (OSError, TimeoutError, ValueError) as exc:
                raise SweepError(f"--executor {spec.address}: no dask scheduler answers there "
                                 f"({type(exc).__name__}); start one with `dask scheduler` "
                                 "and workers with `dask worker ADDRESS`") from None

    @property
    def workers(self) -> int:
        if self.client is not None:
            return max(len(self.client.scheduler_info().get("workers", {})), 1)
        return self.spec.workers

    def completed(self, jobs: list[Job], *, retries: int = 2) -> Iterator[dict[str, Any]]:
        """Records in the order the points finish. A worker that dies takes no point with it:
        dask reschedules the point elsewhere; a broken process pool raises WorkerLost."""
        if self.spec.kind == "serial":
            for job in jobs:
                yield run_point(job)
        elif self.pool is not None:
            from concurrent.futures import as_completed
            from concurrent.futures.process import BrokenProcessPool

            with _signals_blocked():  # the pool starts its workers here
                futs = [self.pool.submit(run_point, job) for job in jobs]
            try:
                for f in as_completed(futs):
                    yield f.result()
            except BrokenProcessPool as exc:
                raise WorkerLost(f"a worker process died ({exc})") from None
            finally:
                for f in futs:
                    f.cancel()
        else:
            from distributed import as_completed

            # one dask key per point and fingerprint: dask never runs a key twice at once,
            # reschedules it when its worker dies, and retries it on an exception
            futs = [self.client.submit(run_point, job, key=f"vifpk-{job.key}-"
                                       f"{job.fingerprint[:12]}", retries=retries, pure=False)
                    for job in jobs]
            from distributed import KilledWorker

            try:
                for f in as_completed(futs):
                    yield f.result()
            except KilledWorker as exc:
                raise WorkerLost(f"dask gave up on a point whose workers kept dying ({exc})"
                                 ) from None
            finally:
                self.client.cancel([f for f in futs if not f.done()])

    def stop(self) -> None:
        """Stop at once (Ctrl-C, SIGTERM): cancel what is queued and end the pool's worker
        processes (ProcessPoolExecutor.terminate_workers from Python 3.14, done the same way
        before it); dask's workers are ended by :meth:`close` (and die with this process)."""
        pool = self.pool
        if pool is None:
            return
        self.stopped = True
        procs = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        if hasattr(pool, "terminate_workers"):
            pool.terminate_workers()
        else:
            for proc in procs:
                try:
                    proc.terminate()
                except (OSError, ValueError, AttributeError):
                    pass
        for proc in procs:  # reap them: gone before this process says it stopped
            proc.join(timeout=1.0)

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=not self.stopped, cancel_futures=True)
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()


# --------------------------------------------------------------------------------------------
def load_record(path: Path) -> dict[str, Any] | None:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def finished(sweep: Sweep, out: Path) -> dict[str, dict[str, Any]]:
    """Records of this sweep's points already on disk (matching fingerprints), by key.

    A numerical failure is a result (the same point fails the same way again) and counts as
    finished; a point that failed with any other error (a bug, a missing library) is retried.
    """
    done = {}
    for pt in sweep.points:
        rec = load_record(out / "points" / f"{pt.key}.json")
        if rec and rec.get("fingerprint") == pt.fingerprint and (
                rec.get("status") == "ok" or rec.get("failure") == "numerical"):
            done[pt.key] = rec
    return done


def _job(sweep: Sweep, pt: Point) -> Job:
    return Job(key=pt.key, fingerprint=pt.fingerprint, params=pt.params, seed=pt.seed,
               workflow=sweep.workflow, scene=pt.scene, bifurcation=sweep.bifurcation,
               sde=pt.sde, models=sweep.models, tolerance=sweep.tolerance,
               tolerance_question=sweep.tolerance_question)


def _tolerance(sweep: Sweep) -> Any:
    """The sweep's tolerance question as a harness.tolerance.Tolerance."""
    from .tolerance import Tolerance

    metric, observable, confidence = sweep.tolerance_question
    return Tolerance(value=sweep.tolerance, metric=metric, observable=observable,
                     confidence=confidence)


@dataclass(frozen=True, kw_only=True)
class SweepRun:
    """What a run of a sweep did: the keys it computed (in order), skipped and failed."""

    total: int
    computed: tuple[str, ...]
    skipped: int
    failed: tuple[str, ...]
    seconds: float
    files: Mapping[str, Path]


def _log(quiet: bool, text: str) -> None:
    if not quiet:
        print(text, file=sys.stderr, flush=True)


#: what a sweep writes into its folder (outdir.KINDS["sweep"] tells such a folder apart)
SWEEP_FILES = {"points": "folder", "sweep.nc": "file", "report.html": "file"}


def check_sweep_folder(out: str | Path) -> Path:
    """Refuse, before any work, an output folder a sweep cannot use: a file; a folder holding
    another kind of output (a check report) or foreign files; ``points`` that is not a folder,
    ``sweep.nc`` or ``report.html`` that are not files (SweepError naming them)."""
    from . import outdir

    target = outdir._resolve(out)
    try:
        outdir.check_replaceable(target, set(SWEEP_FILES), "sweep")
    except SceneError as exc:
        raise SweepError(f"--out {exc}") from None
    for name, what in SWEEP_FILES.items():
        p = target / name
        if p.is_symlink() or (p.exists() and (p.is_dir() != (what == "folder"))):
            raise SweepError(f"--out {out}: {name} exists and is not a {what}; a sweep writes "
                             f"its {'point records' if what == 'folder' else name} there; "
                             "move it away or choose another --out")
    return target


def sweep_seconds(sweep: Sweep, *, speed: float | None = None) -> float:
    """Lower bound of the wall time of the sweep's points on this machine (validate.py's
    estimates: a check point is its Monte Carlo and closed forms, an averaging point its
    closed forms, a bifurcation point its Monte Carlo checks (two per model) or, without
    them, ~20 closed-form evaluations per model). Local executors share the same cores, so
    the points' times add up; a remote cluster may be faster (confirm with --yes)."""
    from . import validate as v
    from .check import models_of

    wanted = sweep.models or (BIFURCATION_MODELS if sweep.workflow == "bifurcation"
                              else CHECK_MODELS)
    total = 0.0
    seen: dict[Any, float] = {}

    def mc_seconds(sc: Scene) -> float:
        # with a fixed step the estimate depends on [montecarlo] and omega0 only
        key = ((sc.montecarlo, sc.system.restoring_law[0]) if sc.montecarlo.dt != "auto"
               else None)  # k1 = omega0^2
        if key is None or key not in seen:
            value = v.montecarlo_seconds(sc, speed=speed)
            if key is None:
                return value
            seen[key] = value
        return seen[key]

    for pt in sweep.points:
        sc = pt.scene
        models = models_of(sc, wanted)[0]
        closed = sum(v.averaging_seconds(sc, m) for m in models)
        if sweep.workflow == "check":
            total += mc_seconds(sc) + closed
        elif sweep.workflow in ("passage", "transient"):
            total += closed  # the Monte Carlo is priced at the point, from the models' MFPT
        elif sweep.workflow == "averaging":
            total += closed
        elif sweep.bifurcation.get("mc"):
            total += 4 * mc_seconds(sc) + 20 * closed
        else:
            total += 20 * closed
    if sweep.mode == "adaptive" and sweep.points:  # the lattice stands for the whole budget
        total *= max(sweep.adaptive["points"] / len(sweep.points), 1.0)
    return total


def _clear_temporaries(out: Path) -> None:
    """Remove the temporary files of killed atomic writes (call with the folder held)."""
    for folder in (out, out / "points"):
        if folder.is_dir():
            for p in folder.glob(".*.tmp*"):  # io._temp_beside: .NAME.<hex>.tmp<suffix>
                p.unlink(missing_ok=True)


def _kept_message(out: Path, done: int, computed: list[str], todo: int) -> str:
    n = done + len(computed)
    if n == 0:
        return "vifpk: interrupted; no point had finished, nothing was kept"
    rest = todo - len(computed)
    return (f"vifpk: interrupted; {n} finished point{'s' if n != 1 else ''} "
            f"({len(computed)} from this run) kept in {out / 'points'}; no sweep.nc written; "
            f"run the same command again to compute the other {rest}")


def run_sweep(sweep: Sweep, out: str | Path, *, executor: str | ExecutorSpec = "serial",
              quiet: bool = False, report: bool = True,
              provenance: Mapping[str, Any] | None = None) -> SweepRun:
    """Compute every unfinished point on the executor, then write sweep.nc (and the maps).

    The folder is held for the whole run with the lock of every vifpk output folder
    (harness/outdir.py): a second run into it is refused; a folder holding another kind of
    output is refused (:func:`check_sweep_folder`). Raises SweepError (bad folder or executor,
    unreachable scheduler) before anything is computed or written. Ctrl-C or SIGTERM stop the
    workers and keep every record written so far (``signals.message()`` says how many).
    """
    from . import outdir, signals
    from .provenance import new_run_id

    spec = parse_executor(executor) if isinstance(executor, str) else executor
    require_output_libraries()
    target = check_sweep_folder(out)
    run_id = str((provenance or {}).get("run_id") or new_run_id())
    with outdir.hold(target, run_id=run_id, allowed=set(SWEEP_FILES), kind="sweep"):
        _clear_temporaries(target)
        if sweep.mode == "adaptive":
            return run_adaptive(sweep, out, executor=spec, quiet=quiet, report=report,
                                provenance=provenance)
        return _run_held(sweep, Path(out), spec, quiet=quiet, report=report,
                         provenance=provenance, signals=signals)


def _run_held(sweep: Sweep, out: Path, spec: ExecutorSpec, *, quiet: bool, report: bool,
              provenance: Mapping[str, Any] | None, signals: Any) -> SweepRun:
    from .io import write_json

    done = finished(sweep, out)
    todo = [pt for pt in sweep.points if pt.key not in done]
    total = len(sweep.points)
    computed: list[str] = []
    signals.set_message(lambda: _kept_message(out, len(done), computed, len(todo)))
    runner = Runner(spec) if todo else None  # connects (or fails) before anything is written
    t0 = time.perf_counter()
    failed = [k for k, r in done.items() if r["status"] == "failed"]
    by_key = {pt.key: pt for pt in sweep.points}
    _log(quiet, f"sweep {sweep.name}: {total} points ({len(done)} done before, {len(todo)} to "
                f"compute) on {spec}, workflow {sweep.workflow}")
    handle = signals.on_interrupt(runner.stop) if runner is not None else None
    if spec.kind in ("dask", "tcp"):
        signals.set_grace(20.0)  # closing a client or a local cluster takes seconds
    try:
        if runner is not None:
            (out / "points").mkdir(parents=True, exist_ok=True)
            for rec in runner.completed([_job(sweep, pt) for pt in todo]):
                write_json(out / "points" / f"{rec['key']}.json", rec)
                computed.append(rec["key"])
                if rec["status"] == "failed":
                    failed.append(rec["key"])
                n = len(computed)
                elapsed = time.perf_counter() - t0
                eta = elapsed / n * (len(todo) - n)
                what = "ok" if rec["status"] == "ok" else f"FAILED: {rec['message']}"
                _log(quiet, f"[{len(done) + n}/{total}] {by_key[rec['key']].label()}: {what} "
                            f"({rec['seconds']:.1f} s); failures {len(failed)}; "
                            f"ETA {_duration(eta)}")
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM: the message says what was kept
        if runner is not None:
            runner.stop()  # no worker outlives the sweep
        raise
    finally:
        if handle is not None:
            signals.forget(handle)
        if runner is not None:
            runner.close()
    files = write_results(sweep, out, executor=str(spec), report=report, provenance=provenance)
    return SweepRun(total=total, computed=tuple(computed), skipped=len(done),
                    failed=tuple(failed), seconds=time.perf_counter() - t0, files=files)


def _reusable(rec: dict[str, Any] | None, pt: Point) -> bool:
    """A record on disk is this point's finished result (see ``finished``)."""
    return bool(rec and rec.get("fingerprint") == pt.fingerprint and (
        rec.get("status") == "ok" or rec.get("failure") == "numerical"))


def adaptive_value(rec: dict[str, Any], model: str) -> float:
    """f = log(L1 / (2 floor)) of ``model`` at a finished point (NaN for a failed one)."""
    from .adaptive import log_ratio

    m = (rec.get("result") or {}).get("models", {}).get(model, {})
    return log_ratio(m.get("averaging_error_A"), m.get("L1_floor_A"))


def run_adaptive(sweep: Sweep, out: str | Path, *, executor: ExecutorSpec,
                 quiet: bool = False, report: bool = True,
                 provenance: Mapping[str, Any] | None = None) -> SweepRun:
    """An adaptive sweep (mode = "adaptive"): the initial lattice, then batches of
    ``[adaptive] batch`` points chosen by harness.adaptive from every finished point, until
    ``[adaptive] points`` or the resolution is reached; then sweep.nc (a ``point`` dimension)
    and the maps.

    The batches are replayed from the records on disk: a point with a record is not computed
    again, and since the choice of a batch depends only on the points before it and their
    results, a sweep started again (after Ctrl-C, a lost machine) chooses the same points and
    computes only those without a record. Progress and ETA on stderr, one line a point.
    """
    from dataclasses import replace

    from .adaptive import next_batch
    from .io import write_json

    require_output_libraries()
    out = Path(out)
    ad = sweep.adaptive
    budget, size, model = ad["points"], ad["batch"], ad["model"]
    if executor.kind in ("processes", "dask") and executor.workers > size:
        _log(quiet, f"note: {executor} has {executor.workers} workers but [adaptive] batch = "
                    f"{size}; set batch >= the workers to keep them busy (the batch size "
                    "chooses the points, the executor does not)")
    from . import signals

    runner = Runner(executor)  # connects (or fails) before anything is written
    handle = signals.on_interrupt(runner.stop)
    t0 = time.perf_counter()
    order: list[Point] = []
    units: list[tuple[float, ...]] = []
    values: list[float] = []
    computed: list[str] = []
    failed: list[str] = []
    skipped = 0
    spent = 0.0  # seconds of the points computed in this run (for the ETA)
    _log(quiet, f"sweep {sweep.name}: adaptive, up to {budget} points in batches of {size} on "
                f"{executor}, refining the {model} model's verdict (L1 < 2 x floor)")
    from .adaptive import initial_design

    batch_units = initial_design(len(sweep.vary), budget)
    batch_no = 0
    signals.set_message(lambda: _kept_message(out, skipped, computed, budget - skipped))
    try:
        while batch_units:
            pts = []
            for u in batch_units:
                if not order and not pts:  # the sweep's first point: as load_sweep built it
                    pt = sweep.points[0]
                else:
                    pt = make_point(sweep.base, sweep.fixed, seed=sweep.seed,
                                    workflow=sweep.workflow, bifurcation=sweep.bifurcation,
                                    params=adaptive_params(sweep.vary, u), where=sweep.name,
                                    models=sweep.models, tolerance=_tolerance(sweep))
                pts.append(replace(pt, batch=batch_no))
            recs: dict[str, dict[str, Any]] = {}
            todo = []
            for pt in pts:
                rec = load_record(out / "points" / f"{pt.key}.json")
                if _reusable(rec, pt):
                    recs[pt.key] = rec
                    skipped += 1
                    if rec["status"] == "failed":
                        failed.append(pt.key)
                else:
                    todo.append(pt)
            if todo:
                (out / "points").mkdir(parents=True, exist_ok=True)
                by_key = {pt.key: pt for pt in todo}
                for rec in runner.completed([_job(sweep, pt) for pt in todo]):
                    write_json(out / "points" / f"{rec['key']}.json", rec)
                    recs[rec["key"]] = rec
                    computed.append(rec["key"])
                    spent = time.perf_counter() - t0
                    if rec["status"] == "failed":
                        failed.append(rec["key"])
                    n = len(order) + len(recs)
                    # every remaining point costs what the computed ones did on average
                    eta = spent / len(computed) * max(budget - n, 0)
                    what = "ok" if rec["status"] == "ok" else f"FAILED: {rec['message']}"
                    f = adaptive_value(rec, model)
                    verdict = "" if math.isnan(f) else (
                        f"; {model} {'within' if f < 0 else 'outside'} the noise "
                        f"(L1 / 2 floor = {math.exp(f):.2f})")
                    _log(quiet, f"[{n}/{budget}] batch {batch_no}: {by_key[rec['key']].label()}"
                                f": {what}{verdict} ({rec['seconds']:.1f} s); failures "
                                f"{len(failed)}; ETA {_duration(eta)}")
            for pt, u in zip(pts, batch_units, strict=True):
                order.append(pt)
                units.append(tuple(u))
                values.append(adaptive_value(recs[pt.key], model))
            if len(order) >= budget:
                break
            batch_no += 1
            batch_units = next_batch(units, values, min(size, budget - len(order)),
                                     resolution=ad["resolution"])
            if not batch_units:
                _log(quiet, f"every triangle is finer than the resolution "
                            f"({ad['resolution']} x {ad['resolution']}): stopped at "
                            f"{len(order)} points")
    except KeyboardInterrupt:  # Ctrl-C or SIGTERM: stop the workers; the message says why
        runner.stop()
        raise
    finally:
        signals.forget(handle)
        runner.close()
    done = replace(sweep, points=tuple(order))
    files = write_results(done, out, executor=str(executor), report=report,
                          provenance=provenance)
    return SweepRun(total=len(order), computed=tuple(computed), skipped=skipped,
                    failed=tuple(failed), seconds=time.perf_counter() - t0, files=files)


def _duration(s: float) -> str:
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.1f} min"
    return f"{s / 3600:.1f} h"


# --------------------------------------------------------------------------------------------
def dataset(sweep: Sweep, records: Mapping[str, dict[str, Any]], *,
            provenance: Mapping[str, Any] | None = None) -> Any:
    """The labelled result (xarray.Dataset) from the points' records."""
    import numpy as np
    import xarray as xr

    if sweep.mode == "product":
        dims = list(sweep.names)
        shape = tuple(len(v) for _, v in sweep.vary)
        coords: dict[str, Any] = {k: (k, np.array(v)) for k, v in sweep.vary}

        def index(pt: Point) -> tuple[int, ...]:
            return tuple(vals.index(v) for (_, vals), (_, v) in zip(sweep.vary, pt.params,
                                                                    strict=True))
    else:  # zip and adaptive: the parameters as coordinates along a point dimension
        dims = ["point"]
        shape = (len(sweep.points),)
        coords = {k: ("point", np.array([dict(pt.params)[k] for pt in sweep.points]))
                  for k in sweep.names}
        order = {pt.key: i for i, pt in enumerate(sweep.points)}

        def index(pt: Point) -> tuple[int, ...]:
            return (order[pt.key],)

    recs = [(pt, records.get(pt.key)) for pt in sweep.points]
    models: list[str] = []
    for _, r in recs:
        for m in (r or {}).get("result", {}).get("models", {}):
            if m not in models:
                models.append(m)
    data: dict[str, Any] = {}

    def put(name: str, value: Any, pt: Point, model: str | None = None,
            dtype: Any = float, fill: Any = np.nan) -> None:
        if name not in data:
            s = shape + ((len(models),) if model is not None else ())
            data[name] = (dims + (["model"] if model is not None else []),
                          np.full(s, fill, dtype=dtype))
        idx = index(pt) + ((models.index(model),) if model is not None else ())
        data[name][1][idx] = fill if value is None else value

    status = np.full(shape, "missing", dtype=object)
    message = np.full(shape, "", dtype=object)
    keys = np.full(shape, "", dtype=object)
    seeds = np.zeros(shape, dtype=np.int64)
    for pt, r in recs:
        i = index(pt)
        keys[i], seeds[i] = pt.key, pt.seed
        if r is None:
            continue
        status[i], message[i] = r["status"], r.get("message", "")
        res = r.get("result")
        if res is None:
            continue
        for m, vals in res.get("models", {}).items():
            for k, v in vals.items():
                if isinstance(v, bool):
                    put(k, int(v), pt, m, dtype=np.int8, fill=-1)
                elif isinstance(v, str):
                    put(k, v, pt, m, dtype=object, fill="")
                else:
                    put(k, v, pt, m)
        for k in ("mean_A_simulation", "mean_A_simulation_err", "L1_paper_exact_A",
                  *TIME_SCALARS):
            if k in res:
                put(k, res[k], pt)
        if "recommended_model" in res:  # check's recommendation (issue 23): a string per point
            put("recommended_model", res["recommended_model"], pt, dtype=object, fill="")
        if "extensions" in res:
            put("extensions", res["extensions"], pt, dtype=np.int16, fill=-1)
        if "converged" in res:
            put("converged", int(res["converged"]), pt, dtype=np.int8, fill=-1)
        for k, v in res.get("flags", {}).items():
            put(k, int(v), pt, dtype=np.int8, fill=-1)
    if sweep.workflow == "bifurcation":
        width = max([len((r or {}).get("result", {}).get("mc_check", [])) for _, r in recs]
                    + [0])
        vals = np.full(shape + (width,), np.nan)
        crater = np.full(shape + (width,), -1, dtype=np.int8)
        agrees = np.full(shape + (width, len(models)), -1, dtype=np.int8)
        for pt, r in recs:
            for j, c in enumerate((r or {}).get("result", {}).get("mc_check", [])):
                vals[index(pt) + (j,)] = c["value"]
                crater[index(pt) + (j,)] = int(c["crater"])
                for mi, m in enumerate(models):
                    agrees[index(pt) + (j, mi)] = int(c["agrees"].get(m, False))
        data["mc_check_value"] = (dims + ["check"], vals)
        data["mc_check_crater"] = (dims + ["check"], crater)
        data["mc_check_agrees"] = (dims + ["check", "model"], agrees)
    for k, (d, arr) in list(data.items()):
        if arr.dtype == object:
            data[k] = (d, arr.astype(str))
    data["failed"] = (dims, (status == "failed").astype(np.int8))
    data["status"] = (dims, status.astype(str))
    data["message"] = (dims, message.astype(str))
    data["key"] = (dims, keys.astype(str))
    data["seed"] = (dims, seeds)
    if sweep.mode == "adaptive":
        data["batch"] = (dims, np.array([pt.batch for pt in sweep.points], dtype=np.int16))
    if models:
        coords["model"] = ("model", np.array(models))
    ds = xr.Dataset(data, coords=coords)
    for k in WARNING_FLAGS:
        if k in ds:
            ds[k].attrs["flag_values"] = "1: the warning applies, 0: it does not, -1: no value"
    if "sampling_ok" in ds:
        ds["sampling_ok"].attrs["flag_values"] = (
            "1: the averaged SDE's Monte Carlo matches its closed form, 0: it does not, -1: not "
            f"run at this point (it runs at the first point and where int(key, 16) % "
            f"{SDE_CHECK_EVERY} == 0)")
    ds.attrs.update({
        "title": f"vifpk sweep {sweep.name}",
        "workflow": sweep.workflow, "mode": sweep.mode, "seed": sweep.seed,
        "varied": json.dumps(list(sweep.names)),
        "sweep_file": sweep.text, "sweep_path": sweep.path,
        "base_scene": json.dumps(sweep.base.to_dict()),
        "seed_scheme": "montecarlo.seed of a point = SeedSequence([seed, *le32 words of "
                       "sha256(canonical params)]).generate_state(1, uint64)[0] >> 2",
    })
    if sweep.workflow == "bifurcation":
        ds.attrs["bifurcation"] = json.dumps(dict(sweep.bifurcation))
    if sweep.workflow in ("passage", "transient"):
        ds.attrs[sweep.workflow] = json.dumps(dict(sweep.bifurcation))
    if sweep.mode == "adaptive":
        ds.attrs["adaptive"] = json.dumps({**sweep.adaptive, "ranges": {
            k: list(v) for k, v in sweep.vary}})
        ds["batch"].attrs["meaning"] = ("0: the initial lattice; n: the n-th refinement batch "
                                        "(harness/adaptive.py)")
    if sweep.workflow == "check":
        ds.attrs["within_noise"] = ("a model is within the Monte Carlo noise where "
                                    "averaging_error_A < 2 L1_floor_A (the check's verdict)")
        tol = _tolerance(sweep)
        ds.attrs["tolerance"] = tol.value
        ds.attrs["tolerance_metric"] = tol.metric
        ds.attrs["tolerance_observable"] = tol.observable
        ds.attrs["tolerance_confidence"] = tol.confidence
        ds.attrs["tolerance_meaning"] = (
            f"the question: {tol.words()}; error_estimate: {tol.metric} of "
            f"p({tol.observable}) with the Monte Carlo noise removed, sqrt(max(d^2 - floor^2, "
            "0)); p_within_tolerance: P(error <= tolerance); tolerance_class: inside / outside "
            "/ undecided at that confidence (harness/tolerance.py)")
    if provenance is not None:
        ds.attrs["provenance"] = json.dumps(dict(provenance))
        ds.attrs["versions"] = json.dumps(provenance.get("versions", {}))
        ds.attrs["vifpk_version"] = str(provenance.get("vifpk", ""))
    return ds


def write_netcdf(ds: Any, path: Path) -> Path:
    """Write a Dataset atomically (temporary file beside it, then rename). The temporary file
    is created with mode 0666 minus the umask, as every other output (netCDF keeps the mode of
    the file it overwrites; ``tempfile`` would give 0600)."""
    from .io import atomic_path

    with atomic_path(path) as tmp:
        ds.to_netcdf(tmp, engine="netcdf4")
    return path


def write_results(sweep: Sweep, out: Path, *, executor: str = "", report: bool = True,
                  provenance: Mapping[str, Any] | None = None) -> dict[str, Path]:
    """DIR/sweep.nc (and DIR/report.html) from the records on disk."""
    from . import provenance as prov

    records = {}
    for pt in sweep.points:
        rec = load_record(out / "points" / f"{pt.key}.json")
        if rec and rec.get("fingerprint") == pt.fingerprint:
            records[pt.key] = rec
    if provenance is None:
        provenance = prov.collect(scene_path=sweep.path)
    ds = dataset(sweep, records, provenance={**provenance, "executor": executor})
    files = {"sweep.nc": write_netcdf(ds, out / "sweep.nc")}
    if report:
        from .sweepmaps import write_maps

        files["report.html"] = write_maps(sweep, ds, out)
    return files
