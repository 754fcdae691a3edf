"""Sweeps: one workflow run at every point of a parameter grid, on any executor.

A sweep file (TOML, issue 14; docs/maps.md) names a base scene, the workflow, fixed overrides and
the varied parameters::

    scene = "paper-base"          # a shipped scene name or a path (relative to the sweep file)
    workflow = "check"            # "check" | "averaging" (closed forms only) | "bifurcation"
                                  # | "passage" | "transient" (harness/sweeps/timesweep.py)
    mode = "product"              # or "zip"
    seed = 7                      # optional; default the base scene's montecarlo.seed
    models = ["paper", "mine"]    # optional: registered averaged models (vifpk.core.registry);
                                  # default: the workflow's own (check, averaging: CHECK_MODELS;
                                  # bifurcation: BIFURCATION_MODELS, vifpk.core.defaults)
    tolerance = 0.02              # optional, check only: the tolerance verdict's L1(A); per
                                  # point and model error_estimate(_err), p_within_tolerance,
                                  # tolerance_class (harness/workflows/tolerance.py); or a table
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

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from vifpk.harness.sweeps.errors import SweepError
from vifpk.harness.sweeps.keys import key_field
from vifpk.harness.sweeps.points import (
    Sweep,
    canonical,
    make_point,
    sweep_functions,
)

from vifpk.core.defaults import CHECK_MODELS, TOLERANCE
from vifpk.core.scene import (
    Scene,
    SceneError,
    load_scene,
)

MODES = ("product", "zip", "adaptive")


TOP_KEYS = ("scene", "workflow", "mode", "seed", "name", "description", "vary", "set",
            "bifurcation", "adaptive", "models", "tolerance", "passage", "transient")


ADAPTIVE_KEYS = ("points", "model", "batch", "resolution", "method")
#: "verdict": refine where the verdict within the noise changes (adaptive.py); "band": shrink the
#: tolerance band by new points and longer runs (band.py), the default when a tolerance is given
ADAPTIVE_METHODS = ("verdict", "band")


#: points of an adaptive batch unless [adaptive] batch says otherwise: a property of the sweep
#: file, not of the executor, so that the points do not depend on where they run
ADAPTIVE_BATCH = 8


ADAPTIVE_RESOLUTION = 40  # refine the boundary as finely as a 40 x 40 grid (adaptive.min_edge)
#: a band sweep weighs every lattice place (resolution^dims candidates) with their covariance
#: (band.choose: candidates^2 doubles, 134 MB at 4096, and 41^2 x candidates for the band's
#: grid), so the lattice holds at most MAX_CANDIDATES places: resolution <= 64 in 2-D
MAX_CANDIDATES = 4096
#: the verdict refiner's finest cell: 1/999 of each range (its triangles stop there)
MAX_VERDICT_RESOLUTION = 1000


BIFURCATION_KEYS = ("find", "range", "mc")


FIND = {"mu": "system.mu", "r": "system.r"}


#: the largest grid a sweep file may ask for: building and validating a point's scene costs
#: ~1-3 ms (measured 2026-11-23: 10000 points in 24 s at load average 10 on 2 cores), so a
#: 1000 x 1000 grid was silent for many minutes before any work
MAX_POINTS = 20_000


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


def _resolve_scene(name: Any, sweep_path: Any) -> tuple[Scene, Path | None]:
    """The sweep's base scene and the file it was read from (None: not a file on disk): a path
    (relative to the sweep file) must exist; a bare name is a scene file ``NAME.toml`` beside
    the sweep file, else the shipped scene of that name."""
    from vifpk.core.provenance import scene_file
    from vifpk.core.scene import shipped_name

    if not isinstance(name, str) or not name:
        raise SweepError(f"{sweep_path.name}: scene must be a shipped scene name or a path")
    if isinstance(sweep_path, Path):  # a sweep file on disk: paths relative to it
        if not shipped_name(name):
            path = sweep_path.parent / Path(name).expanduser()
            return load_scene(path), path
        beside = sweep_path.parent / f"{name}.toml"
        if beside.is_file():
            return load_scene(beside), beside
    return load_scene(name), scene_file(name)


def inputs(sweep: Sweep) -> list[tuple[str, Path]]:
    """(what, path) of the files a sweep reads: the sweep file and its base scene's file, as
    load_sweep resolved them (for harness.request.validate.outputs_apart_from_inputs: no
    second reading of the sweep file)."""
    out = [("the sweep file", Path(sweep.path))]
    if sweep.base_file is not None:
        out.append(("the sweep's scene file", Path(sweep.base_file)))
    return [(what, p.resolve()) for what, p in out if p.is_file()]


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
        base, base_file = _resolve_scene(raw["scene"], p)
    except SweepError:
        raise
    except SceneError as exc:
        raise SweepError(f"{src}: scene: {exc}") from None
    workflow = raw.get("workflow", "check")
    if workflow not in sweep_functions():
        raise SweepError(f"{src}: workflow = {workflow!r}: unknown workflow; allowed: "
                         + ", ".join(sweep_functions()))
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
    from vifpk.harness.request.tolerance import Tolerance, ToleranceError

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
        f = key_field(f"{src}: [vary]", key)
        if f.type not in ("float", "float | str", "float | None"):
            raise SweepError(f"{src}: [vary] {key!r}: only numeric parameters can vary")
        vary.append((key, _range(f"{src}: [vary] {key!r}", spec) if mode == "adaptive"
                     else _values(f"{src}: [vary] {key!r}", spec)))
    adaptive = _adaptive_table(src, raw, mode, workflow, len(vary), models or CHECK_MODELS,
                               tolerance_given="tolerance" in raw)
    if mode == "zip" and len({len(v) for _, v in vary}) > 1:
        lens = ", ".join(f"{k}: {len(v)}" for k, v in vary)
        raise SweepError(f"{src}: mode = 'zip' needs lists of one length ({lens})")
    fixed_raw = raw.get("set", {})
    if not isinstance(fixed_raw, Mapping):
        raise SweepError(f"{src}: [set] must be a table of section.key = value")
    for key in fixed_raw:
        key_field(f"{src}: [set]", key)
        if key in vary_raw:
            raise SweepError(f"{src}: [set] {key!r}: also in [vary]; keep one")
    clash = shared_term([*vary_raw, *fixed_raw])
    if clash is not None:  # the rule --set follows (validate.duplicate_overrides)
        earlier, key, law = clash
        where = "[vary]" if key in vary_raw else "[set]"
        raise SweepError(f"{src}: {where} {key!r}: sets the {law} law's coefficient that "
                         f"{earlier!r} already sets (two spellings of one term); give it once")

    from vifpk.harness.sweeps.timesweep import options

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
            from vifpk.harness.workflows.bifurcation import VARIABLES

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
        from vifpk.harness.sweeps.adaptive import initial_design

        combos = [adaptive_params(vary, u) for u in initial_design(len(vary), adaptive["points"])]
        if len(combos) > adaptive["points"]:
            raise SweepError(f"{src}: [adaptive] points = {adaptive['points']}: at least "
                             f"{len(combos)} (the initial lattice)")
    else:
        combos = [tuple((k, v[i]) for k, v in vary) for i in range(len(vary[0][1]))]
    if mode == "zip" and len({canonical(c) for c in combos}) != len(combos):
        raise SweepError(f"{src}: [vary]: two zipped points have the same values")
    fixed = dict(fixed_raw)  # a step not given anywhere is "auto" (MonteCarloSettings.dt)
    points = [make_point(base, fixed, seed=seed, workflow=workflow, bifurcation=bif,
                         params=params, first=i == 0, where=src, models=models, tolerance=tol)
              for i, params in enumerate(combos)]
    return Sweep(path=str(p), text=text, name=name, workflow=workflow, mode=mode, seed=seed,
                 vary=tuple(vary), fixed=fixed, bifurcation=bif, base=base,
                 base_file=None if base_file is None else str(base_file),
                 points=tuple(points), adaptive=adaptive, models=models,
                 tolerance=tol.value,
                 tolerance_question=(tol.metric, tol.observable, tol.confidence),
                 surface="tolerance" in raw)


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
                    models: tuple[str, ...] = CHECK_MODELS, *, tolerance_given: bool = False
                    ) -> dict[str, Any]:
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
        if isinstance(v, float) and math.isfinite(v) and v.is_integer():
            v = int(v)  # 1e9 is a whole number: judged by its size, not refused as a float
        if not isinstance(v, int) or isinstance(v, bool) or v < lo:
            raise SweepError(f"{src}: [adaptive] {key} = {v!r}: must be a whole number >= {lo}")
        return v

    model = table.get("model")
    if model not in models:  # one of the models the sweep's checks run
        raise SweepError(f"{src}: [adaptive] model = {model!r}: allowed: " + ", ".join(models))
    method = table.get("method", "band" if tolerance_given else "verdict")
    if method not in ADAPTIVE_METHODS:
        raise SweepError(f"{src}: [adaptive] method = {method!r}: allowed: "
                         + ", ".join(ADAPTIVE_METHODS))
    if method == "band" and not tolerance_given:
        raise SweepError(f"{src}: [adaptive] method = 'band' shrinks the band of a tolerance: "
                         "give tolerance = VALUE (e.g. 0.02)")
    resolution = whole("resolution", 3, ADAPTIVE_RESOLUTION)
    top = (int(MAX_CANDIDATES ** (1.0 / dims) + 1e-9) if method == "band"
           else MAX_VERDICT_RESOLUTION)
    if resolution > top:
        why = (f"a band sweep weighs all resolution^{dims} lattice places at once"
               if method == "band" else "the refiner's finest cell")
        raise SweepError(f"{src}: [adaptive] resolution = {resolution}: too fine ({why}); "
                         f"allowed: 3 to {top}")
    return {"points": whole("points", 3), "model": model,
            "batch": whole("batch", 1, ADAPTIVE_BATCH),
            "resolution": resolution, "method": method}


def adaptive_params(vary: Sequence[tuple[str, tuple[float, float]]], unit: Sequence[float]
                    ) -> tuple[tuple[str, float], ...]:
    """The parameters at unit coordinates ``unit`` of an adaptive sweep's ranges (u = 0 is
    start, u = 1 exactly stop)."""
    return tuple((k, hi if u == 1.0 else lo + u * (hi - lo))
                 for (k, (lo, hi)), u in zip(vary, unit, strict=True))
