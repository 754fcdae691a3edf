"""Tolerance tests for averaged models, the way ``numpy.testing`` pins numbers.

    from vifpk.harness.testing import assert_density_close, assert_averaging_error

    assert_averaging_error("paper-base", "exact", below=0.1)          # L1(A) against the MC
    assert_averaging_error(scene, MyModel(), below=0.05, observable="x2")
    assert_density_close(fpk_result.data["A"], closed.data["A"], atol=1e-4)

A density is a record ``{"x", "p"}`` (smooth) or ``{"x", "p", "edges", "err"}`` (a Monte Carlo
histogram with batch standard errors), or an ``(x, p)`` pair. When a side is a histogram its
sampling noise floor for the chosen metric is added to the tolerance automatically.

``model`` in :func:`assert_averaging_error` is the name of a registered model (``"paper"``,
``"exact"``, ``"corrected"`` or a ``vifpk.models`` plugin, docs/plugins.md) or any object
with the **averaged-model protocol**::

    drift(A: ndarray) -> ndarray        # m(A) of dA = m dt + sigma dB, for A > 0
    diffusion(A: ndarray) -> ndarray    # sigma^2(A) > 0
    period(A: ndarray) -> ndarray       # optional: T(A) for p(x1, x2) = p(E)/T (default: exact)

A model with a closed form (``log_stationary_parts`` and ``period``, averaging/stationary.py)
is solved in closed form; any other gets its stationary p(A) from the generic FPK direct solve
(REFERENCE_CELLS = 800 cells, vifpk.core.defaults), and p(x1), p(x2) from the same phase-space
mapping as the closed forms.

Monte Carlo references of the original system -- the stationary densities and the
first-passage runs of :func:`assert_mfpt_close` -- are cached on disk (``cache_dir()``: the
``--vifpk-cache`` pytest option, else vifpk.core.defaults.cache_dir(): ``$VIFPK_CACHE``,
else ``~/.cache/vifpk``) under a key of the scene's physics, the Monte Carlo settings (seed
included), the run's own arguments (threshold, start, horizon, paths) and the package
version, so a test suite pays for each reference once; ``--vifpk-refresh`` rebuilds them.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from vifpk.harness.workflows.compare import compare, is_histogram

from vifpk.core.defaults import DENSITY_OBSERVABLES
from vifpk.core.io import atomic_path, jsonable, write_atomic
from vifpk.core.registry import one_of
from vifpk.core.scene import Scene, load_scene

METRICS = ("L1", "hellinger", "ks")
_STATE: dict[str, Any] = {"cache": None, "refresh": False, "stats": {"hits": 0, "misses": 0}}


class AveragedModel(Protocol):
    def drift(self, A: np.ndarray) -> np.ndarray: ...
    def diffusion(self, A: np.ndarray) -> np.ndarray: ...


def assertion(workflow: str) -> Any:
    """The registered workflow ``workflow``'s tolerance test (its ``assertion``,
    vifpk.core.protocols.Workflow): ``assertion("check")`` is :func:`assert_averaging_error`,
    ``"passage"`` :func:`assert_mfpt_close`, ``"transient"`` :func:`assert_relaxation_close`,
    and a plugin workflow's comes the same way. UnknownName naming those that have one."""
    from vifpk.core.protocols import resolved
    from vifpk.core.registry import workflows

    have = {w.name: w.assertion for w in workflows()
            if getattr(w, "assertion", None) is not None}
    one_of("workflow with a tolerance test", workflow, tuple(have))
    return resolved(have[workflow])


def configure(*, cache: str | Path | None = None, refresh: bool | None = None) -> None:
    """Set the reference cache directory and refresh flag (the pytest plugin calls this)."""
    if cache is not None:
        _STATE["cache"] = Path(cache)
    if refresh is not None:
        _STATE["refresh"] = refresh


def cache_dir() -> Path:
    if _STATE["cache"] is not None:
        return Path(_STATE["cache"])
    from vifpk.core.defaults import cache_dir as default

    return default()


def cache_stats() -> dict[str, int]:
    return dict(_STATE["stats"])


def _record(d: Any) -> dict[str, Any]:
    if isinstance(d, tuple) and len(d) == 2:
        return {"x": np.asarray(d[0], float), "p": np.asarray(d[1], float)}
    if isinstance(d, dict) and "x" in d and "p" in d:
        return d
    raise TypeError("a density is a dict with 'x' and 'p' (and 'edges', 'err' for a histogram)"
                    f" or an (x, p) pair, not {type(d).__name__}")


def assert_density_close(actual: Any, desired: Any, *, metric: str = "L1", atol: float,
                         noise_floor: float | None = None) -> dict[str, float]:
    """Assert metric(actual, desired) <= atol + noise floor; return the metrics.

    The noise floor is that of the Monte Carlo side(s) for this metric (a parametric
    bootstrap of their batch errors, harness/workflows/compare.py), unless given.
    """
    one_of("metric", metric, METRICS)
    a, d = _record(actual), _record(desired)
    m = compare(a, d)
    floor = m.get(f"{metric}_floor", 0.0) if noise_floor is None else noise_floor
    tol = atol + floor
    if not m[metric] <= tol:
        mc = " (one side is a Monte Carlo histogram)" if is_histogram(a) or is_histogram(d) \
            else ""
        raise AssertionError(
            f"densities differ: {metric} = {m[metric]:.4g} > tolerance {tol:.4g} = atol "
            f"{atol:.4g} + noise floor {floor:.4g}{mc}")
    return m


# ------------------------------------------------------------------- Monte Carlo references
def _scene(scene: Any) -> Scene:
    if isinstance(scene, Scene):
        return scene
    return load_scene(scene)


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("vifpk")
    except metadata.PackageNotFoundError:
        return "unknown"


def reference_key(scene: Scene) -> str:
    """Cache key: the physics (system, noise), the Monte Carlo settings, the version."""
    d = scene.to_dict()
    payload = {"system": d["system"], "noise": d["noise"], "montecarlo": d["montecarlo"],
               "version": _version()}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:20]


def passage_key(scene: Scene, **call: Any) -> str:
    """Cache key of a first-passage Monte Carlo of the original system: the physics (system,
    noise, parametric forcing when on), the scene's Monte Carlo settings (seed, dt, blocks,
    ...), every argument of the run (threshold, start, horizon, paths, burn-in: the model
    enters through the horizon it sets, harness/workflows/passage.py: plan) and the version."""
    d = scene.to_dict()
    payload = {k: d.get(k) for k in ("system", "noise", "parametric", "montecarlo")}
    payload.update(kind="passage", call=jsonable(call), version=_version())
    return "passage-" + hashlib.sha256(
        json.dumps(payload, sort_keys=True).encode()).hexdigest()[:20]


def _scene_argument(scene: Scene) -> str:
    """How the command names the scene: its file when that is in the working directory, the
    bare name of a shipped scene (``paper-base``; a path ending in .toml must exist), else a
    placeholder. Every value the run depends on is given with --set anyway."""
    from vifpk.core.scene import find_scene

    source = scene.source or ""
    if source and Path(source).is_file():
        return source
    stem = source[:-5] if source.endswith(".toml") else source
    if stem and find_scene(stem) is not None:
        return stem
    return "SCENE.toml"


def reproduce_command(scene: Scene) -> str:
    """The ``vifpk solve`` command that runs this scene's Monte Carlo reference again: every
    value of [system], [noise] and of the [montecarlo] settings the result depends on, numbers
    as ``repr`` (exact), ``dt`` a number or "auto"."""
    st = scene.montecarlo

    def show(v: Any) -> str:  # as --set parses it: TOML booleans, bare words, floats exact
        return str(v).lower() if isinstance(v, bool) else f"{v}"

    d = scene.to_dict()  # the system's laws in the spelling the scene uses (lists as TOML)
    sets = " ".join(f"--set {sec}.{k}={show(v)}" for sec in ("system", "noise")
                    for k, v in d[sec].items())
    sets += "".join(f" --set montecarlo.{k}={show(getattr(st, k))}"
                    for k in ("blocks", "burn_in", "sample_every", "bins", "floor", "budget"))
    return (f"vifpk solve {_scene_argument(scene)} --solver montecarlo --paths {st.paths} "
            f"--dt {st.dt} --time {st.time!r} --seed {st.seed} {sets} --json reference.json")


class Reference:
    """A cached Monte Carlo reference of the original system: ``data`` and ``info``."""

    def __init__(self, data: dict[str, Any], info: dict[str, Any], *, cached: bool):
        self.data, self.info, self.cached = data, info, cached


def mc_reference(scene: Any, **montecarlo: Any) -> Reference:
    """The Monte Carlo of the original system for a scene, from the cache or run and cached.

    ``montecarlo`` overrides the scene's [montecarlo] settings (paths, dt, time, seed, ...).
    """
    from vifpk.harness.door.solvers import montecarlo_solution

    sc = _scene(scene)
    if montecarlo:
        sc = sc.with_values({f"montecarlo.{k}": v for k, v in montecarlo.items()})
    key = reference_key(sc)
    npz, meta = cache_dir() / f"{key}.npz", cache_dir() / f"{key}.json"
    if npz.is_file() and meta.is_file() and not _STATE["refresh"]:
        _STATE["stats"]["hits"] += 1
        return Reference(*_load(npz, meta), cached=True)
    _STATE["stats"]["misses"] += 1
    obs = dataclasses.replace(sc.observables, A=True, x1=True, x2=True, joint=False)
    res = montecarlo_solution(dataclasses.replace(sc, observables=obs), progress=False)
    data = {o: r for o, r in res.data.items() if o != "joint"}
    info = {"settings": res.info["settings"], "seed": res.info["seed"]["root"],
            "scene": sc.to_dict(), "command": reproduce_command(sc), "key": key}
    _store(npz, meta, data, info)
    return Reference(data, info, cached=False)


def _load(npz: Path, meta: Path) -> tuple[dict[str, Any], dict[str, Any]]:
    with np.load(npz) as z:
        data: dict[str, Any] = {}
        for name in z.files:
            obs, field = name.split("__")
            data.setdefault(obs, {})[field] = z[name]
    return data, json.loads(meta.read_text())


def _store(npz: Path, meta: Path, data: dict[str, Any], info: dict[str, Any]) -> None:
    npz.parent.mkdir(parents=True, exist_ok=True)
    arrays = {f"{o}__{k}": np.asarray(v) for o, rec in data.items() for k, v in rec.items()}
    with atomic_path(npz) as tmp:
        np.savez(tmp, **arrays)
    write_atomic(meta, json.dumps(jsonable(info), indent=1))


def cached_passage_montecarlo(scene: Scene, *, progress: bool = False, **call: Any) -> Any:
    """harness.door.timedomain.passage_montecarlo through the reference cache (cache_dir(),
    key :func:`passage_key`; ``--vifpk-refresh`` runs it again). ``info["cached"]`` says
    whether it came from the cache."""
    from vifpk.harness.door import timedomain

    from vifpk.core.result import Result

    key = passage_key(scene, **call)
    npz, meta = cache_dir() / f"{key}.npz", cache_dir() / f"{key}.json"
    if npz.is_file() and meta.is_file() and not _STATE["refresh"]:
        _STATE["stats"]["hits"] += 1
        data, info = _load(npz, meta)
        return Result(data=data, info=dict(info, cached=True))
    _STATE["stats"]["misses"] += 1
    from vifpk.harness.workflows.passage import plain_info

    res = timedomain.passage_montecarlo(scene, progress=progress, **call)
    _store(npz, meta, res.data, dict(plain_info(res.info), key=key))
    return Result(data=res.data, info=dict(res.info, key=key, cached=False))


def model_densities(scene: Scene, model: Any) -> dict[str, dict[str, Any]]:
    """p(A), p(x1), p(x2) of an averaged model (a registered name, or an object with the
    averaged-model protocol): its closed form when it has one, else the FPK direct solve of its
    m and sigma^2 mapped to phase space (``harness.door.solvers.closed_form``)."""
    from vifpk.harness.door.solvers import closed_form

    return closed_form(scene, model=model).data


def assert_averaging_error(scene: Any, model: Any, *, below: float, observable: str = "A",
                           metric: str = "L1", **montecarlo: Any) -> dict[str, float]:
    """Assert that the model's error against the original system is below ``below``.

    The error is metric(model density, Monte Carlo of the original system) for the
    observable; the failure message prints it with its error bar and noise floor, the
    reference's settings, and the command that reproduces the reference.
    """
    one_of("metric", metric, METRICS)
    one_of("observable", observable, DENSITY_OBSERVABLES)
    below = _below(below)
    sc = _scene(scene)
    ref = mc_reference(sc, **montecarlo)
    dens = model_densities(sc, model)
    m = compare(dens[observable], ref.data[observable])
    if not m[metric] < below:
        name = model if isinstance(model, str) else type(model).__name__
        st = ref.info["settings"]
        raise AssertionError(
            f"averaging error of {name} on p({observable}): {metric} = {m[metric]:.4g} "
            f"+/- {m[f'{metric}_err']:.2g} (noise floor {m[f'{metric}_floor']:.2g}) is not below "
            f"{below:g}\n  reference: Monte Carlo of the original system, {st['paths']} paths, "
            f"dt {st['dt']:g}, time {st['time']:g} after burn-in {st['burn_in']:g}, seed "
            f"{ref.info['seed']}{' (from cache)' if ref.cached else ''}\n  reproduce: "
            f"{ref.info['command']}")
    return m


# ------------------------------------------------------------------------- time domain
def _rtol(rtol: Any) -> float:
    """A relative tolerance: a finite number >= 0 (BadInput, a usage error, not a failed
    assertion: issue 39, A31, A32, A34)."""
    import math
    import numbers

    from vifpk.harness.request.errors import InputError

    if isinstance(rtol, bool) or not isinstance(rtol, numbers.Real):
        raise InputError(f"rtol {rtol!r}: not a number; allowed: a finite number >= 0")
    if not (math.isfinite(rtol) and rtol >= 0):
        raise InputError(f"rtol {float(rtol):g}: out of range; allowed: a finite number >= 0")
    return float(rtol)


def _below(below: Any) -> float:
    """The bound of assert_averaging_error: a finite number > 0 (BadInput before any Monte
    Carlo: ``below=float("nan")`` ran the reference, then failed as an AssertionError "is
    not below nan", issue 45; every distance is >= 0, so a bound <= 0 can never pass)."""
    import math
    import numbers

    from vifpk.harness.request.errors import InputError

    if isinstance(below, bool) or not isinstance(below, numbers.Real):
        raise InputError(f"below {below!r}: not a number; allowed: a finite number > 0")
    if not (math.isfinite(below) and below > 0):
        raise InputError(f"below {float(below):g}: out of range; allowed: a finite number > 0 "
                         "(a distance is >= 0)")
    return float(below)


def _reproduce_passage(sc: Scene, model: str, threshold: float, start: Any,
                       paths: int, horizon: float) -> str:
    st = "stationary" if start == "stationary" else repr(float(start))
    return (f"vifpk passage {_scene_argument(sc)} --threshold {threshold!r} --start {st} "
            f"--model {model} --paths {paths} --seed {sc.montecarlo.seed} --dt "
            f"{sc.montecarlo.dt} --horizon {horizon!r}")


def _exact(sc: Any, paths: Any) -> Any:
    """The testing API's paths: as given, else exactly the scene's montecarlo.paths (the
    assertions keep their documented sample size; the command's --rel-se growth, issue 39
    item 5, is not applied here)."""
    return sc.montecarlo.paths if paths is None else paths


def assert_mfpt_close(scene: Any, model: Any, threshold: float, *, rtol: float,
                      start: float | str = "stationary", paths: int | None = None,
                      horizon: float | None = None) -> dict[str, Any]:
    """Assert that the model's mean first-passage time to ``threshold`` is within ``rtol`` of
    the original system's, noise-aware: |T_model / T_MC - 1| <= rtol + 2 x its error bar (the
    Monte Carlo's standard error carried to the ratio). When the Monte Carlo censored more than
    1% of its paths, restricted means over [0, horizon] are compared (harness/workflows/passage.py).
    Returns the model's metrics (``mfpt_error``, ``R_sup``, ...); the failure message gives
    both MFPTs, the error bar, the Monte Carlo's settings and the command that reproduces it."""
    from vifpk.harness.door.solvers import model_label
    from vifpk.harness.request.timedomain import passage_request, with_quadratures
    from vifpk.harness.workflows.passage import run
    from vifpk.harness.workflows.pricing import refuse_costly_direct

    rtol = _rtol(rtol)
    sc = _scene(scene)  # exactly the paths asked (default the scene's): no --rel-se growth
    req = passage_request(sc, threshold=threshold, start=start, models=(model,),
                          horizon=horizon, paths=_exact(sc, paths), sde=False,
                          method="direct")
    threshold, start, sc = req.threshold, req.start, req.scene
    name = model_label(model)
    req = with_quadratures(req)
    # issue 39, X12: hours of R(t) stepping and Monte Carlo, silently, at threshold 2.0
    refuse_costly_direct(req, override="or a lower threshold, fewer paths, a horizon")
    res = run(req, quiet=True, reference=cached_passage_montecarlo)
    if name not in res.metrics["models"]:
        raise ValueError(f"model {name}: {res.metrics.get('models_absent', {}).get(name, '')}")
    e = res.metrics["models"][name]
    err = e.get("mfpt_error_restricted", e["mfpt_error"])
    tol = rtol + 2.0 * err["err"]
    if not abs(err["value"]) <= tol:
        mc = res.metrics["mfpt"]["original_system"]
        p = res.metrics["plan"]
        raise AssertionError(
            f"MFPT of {name} to Ac = {threshold:g}: {res.metrics['mfpt'][name]['value']:.5g} "
            f"against the original system's {mc['value']:.5g} +/- {mc['stderr']:.2g}: "
            f"relative error {err['value']:+.4f} +/- {err['err']:.4f} exceeds rtol {rtol:g} + "
            f"2 error bars = {tol:.4f}\n  reference: Monte Carlo of the original system, "
            f"{mc['paths']} paths ({mc['censored']} censored at {p['horizon']:.4g}), dt "
            f"{p['dt']:g}, seed {p['seed']}"
            f"{' (from cache)' if res.metrics['monte_carlo'].get('cached') else ''}"
            "\n  reproduce: "
            + _reproduce_passage(sc, name, threshold, start, mc["paths"], p["horizon"]))
    return e


def assert_relaxation_close(scene: Any, model: Any, *, start: float, times: Any, rtol: float,
                            paths: int | None = None) -> dict[str, Any]:
    """Assert that the relaxation time the model's FPK predicts (1 / its slowest decay rate) is
    within ``rtol`` of the one fitted on the original system's mean amplitude (harness/
    transient.py), noise-aware: |tau_model / tau_MC - 1| <= rtol + 2 x its error bar.
    ``times``: at least three (the fit has two parameters); ``paths``: the Monte Carlo's
    (default: the scene's montecarlo.paths). Usage errors (rtol, times, start) are BadInput,
    raised before any Monte Carlo."""
    from vifpk.harness.door.solvers import model_label
    from vifpk.harness.request.timedomain import transient_request
    from vifpk.harness.workflows.transient import run

    rtol = _rtol(rtol)
    sc = _scene(scene)
    req = transient_request(sc, start=start, times=times, models=(model,),
                            paths=_exact(sc, paths), sde=False)
    name = model_label(model)
    res = run(req, quiet=True)
    meas = res.metrics["relaxation"]["original_system"]
    if meas is None:
        raise AssertionError(f"no relaxation time measured on the original system from the "
                             f"times {list(times)}: {res.warnings[0] if res.warnings else ''}")
    pred = res.metrics["relaxation"][name]["predicted"]
    r = pred / meas["value"]
    bar = r * meas["err"] / meas["value"]
    if not abs(r - 1.0) <= rtol + 2.0 * bar:
        raise AssertionError(
            f"relaxation time of {name}: predicted {pred:.5g} against {meas['value']:.5g} +/- "
            f"{meas['err']:.2g} measured on the original system ({meas['method']}): relative "
            f"error {r - 1:+.4f} +/- {bar:.4f} exceeds rtol {rtol:g} + 2 error bars")
    return dict(res.metrics["relaxation"][name], measured=meas)
