"""Scenes: a frozen description of one physical system, read from TOML.

A scene switches physics on and off and says what to compute. Its format is documented in
``docs/scenes.md``. Every field is validated on load; a bad value raises :class:`SceneError`
whose message is one line naming the field and its allowed range (the CLI prints it and exits
with code 2).

The system (Liu, Xu, Yue & Huang, Symmetry 2019, 11(1):4, eq. 17)::

    x'' + (c2 x^2 - c1) x' + omega0^2 x + alpha x^3 + mu sgn(x') = f xi(t),   x > 0
    x'(+) = -r x'(-)  at the barrier x = 0
    xi' + alpha1 xi = W(t),  E[W(t) W(t+s)] = 2 D delta(s)      (kind = "ou")
    xi = W(t)                                                     (kind = "white")
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, replace
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any


class SceneError(ValueError):
    """A scene that cannot be used; the message is one line naming the field."""


# --------------------------------------------------------------------------------------------
# range checks: each returns None when the value is fine, else the allowed range in words
Check = Callable[[Any], "str | None"]


def _finite(v: float) -> str | None:
    return None if math.isfinite(v) else "a finite number"


def _positive(v: float) -> str | None:
    return None if math.isfinite(v) and v > 0 else "a finite number > 0"


def _nonneg(v: float) -> str | None:
    return None if math.isfinite(v) and v >= 0 else "a finite number >= 0"


def _tail(v: float) -> str | None:
    """The probability mass the amplitude grid may leave beyond A_max: a small tolerance (a
    tail of 0.5 would cut half the density off the grid)."""
    return None if math.isfinite(v) and 0.0 < v <= 1e-3 else "0 < tail <= 0.001"


def _floor(v: float) -> str | None:
    """A target L1 noise floor: an L1 distance between densities is at most 2."""
    return None if math.isfinite(v) and 0.0 <= v < 2.0 else "0 <= floor < 2 (0: none)"


def _restitution(v: float) -> str | None:
    return None if math.isfinite(v) and 0 < v <= 1 else "0 < r <= 1"


def _int_at_least(lo: int) -> Check:
    def check(v: Any) -> str | None:
        ok = isinstance(v, int) and not isinstance(v, bool) and v >= lo
        return None if ok else f"a whole number >= {lo}"

    return check


def _int_between(lo: int, hi: int) -> Check:
    def check(v: Any) -> str | None:
        ok = isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi
        return None if ok else f"a whole number from {lo} to {hi}"

    return check


def _one_of(*allowed: str) -> Check:
    def check(v: Any) -> str | None:
        return None if v in allowed else "one of " + ", ".join(repr(a) for a in allowed)

    return check


def _bool(v: Any) -> str | None:
    return None if isinstance(v, bool) else "true or false"


def _auto_or(check: Check) -> Check:
    def auto(v: Any) -> str | None:
        if v == "auto":
            return None
        if isinstance(v, bool) or not isinstance(v, int | float):
            return '"auto" or ' + (check(float("nan")) or "a number")
        problem = check(float(v))
        return None if problem is None else f'"auto" or {problem}'

    return auto


def _meta(check: Check, doc: str) -> dict[str, Any]:
    return {"check": check, "doc": doc}


# --------------------------------------------------------------------------------------------
@dataclass(frozen=True, kw_only=True)
class System:
    """Oscillator parameters (paper eq. 17). ``barrier = false`` removes the impact wall."""

    c1: float = field(default=0.025, metadata=_meta(_finite, "negative: positive linear damping"))
    c2: float = field(default=0.05, metadata=_meta(_nonneg, "Van der Pol cubic damping"))
    omega0: float = field(default=1.0, metadata=_meta(_positive, "linear natural frequency"))
    alpha: float = field(default=0.6, metadata=_meta(_nonneg, "Duffing hardening"))
    mu: float = field(default=0.001, metadata=_meta(_nonneg, "Coulomb friction amplitude"))
    r: float = field(default=0.96, metadata=_meta(_restitution, "restitution at x = 0"))
    f: float = field(default=1.0, metadata=_meta(_finite, "noise gain (not given in paper)"))
    barrier: bool = field(default=True, metadata=_meta(_bool, "impact barrier at x = 0"))


@dataclass(frozen=True, kw_only=True)
class Noise:
    """Excitation xi(t): OU ("real") noise with bandwidth alpha1, or Gaussian white noise."""

    kind: str = field(default="ou", metadata=_meta(_one_of("ou", "white"), "noise model"))
    D: float = field(default=0.01, metadata=_meta(_positive, "intensity: E[W W] = 2 D delta"))
    alpha1: float = field(default=2.0, metadata=_meta(_positive, "OU bandwidth"))


@dataclass(frozen=True, kw_only=True)
class AveragingSettings:
    """Numerical settings of the averaged models (closed form and exact orbit averages)."""

    points: int = field(default=801, metadata=_meta(_int_at_least(17), "grid points in A"))
    tail: float = field(default=1e-10, metadata=_meta(_tail, "mass allowed beyond A_max"))
    theta_nodes: int = field(default=64, metadata=_meta(_int_at_least(8), "GL nodes a quarter"))
    harmonics: int = field(default=24, metadata=_meta(_int_at_least(4), "orbit harmonics"))
    # at most 4001: memory grows as phase_points^2 (12.7 GB and 53 s measured at 20001)
    phase_points: int = field(default=201, metadata=_meta(_int_between(17, 4001),
                                                          "x1, x2 grids"))


@dataclass(frozen=True, kw_only=True)
class MonteCarloSettings:
    """Monte Carlo of the original system: the one set of defaults (montecarlo.Settings has
    none); the study behind them is in docs/montecarlo.md."""

    paths: int = field(default=1024, metadata=_meta(_int_at_least(2), "independent paths"))
    dt: float | str = field(default=0.01, metadata=_meta(
        _auto_or(_positive), 'time step, or "auto": from the target floor'))
    time: float = field(default=2000.0, metadata=_meta(_positive, "sampled time per path"))
    burn_in: float | str = field(default="auto", metadata=_meta(
        _auto_or(_nonneg), 'time before sampling, or "auto": 6 x the measured relaxation time'))
    sample_every: float = field(default=0.5, metadata=_meta(_positive, "sampling interval"))
    seed: int = field(default=20190101, metadata=_meta(_int_at_least(0), "root seed"))
    blocks: int = field(default=32, metadata=_meta(_int_at_least(2), "batches of paths"))
    # at most 100000: far past what a histogram of 1e9 samples resolves
    bins: int = field(default=100, metadata=_meta(_int_between(4, 100_000), "histogram bins"))
    threads: int = field(default=0, metadata=_meta(_int_at_least(0), "0: all cores"))
    floor: float = field(default=0.0, metadata=_meta(
        _floor, "target L1 noise floor of p(A); 0: sample exactly `time`"))
    budget: float = field(default=600.0, metadata=_meta(
        _nonneg, "wall seconds allowed to reach the floor; 0: no limit"))


@dataclass(frozen=True, kw_only=True)
class Observables:
    """What the Monte Carlo records (unrequested ones are not computed)."""

    A: bool = field(default=True, metadata=_meta(_bool, "histogram of the amplitude"))
    x1: bool = field(default=True, metadata=_meta(_bool, "histogram of displacement"))
    x2: bool = field(default=True, metadata=_meta(_bool, "histogram of velocity"))
    joint: bool = field(default=False, metadata=_meta(_bool, "2-D histogram of (x1, x2)"))
    moments: bool = field(default=True, metadata=_meta(_bool, "means and second moments"))
    events: bool = field(default=True, metadata=_meta(_bool, "impacts, sticking, chatter"))
    energy: bool = field(default=False, metadata=_meta(_bool, "stationary power balance"))

    def names(self) -> tuple[str, ...]:
        return tuple(f.name for f in fields(self) if getattr(self, f.name))


SECTIONS: dict[str, type] = {
    "system": System,
    "noise": Noise,
    "averaging": AveragingSettings,
    "montecarlo": MonteCarloSettings,
    "observables": Observables,
}
SWEEPABLE = {"system", "noise"}


@dataclass(frozen=True, kw_only=True)
class Sweep:
    """One parameter varied over a list of values (the paper's figures)."""

    section: str
    key: str
    values: tuple[float, ...]

    @property
    def path(self) -> str:
        return f"{self.section}.{self.key}"


@dataclass(frozen=True, kw_only=True)
class Scene:
    """One system, its noise, and solver settings. Immutable; use :meth:`with_values`."""

    name: str = "scene"
    description: str = ""
    system: System = field(default_factory=System)
    noise: Noise = field(default_factory=Noise)
    averaging: AveragingSettings = field(default_factory=AveragingSettings)
    montecarlo: MonteCarloSettings = field(default_factory=MonteCarloSettings)
    observables: Observables = field(default_factory=Observables)
    sweep: Sweep | None = None
    source: str = ""

    # ---------------------------------------------------------------- sweeps
    def variants(self) -> list[Scene]:
        """The concrete scenes of a sweep (or ``[self]``), each with ``sweep = None``."""
        if self.sweep is None:
            return [self]
        out = []
        for v in self.sweep.values:
            s = self.with_values({self.sweep.path: v})
            out.append(replace(s, name=f"{self.name}[{self.sweep.key}={v:g}]", sweep=None))
        return out

    def with_values(self, values: Mapping[str, Any]) -> Scene:
        """A copy with ``{"section.key": value}`` overrides, validated like a file."""
        raw = self.to_dict()
        raw.pop("sweep", None)
        for path, value in values.items():
            section, _, key = path.partition(".")
            if section not in SECTIONS or not key:
                raise SceneError(f"{path}: unknown field; use section.key with a section in "
                                 f"{sorted(SECTIONS)}")
            raw.setdefault(section, {})[key] = value
        if self.sweep is not None and self.sweep.path not in values:
            raw[self.sweep.section][self.sweep.key] = list(self.sweep.values)
        return scene_from_dict(raw, source=self.source or "<overrides>")

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-ready dictionary (the ``scene`` entry of the solution JSON)."""
        d: dict[str, Any] = {"name": self.name, "description": self.description}
        for sec in SECTIONS:
            d[sec] = dataclasses.asdict(getattr(self, sec))
        if self.sweep is not None:
            d["sweep"] = {"field": self.sweep.path, "values": list(self.sweep.values)}
            d[self.sweep.section][self.sweep.key] = list(self.sweep.values)
        return d


# --------------------------------------------------------------------------------------------
def _suggest(word: str, options: list[str]) -> str:
    close = difflib.get_close_matches(word, options, n=1, cutoff=0.5)
    if close:
        return f"did you mean '{close[0]}'?"
    return "allowed: " + ", ".join(options)


def _coerce(where: str, cls: type, name: str, value: Any) -> Any:
    """Validate one value; ``where`` is "file: section.key" (with [i] for list entries)."""
    f = next(f for f in fields(cls) if f.name == name)
    check: Check = f.metadata["check"]
    if isinstance(f.default, bool):
        pass
    elif f.metadata["check"].__name__ == "auto":  # a number or "auto"
        if isinstance(value, int | float) and not isinstance(value, bool):
            value = float(value)
    elif isinstance(f.default, float):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SceneError(f"{where} = {value!r} must be {check(float('nan'))}")
        value = float(value)
    problem = check(value)
    if problem is not None:
        raise SceneError(f"{where} = {value!r} is out of range; allowed: {problem}")
    return value


def check_value(where: str, section: str, key: str, value: Any) -> Any:
    """One value of ``section.key`` validated as in a scene file (SceneError naming ``where``,
    e.g. a command-line option, with the allowed range); the value as the scene stores it."""
    return _coerce(where, SECTIONS[section], key, value)


def scene_from_dict(raw: Mapping[str, Any], *, source: str = "<dict>") -> Scene:
    """Build and validate a Scene from a parsed TOML document."""
    top = {"name", "description", *SECTIONS}
    for key in raw:
        if key == "sweep" and isinstance(raw[key], Mapping) and set(raw[key]) <= {"field",
                                                                                 "values"}:
            continue  # written by Scene.to_dict beside the varied list; the list rules
        if key not in top:
            raise SceneError(f"{source}: unknown key '{key}'; {_suggest(key, sorted(top))}")
    name = raw.get("name", Path(source).stem if source else "scene")
    if not isinstance(name, str) or not name:
        raise SceneError(f"{source}: name must be a non-empty string")
    description = raw.get("description", "")
    if not isinstance(description, str):
        raise SceneError(f"{source}: description must be a string")

    sweep: Sweep | None = None
    parts: dict[str, Any] = {}
    for sec, cls in SECTIONS.items():
        table = raw.get(sec, {})
        if not isinstance(table, Mapping):
            raise SceneError(f"{source}: [{sec}] must be a table")
        known = [f.name for f in fields(cls)]
        kwargs: dict[str, Any] = {}
        for key, value in table.items():
            where = f"{source}: {sec}"
            if key not in known:
                raise SceneError(f"{where}.{key}: unknown key; {_suggest(key, known)}")
            if isinstance(value, list):
                if sec not in SWEEPABLE:
                    raise SceneError(f"{where}.{key}: a list is only allowed in "
                                     f"{sorted(SWEEPABLE)} (the varied parameter)")
                if sweep is not None:
                    raise SceneError(f"{where}.{key}: only one parameter may vary; "
                                     f"{sweep.path} already does")
                if not value:
                    raise SceneError(f"{where}.{key}: the list of values is empty")
                vals = tuple(_coerce(f"{where}.{key}[{i}]", cls, key, v)
                             for i, v in enumerate(value))
                if not all(isinstance(v, float) for v in vals):
                    raise SceneError(f"{where}.{key}: only numeric parameters can vary")
                sweep = Sweep(section=sec, key=key, values=vals)
                kwargs[key] = vals[0]
            else:
                kwargs[key] = _coerce(f"{where}.{key}", cls, key, value)
        parts[sec] = cls(**kwargs)
    return Scene(name=name, description=description, sweep=sweep, source=source, **parts)


def shipped_scenes() -> Traversable:
    """The shipped scenes: package data ``harness.scenes`` (the repository's top-level
    ``scenes/``, mapped into the wheel by pyproject.toml), read with importlib.resources. In a
    source checkout on ``sys.path`` that is not installed, the repository's ``scenes/``."""
    try:
        return resources.files("harness.scenes")
    except ModuleNotFoundError:
        return Path(__file__).resolve().parents[2] / "scenes"


def shipped_name(text: str) -> bool:
    """True when ``text`` is the name of a shipped scene rather than a path: relative, no
    ``.toml`` suffix, no ``.``/``..``/``~`` parts ("paper-base", "hard/r-low"). A path is a
    path: one that does not exist is an error, never a shipped scene of the same name."""
    parts = text.split("/")
    return bool(text) and not text.endswith(".toml") and not text.startswith(("/", "~")) \
        and all(part and not part.startswith(".") for part in parts) and "\\" not in text


def shipped_names() -> list[str]:
    """The names of the shipped scenes (``hard/...`` included; sweeps excluded)."""
    root = shipped_scenes()
    out = []
    for entry in sorted(root.iterdir(), key=lambda e: e.name):
        if entry.is_file() and entry.name.endswith(".toml"):
            out.append(entry.name[:-5])
        elif entry.is_dir() and entry.name == "hard":
            out += [f"hard/{e.name[:-5]}" for e in sorted(entry.iterdir(), key=lambda e: e.name)
                    if e.name.endswith(".toml")]
    return out


def find_scene(path: str | Path | Traversable) -> Path | Traversable | None:
    """The file a scene path or name stands for, as :func:`load_scene` reads it: the path
    itself when it is a file, else the shipped scene of that bare name (:func:`shipped_name`,
    in :func:`shipped_scenes`); None when there is none."""
    p: Path | Traversable = path if isinstance(path, Traversable) else Path(path)
    if p.is_file():
        return p
    text = str(path)
    if isinstance(path, Traversable) and not isinstance(path, Path) or not shipped_name(text):
        return None
    where = shipped_scenes()
    for part in f"{text}.toml".split("/"):  # one part at a time: a namespace
        where = where / part                # package's MultiplexedPath takes one
    return where if where.is_file() else None


def load_scene(path: str | Path | Traversable) -> Scene:
    """Read a scene file, or a shipped scene by its bare name ("paper-base", "hard/r-low";
    see :func:`shipped_name`). A path (anything ending in ``.toml``, absolute, or starting
    with ``.``) must exist: a wrong path is an error, not another scene of that name. Raises
    :class:`SceneError` (one line) on any problem."""
    p: Path | Traversable = path if isinstance(path, Traversable) else Path(path)
    try:
        is_dir, is_file = p.is_dir(), p.is_file()
    except OSError as exc:  # e.g. a name longer than the file system allows
        raise SceneError(f"{str(path)[:80]}: cannot read ({exc.strerror or exc})") from None
    if is_dir:
        raise SceneError(f"{path}: is a folder; give a scene file (.toml)")
    if not is_file:
        found = find_scene(path)
        if found is None:
            text = str(path)
            if isinstance(path, Traversable) and not isinstance(path, Path) \
                    or not shipped_name(text):
                raise SceneError(f"{path}: no such scene file")
            names = shipped_names()
            close = difflib.get_close_matches(text, names, n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'?" if close else "shipped: " + ", ".join(names)
            raise SceneError(f"{path}: no such scene file or shipped scene; {hint}")
        p = found
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8-sig"))  # a UTF-8 BOM is fine
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"{p.name}: not valid TOML: {exc}") from None
    except RecursionError:
        raise SceneError(f"{p.name}: not valid TOML: arrays or tables nested too deeply"
                         ) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SceneError(f"{p.name}: cannot read: {exc}") from None
    return scene_from_dict(raw, source=p.name)
