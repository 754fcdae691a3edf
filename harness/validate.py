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

import contextlib
import math
import os
import tempfile
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from vifpk.core import registry
from vifpk.core.defaults import CHECK_MODELS, FPK_CELLS
from vifpk.core.result import BadInput
from vifpk.core.scene import SECTIONS, Scene

HOUR = 3600.0
MAGNITUDE = (1e-100, 1e100)  # allowed |value| of a non-zero physical parameter (module doc)
PHYSICAL = {"system": ("c1", "c2", "omega0", "alpha", "mu", "f"), "noise": ("D", "alpha1")}
REL = 1e-9  # relative slack of "a whole number" tests (far above rounding, far below any step)

# measured rates for the cost estimate (lower bounds of the wall time)
# (solve on the base scene, this machine, 2026-11-23: FPK 2.6 / 2.9 / 4.1 / 5.6 s at 400 / 800
# / 1600 / 3200 cells; closed forms at 3201 points: paper 0.11 s, exact 2.6 s with 64 nodes x 24
# harmonics); each rate below is faster than measured, so the estimate is a lower bound
MC_STEPS_PER_CORE = 150e6  # faster than every kernel measured: benchmarks/results/kernel_bound.json
#   (paper-base 68.7, no friction 106.7, smooth OU 123.6 M path-steps/s a core; 60e6 was below)
FPK_SECONDS_PER_CELL = 5e-4  # measured 1.7e-3 s per cell at 3200 cells
AVG_SECONDS_PER_POINT = 1e-5  # paper model, measured 3.5e-5 s per point
AVG_SECONDS_PER_NODE = 2e-7  # exact model, per point x theta node x harmonic, measured 5.2e-7

# the Monte Carlo options of the CLI and the scene fields they set
MC_OPTIONS = {"paths": "paths", "dt": "dt", "time": "time", "seed": "seed", "floor": "floor",
              "budget": "budget"}


MAX_STEPS_PER_SAMPLE = 1e9  # time steps between two samples of a path (dt >= sample_every/1e9)


class InputError(BadInput):
    """Bad input found before any work (an option, a combination, a cost): one line naming
    it. Not a SceneError: the scene file itself may be fine."""


def observables(scene: Scene) -> None:
    """At least one observable of the simulation switched on."""
    from dataclasses import fields

    obs = scene.observables
    if not obs.names():  # the schema's own list (energy included), not a copy of it
        raise InputError("observables: every observable is off, so the simulation would "
                         "compute nothing; allowed: at least one of " + ", ".join(
                             f"observables.{f.name}" for f in fields(obs)) + " = true")


def numba_threads_available() -> int:
    """The threads numba can use: NUMBA_NUM_THREADS if set, else the cores."""
    env = os.environ.get("NUMBA_NUM_THREADS", "").strip()
    return int(env) if env.isdigit() and int(env) >= 1 else (os.cpu_count() or 1)


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
            if "[" in key:
                raise InputError(f"{sec}.{key} = {v:g} is out of range; allowed: 0 or "
                                 f"{lo:g} <= |coefficient| <= {hi:g} (beyond, the model's "
                                 "coefficients over- or underflow double precision)")
            zero = fields_of(sec)[key].metadata["check"](0.0) is None  # 0 allowed there?
            raise InputError(f"{sec}.{key} = {v:g} is out of range; allowed: "
                             f"{'0 or ' if zero else ''}{lo:g} <= |{key}| <= {hi:g} "
                             "(beyond, the model's coefficients over- or underflow double "
                             "precision)")


def stationary_density(scene: Scene) -> None:
    """A scene whose energy grows without bound has no stationary density: refused before any
    work, naming the fields (vifpk.core.scene.energy_balance derives the large-amplitude
    balance; a tie of gains and losses at the top degree is left to the solvers)."""
    from vifpk.core.scene import energy_balance

    bal = energy_balance(scene.system)
    if not bal.grows:
        return
    if bal.gains:
        allowed = (f"a loss of a degree above A^{bal.degree} (e.g. a positive damping or "
                   "velocity_damping term of higher degree), or no gain at that degree")
    else:
        allowed = ("a damping or velocity_damping law whose leading term is > 0, "
                   "system.mu > 0, or system.r < 1 with the barrier")
    raise InputError(f"system: no stationary density: {bal.text}; allowed: {allowed}")


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
    return out


def finite_result(result: Any, scene: Scene) -> None:
    """Never report NaN as a result: every density and summary number of a solver result
    must be finite, else SolverFailure naming the scene's most extreme magnitude."""
    import numpy as np

    from .run import SolverFailure

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
    from .run import montecarlo_plan

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
        least = _montecarlo_least_seconds(scene)
        if mc.budget < least:
            raise InputError(f"{_name('budget', options)} = {_g(mc.budget)} s cannot cover the "
                             "pilots, the burn-in and the first sampling windows (at least "
                             f"{least:.2g} s here, a lower bound from their path-steps); "
                             f"allowed: at least {least:.2g} s, or 0 for no limit")
    refuse_unreachable_floor(scene, options)


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


# --------------------------------------------------------------------------------------------
# output paths
NAME_BYTES = 200  # one file or folder name; the writers add hidden siblings beside it
#                  (".NAME.partial-<run id>", ".NAME.<hex>.tmp") within the usual 255-byte limit
PATH_BYTES = 3800  # a whole path, below the usual 4096 with room for those siblings


def _short(path: Any) -> str:
    text = str(path)
    return text if len(text) <= 80 else text[:60] + "..." + text[-12:]


def _lengths(path: Path, option: str) -> None:
    """Every name in the path within NAME_BYTES, the whole path within PATH_BYTES."""
    for part in path.parts:
        n = len(os.fsencode(part))
        if n > NAME_BYTES:
            raise InputError(f"{option} {_short(path)}: a name in the path is {n} bytes long; "
                             f"allowed: up to {NAME_BYTES} bytes per name")
    n = len(os.fsencode(str(path.absolute())))
    if n > PATH_BYTES:
        raise InputError(f"{option} {_short(path)}: the path is {n} bytes long; allowed: up "
                         f"to {PATH_BYTES} bytes")


def _nearest_existing(path: Path) -> Path:
    p = path.absolute()
    while not p.exists():
        p = p.parent
    return p


def _probe(folder: Path, option: str, path: Path) -> None:
    """A temporary file in ``folder``, removed at once: can the run write there?"""
    if not folder.is_dir():
        raise InputError(f"{option} {_short(path)}: {folder} is not a folder")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".vifpk-probe-", dir=folder)
    except OSError as exc:
        raise InputError(f"{option} {_short(path)}: cannot write in {folder} "
                         f"({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(tmp)


def output_file(path: str | None, option: str) -> None:
    """A file the run will write as a unit (a temporary file beside it, then a rename): a
    regular file or a new name, never a folder, a device, a pipe or a symbolic link (the
    rename would replace the link, e.g. /dev/stdout, instead of writing through it)."""
    if path is None:
        return
    p = Path(path)
    _lengths(p, option)
    if path.endswith(("/", os.sep)):
        raise InputError(f"{option} {path}: ends with a folder separator; give a file name")
    if p.is_symlink():
        raise InputError(f"{option} {_short(path)}: is a symbolic link; give the real file "
                         "path (outputs are written as a temporary file renamed over the name)")
    if p.is_dir():
        raise InputError(f"{option} {path}: is a folder; give a file name")
    if p.exists() and not p.is_file():
        raise InputError(f"{option} {path}: is not a regular file (a device or a pipe); give "
                         "a file name (outputs are written as a unit, then renamed)")
    if p.name in ("", ".", ".."):
        raise InputError(f"{option} {path}: give a file name")
    _probe(_nearest_existing(p.parent), option, p)


def output_folder(path: str | None, option: str, *, replaced: bool = False) -> None:
    """A folder the run will write files into (created if missing). ``replaced``: the run
    swaps the whole folder in at its end, so it must not be the current folder or one that
    holds it (the shell would be left in a deleted folder)."""
    if path is None:
        return
    p = Path(path)
    _lengths(p, option)
    if p.exists() and not p.is_dir():
        raise InputError(f"{option} {path}: exists and is not a folder; give a folder")
    if p.is_symlink():
        raise InputError(f"{option} {path}: is a symbolic link; give the real folder path")
    if replaced:
        here = Path.cwd().resolve()
        full = p.expanduser().resolve()
        if full == here or full in here.parents:
            raise InputError(f"{option} {path}: is the current folder (or holds it); the "
                             "output folder is replaced as a unit at the end, which would "
                             "pull it from under the shell; give a new subfolder, e.g. "
                             f"{option.split()[0]} out")
    _probe(_nearest_existing(p), option, p)


def run_inputs(args: Any) -> list[tuple[str, Path]]:
    """(what, resolved path) of every file a command reads: its scene or sweep file (a shipped
    one too: in a source checkout it is a file of the repository), the sweep's base scene, and
    the source of every registered model plugin."""
    import importlib.util
    import tomllib

    from vifpk.core import registry
    from vifpk.core.scene import find_scene, shipped_scenes

    found: list[tuple[str, Path]] = []

    def add(what: str, p: Any) -> None:
        if isinstance(p, Path) and p.is_file():
            found.append((what, p.resolve()))

    scene = getattr(args, "scene", None)
    if isinstance(scene, str):
        with contextlib.suppress(OSError, ValueError):
            add("the scene file", find_scene(scene))
    sweep = getattr(args, "sweep", None)
    if isinstance(sweep, str):
        sp: Any = Path(sweep)
        with contextlib.suppress(Exception):  # a bad sweep file is the sweep loader's to name
            if not sp.is_file():
                sp = shipped_scenes() / "sweeps" / f"{sweep}.toml"
            add("the sweep file", sp)
            base = tomllib.loads(Path(sp).read_text(encoding="utf-8")).get("scene")
            if isinstance(base, str):
                beside = Path(sp).parent / (base if base.endswith(".toml") else f"{base}.toml")
                add("the sweep's scene file", beside if beside.is_file() else find_scene(base))
    for entry in registry.models():
        if entry.distribution == registry.DISTRIBUTION:
            continue
        with contextlib.suppress(Exception):  # a plugin that cannot even be found: no file
            spec = importlib.util.find_spec(entry.value.split(":")[0].strip())
            if spec is not None and spec.origin:
                add(f"the source of model plugin {entry.name!r}", Path(spec.origin))
    return found


def outputs_apart_from_inputs(args: Any, *, replaced: bool, names: Iterable[str] = ()) -> None:
    """No output overwrites what the run reads: ``--json`` is not an input file; an ``--out``
    folder the run replaces as a unit (``replaced``) holds no input; one it writes into holds
    no input under one of the ``names`` it writes. One line, exit 2, before any work."""
    inputs = run_inputs(args)
    json_out = getattr(args, "json", None)
    if isinstance(json_out, str):
        target = Path(json_out).expanduser().resolve()
        for what, p in inputs:
            if target == p or target.is_file() and os.path.samefile(target, p):  # hard links
                raise InputError(f"--json {json_out}: is {what} this run reads; give "
                                 "another file name (the output would replace it)")
    out = getattr(args, "out", None)
    if isinstance(out, str):
        folder = Path(out).expanduser().resolve()
        for what, p in inputs:
            inside = folder in p.parents
            if inside and (replaced or any(p == folder / n or folder / n in p.parents
                                           for n in names)):
                raise InputError(f"--out {out}: holds {what} ({_short(p)}), which the run "
                                 f"would {'replace with the folder' if replaced else 'overwrite'}"
                                 "; give another folder")


# --------------------------------------------------------------------------------------------
# cost
def _montecarlo_parts(scene: Scene, speed: float | None) -> tuple[float, float, float]:
    """(seconds of the pilots and the burn-in, of the first sampled windows, of the sampling
    a target floor needs at least) at ``speed`` path-steps per second per core (default
    MC_STEPS_PER_CORE, faster than any machine measured) on every core the run uses, from the
    Monte Carlo's own plan (montecarlo.plan: burn-in "auto" at its minimum, the pilots' sizes);
    with a target floor the first windows are half of ``time``, else the sampled time."""
    from .run import montecarlo_plan

    mc = scene.montecarlo
    plan = montecarlo_plan(scene)
    cores = mc.threads or min(numba_threads_available(), os.cpu_count() or 1)
    per_step = 1.0 / plan.dt / ((speed or MC_STEPS_PER_CORE) * cores)
    first = mc.time / 2 if mc.floor > 0 else plan.sampled_time
    needed = floor_time(scene) if mc.floor > 0 else 0.0
    return ((mc.paths * plan.burn_in + plan.pilot_path_time) * per_step,
            mc.paths * first * per_step, mc.paths * needed * per_step)


def _montecarlo_least_seconds(scene: Scene) -> float:
    """Lower bound of the least wall time a Monte Carlo run does (the pilots, the burn-in
    and the first sampled windows; see :func:`_montecarlo_parts`)."""
    fixed, first, _ = _montecarlo_parts(scene, None)
    return fixed + first


def montecarlo_seconds(scene: Scene, *, speed: float | None = None) -> float:
    """Lower bound of the wall time of one Monte Carlo run of the original system
    (:func:`_montecarlo_parts`): with a target floor, the sampling is the larger of the
    first windows and what the floor needs (:func:`floor_time`), cut at ``budget`` seconds
    when there is one (0: no limit)."""
    mc = scene.montecarlo
    fixed, first, needed = _montecarlo_parts(scene, speed)
    sampling = max(first, needed)
    if mc.floor > 0 and mc.budget > 0:
        sampling = min(sampling, mc.budget)
    return fixed + sampling


def floor_time(scene: Scene) -> float:
    """Lower bound of the sampled time per path that reaching the target floor F needs.

    N >= 2 / (pi F^2) independent samples: the floor of a histogram is sqrt(2/pi) sum se_i
    w_i >= sqrt(2 / (pi N)) (sum sqrt(q_i) >= 1 for bin masses q_i, se_i^2 = q_i / (N w_i^2)
    at best), and a path gives at most one independent sample a ``sample_every``."""
    mc = scene.montecarlo
    return 2.0 / (math.pi * mc.floor**2) * mc.sample_every / mc.paths


def refuse_unreachable_floor(scene: Scene, options: Mapping[str, str] | None = None) -> None:
    """A target floor the budget cannot reach even at the fastest rate is refused up front
    (the run would stop at its budget, the floor not reached)."""
    from .run import montecarlo_plan

    mc = scene.montecarlo
    if not (mc.floor > 0 and mc.budget > 0):
        return
    cores = mc.threads or min(numba_threads_available(), os.cpu_count() or 1)
    h = montecarlo_plan(scene).dt
    seconds = mc.paths * floor_time(scene) / h / (MC_STEPS_PER_CORE * cores)
    if seconds > mc.budget:
        names = options or {}
        raise InputError(f"{_name('floor', names)} = {mc.floor:g}: needs at least {seconds:.3g}"
                         f" s of sampling at dt = {h:g}, more than {_name('budget', names)} = "
                         f"{mc.budget:g} s allows; "
                         "raise the floor or the budget (0: no limit, then the cost limit "
                         "applies)")


def memory_bytes(scene: Scene) -> float:
    """Lower bound of the memory one Monte Carlo run allocates: per path its state and random
    generator (~100 bytes) and the equilibration certificate's window sums (8 bytes a window:
    the plan's windows, or with a target floor as many windows of the plan's length as fit
    in ``montecarlo.time``, the most a floor run can grow to)."""
    from .run import montecarlo_plan

    mc = scene.montecarlo
    plan = montecarlo_plan(scene)
    windows = float(plan.windows)
    if mc.floor:
        window_time = plan.samples_per_window * plan.sample_interval
        windows = max(windows, mc.time / max(window_time, 1e-300))
    return mc.paths * (100.0 + 8.0 * min(windows, 1e6))


def refuse_oversized(scene: Scene, option: str = "--paths") -> None:
    """A run that cannot fit in this machine's memory is refused even with --yes."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return
    need = memory_bytes(scene)
    if need > total:
        raise InputError(f"{option} {scene.montecarlo.paths}: the simulation needs at least "
                         f"{need / 2**30:.3g} GiB of memory; this machine has {total / 2**30:.3g}"
                         " GiB; allowed: fewer paths")


def refuse_costly(seconds: float | Callable[[float | None], float], what: str, yes: bool
                  ) -> None:
    """Refuse a run estimated above an hour, unless ``--yes``.

    ``seconds`` may be a function of the machine's speed (path-steps per second per core):
    the estimate at MC_STEPS_PER_CORE (faster than any machine) decides alone when it is
    already above the hour or far below it; in between, the speed measured on this machine
    (:func:`machine_speed`, a short calibration, cached) decides."""
    if yes:
        return
    if callable(seconds):
        fast = seconds(None)
        if HOUR / CALIBRATE_BELOW < fast <= HOUR:
            seconds = seconds(machine_speed())
        else:
            seconds = fast
    if seconds > HOUR:
        raise InputError(f"{what}: estimated at least {_duration(seconds)} of computation; "
                         "allowed without --yes: up to 1 hour (reduce the size, or add --yes)")


def run_cost_limit(scene: Scene, yes: bool) -> tuple[float, float] | None:
    """(seconds, path-steps per second) for harness.run.cost_limit: the hour the guard allows
    without ``--yes`` at this machine's speed on the run's cores, the one refuse_costly
    applies up front. The speed is the cached calibration (or VIFPK_STEPS_PER_SECOND), never
    faster than MC_STEPS_PER_CORE; with none cached, MC_STEPS_PER_CORE (so that only a run
    certainly above the hour is stopped). None with ``--yes`` (no limit)."""
    if yes:
        return None
    mc = scene.montecarlo
    cores = mc.threads or min(numba_threads_available(), os.cpu_count() or 1)
    speed = min(cached_speed() or MC_STEPS_PER_CORE, MC_STEPS_PER_CORE)
    return HOUR, speed * cores


@contextmanager
def guarded_run(scene: Scene, yes: bool) -> Iterator[None]:
    """The run inside is priced again once its relaxation pilot has measured an automatic
    burn-in (run_cost_limit, handed to the door as run.cost_limit); a refusal then is worded
    here (priced_burn_in), where the rest of the guard's words are."""
    from vifpk.core.result import CostRefused

    from .run import cost_limit

    limit = run_cost_limit(scene, yes)
    with cost_limit(limit):
        try:
            yield
        except CostRefused as exc:
            if limit is None:
                raise
            raise CostRefused(priced_burn_in(exc.numbers, *limit), **exc.numbers) from None


def priced_burn_in(numbers: Mapping[str, float], seconds: float, rate: float) -> str:
    """The one line of a run refused once its relaxation pilot has measured the burn-in
    (montecarlo's CostRefused numbers: relaxation_time, burn_in, path_steps)."""
    return (f"the relaxation pilot measured a relaxation time of "
            f"{numbers['relaxation_time']:.3g}, so the automatic burn-in is "
            f"{numbers['burn_in']:.3g} time units and the run {numbers['path_steps']:.3g} "
            f"path-steps: estimated at least {_duration(numbers['path_steps'] / rate)} at "
            f"{rate / 1e6:.3g} M path-steps/s; allowed without --yes: up to "
            f"{'1 hour' if seconds == HOUR else _duration(seconds)}; give --yes, a fixed "
            "burn-in (--set montecarlo.burn_in=T), or stronger noise (a larger noise.D or "
            "system.f: the paths mix faster)")


CALIBRATE_BELOW = 8.0  # an estimate at the fastest rate above HOUR / 8 is re-estimated with
#                        the measured speed (machines measured 1.3-3x below MC_STEPS_PER_CORE)


def _cache_file() -> Path:
    from vifpk.core.defaults import cache_dir

    return cache_dir() / "speed.json"


def machine_speed() -> float:
    """Path-steps per second per core of the original system's simulation on this machine.

    ``VIFPK_STEPS_PER_SECOND`` overrides it; else the value cached in
    ``speed.json`` in vifpk.core.defaults.cache_dir() for this host and core count; else a
    short calibration (the base scene, 512 paths x 200 time units on one thread, ~1-5 s with
    the compile), which is cached with the load average it was taken under."""
    import socket

    known = cached_speed()
    if known is not None:
        return known
    key = {"host": socket.gethostname(), "cores": os.cpu_count()}
    path = _cache_file()
    speed = _calibrate()
    try:
        from .io import write_json

        write_json(path, {**key, "steps_per_second_per_core": speed,
                          "load_average": os.getloadavg()[0],
                          "how": "harness.validate._calibrate: paper-base, 512 paths, one "
                                 "thread, 200 time units at dt 0.01"})
    except OSError:
        pass  # an unwritable cache: measure again next time
    return speed


def cached_speed() -> float | None:
    """VIFPK_STEPS_PER_SECOND, else the speed cached for this host and core count (see
    :func:`machine_speed`), else None: nothing is measured here."""
    import json
    import socket

    env = os.environ.get("VIFPK_STEPS_PER_SECOND")
    if env:
        try:
            if float(env) > 0:
                return float(env)
        except ValueError:
            pass
        raise InputError(f"VIFPK_STEPS_PER_SECOND={env}: allowed: a number > 0")
    key = {"host": socket.gethostname(), "cores": os.cpu_count()}
    try:
        cached = json.loads(_cache_file().read_text(encoding="utf-8"))
        if {k: cached.get(k) for k in key} == key and cached["steps_per_second_per_core"] > 0:
            return float(cached["steps_per_second_per_core"])
    except (OSError, ValueError, KeyError, TypeError):
        pass
    return None


def _calibrate() -> float:
    import sys

    from vifpk.core.scene import load_scene

    from .run import run_solver

    print("vifpk: measuring this machine's simulation speed once (a few seconds; cached in "
          f"{_cache_file()})", file=sys.stderr, flush=True)
    scene = load_scene("paper-base").with_values({
        "montecarlo.paths": 512, "montecarlo.blocks": 32, "montecarlo.time": 200.0,
        "montecarlo.burn_in": 0.0, "montecarlo.dt": 0.01, "montecarlo.threads": 1,
        "montecarlo.floor": 0.0})
    info = run_solver(scene, "montecarlo", progress=False).info
    return float(info["steps_per_second"]) / max(int(info.get("threads", 1)), 1)


def _duration(s: float) -> str:
    if s < 2 * HOUR:
        return f"{s / 60:.0f} minutes"
    if s < 48 * HOUR:
        return f"{s / HOUR:.0f} hours"
    return f"{s / 86400:.3g} days"


def fields_of(section: str) -> dict[str, Any]:
    from dataclasses import fields

    return {f.name: f for f in fields(SECTIONS[section])}


def fpk_seconds(cells: int) -> float:
    """Lower bound of one FPK stationary solve by stepping: FPK_SECONDS_PER_CELL x cells,
    times cells / 3200 above 3200 cells (the stable step shrinks with the cell: measured
    1.4 s of CPU at 3200 cells and more than 56 s at 12800, load 11; it was priced linearly,
    so --grid 5e6 ran for minutes with no word)."""
    return FPK_SECONDS_PER_CELL * cells * max(1.0, cells / 3200)


def averaging_seconds(scene: Scene, model: str) -> float:
    """Lower bound of one closed-form solve: AVG_SECONDS_PER_POINT per grid point (paper),
    AVG_SECONDS_PER_NODE per point x theta node x harmonic (exact and corrected: the orbit
    quadrature)."""
    av = scene.averaging
    if model != "paper":  # exact, corrected: orbit quadratures
        return AVG_SECONDS_PER_NODE * av.points * av.theta_nodes * av.harmonics
    return AVG_SECONDS_PER_POINT * av.points


def solve_seconds(scene: Scene, solver: str, model: str, grid: int | None, *,
                  speed: float | None = None) -> float:
    """Lower bound of ``vifpk solve``."""
    if solver == "montecarlo":
        return montecarlo_seconds(scene, speed=speed)
    base = averaging_seconds(scene, model)
    return base + (fpk_seconds(grid or FPK_CELLS) if solver == "fpk" else 0.0)


def check_seconds(scene: Scene, models: tuple[str, ...] = CHECK_MODELS, *,
                  speed: float | None = None) -> float:
    """Lower bound of ``vifpk check``: the Monte Carlo of the original system, the closed
    forms and FPKs of the models that apply (the averaged SDEs are not counted): the
    models that do not apply to the scene are left out (they are not run there)."""
    models = registry.applicable(scene, models)[0]
    return (montecarlo_seconds(scene, speed=speed)
            + sum(averaging_seconds(scene, m) for m in models)
            + len(models) * fpk_seconds(FPK_CELLS))


def workprecision_seconds(scene: Scene, quick: bool, *, speed: float | None = None) -> float:
    """Lower bound of ``vifpk workprecision``: its Monte Carlo reference run (256 paths x 400
    time units with --quick, else 4096 x 4000, at dt / 2)."""
    from dataclasses import replace

    paths, time_ = (256, 400.0) if quick else (4096, 4000.0)
    mc = scene.montecarlo
    ref = replace(scene, montecarlo=replace(mc, paths=paths, time=time_, blocks=16,
                                            dt=float(mc.dt) / 2, floor=0.0))
    return montecarlo_seconds(ref, speed=speed)
