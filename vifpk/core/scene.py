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
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

# the scene's parts live in their own modules; their names are the scene's words too
from .checks import MAX_TERMS, Check, SceneError
from .energy import EnergyBalance, energy_balance
from .paths import INDEXED, _field_of, law_term, shared_term
from .protocols import show
from .result import BadInput
from .sections import (
    AVERAGING_SIZE,
    AveragingSettings,
    MonteCarloSettings,
    Noise,
    Observables,
    _check_harmonics,
    noise_fields,
    noise_from_table,
    noise_keys,
    noise_kind,
    noise_value,
)
from .shipped import (
    find_scene,
    is_toml_file,
    read_toml,
    shipped_name,
    shipped_names,
    shipped_scenes,
)
from .system import ALIASES, System, _alias_formula, restoring_problem
from .walls import Parametric, Wall, check_walls, wall_from_table, wall_keys

__all__ = [
    "ALIASES", "AVERAGING_SIZE", "INDEXED", "MAX_TERMS", "SECTIONS", "SWEEPABLE",
    "WALL_TABLES", "AveragingSettings", "Check", "EnergyBalance", "MonteCarloSettings", "Noise",
    "Observables", "Parametric", "Scene", "SceneError", "Sweep", "System", "Wall",
    "check_value", "declared_params", "energy_balance", "find_scene", "is_toml_file",
    "law_term", "load_scene", "no_noise", "read_toml", "restoring_problem", "scene_from_dict",
    "section_fields", "shared_term", "shipped_name", "shipped_names", "shipped_scenes",
]


SECTIONS: dict[str, type] = {
    "system": System,
    "noise": Noise,
    "parametric": Parametric,
    "averaging": AveragingSettings,
    "montecarlo": MonteCarloSettings,
    "observables": Observables,
}
SWEEPABLE = {"system", "noise", "parametric"}
#: the system's wall tables (vifpk.core.walls): "system.lower_wall.at" and so on
WALL_TABLES = {"lower_wall": "lower", "upper_wall": "upper"}


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
    parametric: Parametric = field(default_factory=Parametric)
    averaging: AveragingSettings = field(default_factory=AveragingSettings)
    montecarlo: MonteCarloSettings = field(default_factory=MonteCarloSettings)
    observables: Observables = field(default_factory=Observables)
    sweep: Sweep | None = None
    source: str = ""
    #: "section.key" of every value the scene was given (its file, with_values, --set), as
    #: opposed to a default: e.g. whether a time step was asked for (harness.request.prepare)
    given: frozenset[str] = field(default=frozenset(), compare=False)

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
            if section == "system":
                _set_system(raw.setdefault("system", {}), path, key, value)
            elif path == "noise.kind":
                _set_kind(raw.setdefault("noise", {}), value, values)
            else:
                raw.setdefault(section, {})[key] = value
        if self.sweep is not None and self.sweep.path not in values:
            raw[self.sweep.section][self.sweep.key] = list(self.sweep.values)
        new = scene_from_dict(raw, source=self.source or "<overrides>")
        return replace(new, given=self.given | {_field_of(p) for p in values})

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON-ready dictionary (the ``scene`` entry of the solution JSON)."""
        d: dict[str, Any] = {"name": self.name, "description": self.description}
        for sec in SECTIONS:
            if sec == "parametric" and not self.parametric.on:
                continue  # off: the paper's scenes keep their dictionary (and hash)
            d[sec] = (getattr(self, sec).to_dict() if sec in ("system", "noise")
                      else dataclasses.asdict(getattr(self, sec)))
        if self.sweep is not None:
            d["sweep"] = {"field": self.sweep.path, "values": list(self.sweep.values)}
            d[self.sweep.section][self.sweep.key] = list(self.sweep.values)
        return d


def section_fields(section: str) -> dict[str, Any]:
    """The fields of a scene section by name (``noise``: every registered kind's declared
    parameters, vifpk.core.sections.noise_fields)."""
    if section == "noise":
        return noise_fields()
    return {f.name: f for f in fields(SECTIONS[section])}


def declared_params(scene: Scene) -> list[tuple[str, str, Any, float]]:
    """(section, key, Param, value) of the scene's noise kind's parameters ("noise", "D") and
    of its wall tables' laws' ("system", "lower_wall.v_yield"), as the kind and the laws
    declare them (vifpk.core.protocols.Param): what the magnitude rules read."""
    from . import registry

    out = [("noise", p.name, p, scene.noise.values[p.name])
           for p in registry.noise_kind(scene.noise.kind).params]
    if scene.system.r is None:  # wall tables (the paper's r is a system key)
        for w in scene.system.walls:
            out += [("system", f"{w.side}_wall.{p.name}", p, w.values[p.name])
                    for p in registry.impact_law(w.law).params]
    return out


def no_noise(system: Any) -> str | None:
    """The f = 0 rule, in its one wording (every workflow and solver says it so, adding what
    it means there): None when the system is driven by noise."""
    if system.f == 0.0:
        return ("f = 0: there is no noise, so no stationary density exists (the amplitude "
                "relaxes to a deterministic attractor)")
    return None


def _set_kind(raw: dict[str, Any], kind: Any, values: Mapping[str, Any]) -> None:
    """``noise.kind = kind`` on a raw noise table: the old kind's keys the new kind does not
    declare go (a value the same overrides give stays, and is refused if foreign); an unknown
    kind is left for the validation to name."""
    try:
        new = noise_kind("noise.kind", kind)
    except SceneError:
        raw["kind"] = kind
        return
    if raw.get("kind", "ou") != kind:
        for key in list(raw):
            if key != "kind" and key not in noise_keys(new) and f"noise.{key}" not in values:
                del raw[key]
    raw["kind"] = kind


def _drop_foreign(wall: dict[str, Any], law: Any) -> None:
    """A wall table switched to ``law``: the old law's parameters the new one does not
    declare go (an unknown law is left for the validation to name)."""
    from . import registry

    try:
        keep = {"at", "law", *(p.name for p in registry.impact_law(law).params)}
    except registry.UnknownName:
        return
    for key in [k for k in wall if k not in keep]:
        del wall[key]


def wall_is_a_table(path: str, value: Any) -> str:
    """The one line for a wall table given a single value (``--set system.lower_wall=-0.2``,
    a sweep varying ``system.lower_wall``)."""
    example = value if isinstance(value, int | float) and not isinstance(value, bool) else "X"
    return (f"{path} is a table (keys {', '.join(wall_keys())}), not a value; set one of its "
            f"keys, e.g. {path}.at={example}")


def _set_system(raw: dict[str, Any], path: str, key: str, value: Any) -> None:
    """Apply ``system.key = value`` to a raw system table. ``key`` may index a law
    ("restoring[2]": the k5 coefficient; the list grows with zeros) or be a paper name; either
    spelling works whichever one the scene was written in."""
    table, dot, sub = key.partition(".")
    if dot:
        if table not in WALL_TABLES:
            raise SceneError(f"{path}: unknown field; only {sorted(WALL_TABLES)} have "
                             "sub-keys (e.g. system.lower_wall.at)")
        if table not in raw and not any(t in raw for t in WALL_TABLES):
            # the paper's wall (r, barrier) becomes a table, so one spelling stays
            if raw.pop("barrier", True):
                raw["lower_wall"] = {"at": 0.0, "r": raw.pop("r", System.r)}
            raw.pop("r", None)
        wall = dict(raw.get(table) or {})
        if sub == "law" and value != wall.get("law", "newton"):
            _drop_foreign(wall, value)
        wall[sub] = value
        raw[table] = wall
        return
    if key in WALL_TABLES and not isinstance(value, Mapping | Wall):
        raise SceneError(wall_is_a_table(path, value))
    m = INDEXED.fullmatch(key)
    name, index = (m.group(1), int(m.group(2))) if m else (key, None)
    laws = {law for law, _, _ in ALIASES.values()} | {"velocity_damping"}
    if index is not None and name not in laws:
        raise SceneError(f"{path}: only {sorted(laws)} take an index")
    if name in ALIASES and ALIASES[name][0] in raw:
        law, index, to_coefficient = ALIASES[name]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SceneError(f"{path} = {value!r} must be a finite number")
        _coerce(path, System, name, float(value))
        name, value = law, to_coefficient(float(value))
    if name in laws:
        names = [a for a, (law, _, _) in ALIASES.items() if law == name]
        if any(a in raw for a in names):  # written with the paper's names: convert
            sys_ = scene_from_dict({"system": raw}, source=path).system
            raw[name] = list(sys_.restoring_law if name == "restoring" else sys_.damping_law)
            for a in names:
                raw.pop(a, None)
        if index is None:
            raw[name] = value
            return
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SceneError(f"{path} = {value!r} must be a finite number")
        coeffs = list(raw.get(name, []))
        if index >= MAX_TERMS:
            raise SceneError(f"{path}: index out of range; allowed: 0 to {MAX_TERMS - 1}")
        coeffs += [0.0] * (index + 1 - len(coeffs))
        coeffs[index] = float(value)
        raw[name] = coeffs
        return
    raw[name] = value


def _suggest(word: str, options: list[str]) -> str:
    close = difflib.get_close_matches(word, options, n=1, cutoff=0.5)
    if close:
        return f"did you mean '{close[0]}'?"
    return "allowed: " + ", ".join(options)


def _coerce(where: str, cls: type, name: str, value: Any) -> Any:
    """Validate one value; ``where`` is "file: section.key" (with [i] for list entries)."""
    f = next(f for f in fields(cls) if f.name == name)
    check: Check = f.metadata["check"]
    if isinstance(f.default, tuple):  # a polynomial law: a list of numbers
        if not isinstance(value, list | tuple):
            raise SceneError(f"{where} = {value!r} must be {check(None)}")
        for i, c in enumerate(value):
            if isinstance(c, bool) or not isinstance(c, int | float) or not math.isfinite(c):
                raise SceneError(f"{where}[{i}] = {c!r} must be a finite number")
        value = tuple(float(c) for c in value)
    elif isinstance(f.default, bool):
        pass
    elif f.metadata["check"].__name__ == "auto":  # a number or "auto"
        if isinstance(value, int | float) and not isinstance(value, bool):
            value = float(value)
    elif isinstance(f.default, float):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SceneError(f"{where} = {value!r} must be {check(float('nan'))}")
        value = float(value)
    elif (isinstance(f.default, int) and isinstance(value, float) and value.is_integer()
          and abs(value) < 2.0**63):
        value = int(value)  # 1e8 is a whole number: its size is for the range and the cost
    problem = check(value)
    if problem is not None:
        shown = list(value) if isinstance(value, tuple) else value
        raise SceneError(f"{where} = {shown!r} is out of range; allowed: {problem}")
    return value


def check_value(where: str, section: str, key: str, value: Any) -> Any:
    """One value of ``section.key`` validated as in a scene file (SceneError naming ``where``,
    e.g. a command-line option, with the allowed range); the value as the scene stores it.
    A ``noise`` key is checked against the declaration of the first kind that has it."""
    if section == "noise":
        from . import registry

        for name in registry.noise_kind_names():
            param = noise_keys(registry.noise_kind(name)).get(key)
            if param is not None:
                return noise_value(where, param, value)
        raise SceneError(f"{where}: noise.{key} is no registered noise kind's parameter")
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
        if cls is Noise:
            parts[sec], sweep = _noise_section(f"{source}: noise", table, sweep)
            continue
        known = [f.name for f in fields(cls)]
        kwargs: dict[str, Any] = {}
        if cls is System:
            _check_wall_spelling(f"{source}: system", table)
        for key, value in table.items():
            where = f"{source}: {sec}"
            if key not in known:
                raise SceneError(f"{where}.{key}: unknown key; {_suggest(key, known)}")
            if cls is System and key in WALL_TABLES:
                try:
                    kwargs[key] = wall_from_table(f"{where}.{key}", WALL_TABLES[key], value)
                except SceneError:
                    raise
                except BadInput as e:
                    raise SceneError(str(e)) from None
                continue
            if isinstance(value, list) and not isinstance(
                    next(f for f in fields(cls) if f.name == key).default, tuple):
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
        if cls is System:
            _check_laws(f"{source}: system", table, kwargs)
            try:
                check_walls(f"{source}: system", kwargs.get("lower_wall"),
                            kwargs.get("upper_wall"))
            except BadInput as e:
                raise SceneError(str(e)) from None
        if cls is AveragingSettings:
            _check_harmonics(f"{source}: averaging", kwargs)
        parts[sec] = cls(**kwargs)
        if cls is System:
            _check_wall_energy(f"{source}: system", parts[sec])
    given = frozenset(f"{sec}.{key}" for sec in SECTIONS
                      if isinstance(raw.get(sec), Mapping) for key in raw[sec])
    return Scene(name=name, description=description, sweep=sweep, source=source, given=given,
                 **parts)


def _noise_section(where: str, table: Mapping[str, Any], sweep: Sweep | None
                   ) -> tuple[Noise, Sweep | None]:
    """The ``[noise]`` table validated from its kind's declaration (sections.noise_from_table),
    with a list of values for one of its parameters as the scene's sweep."""
    kind = noise_kind(f"{where}.kind", table.get("kind", "ou"))
    keys = noise_keys(kind)
    table = dict(table)
    for key, value in list(table.items()):
        if not isinstance(value, list) or key not in keys:
            continue  # not a list, or an unknown key: noise_from_table names it
        if sweep is not None:
            raise SceneError(f"{where}.{key}: only one parameter may vary; "
                             f"{sweep.path} already does")
        if not value:
            raise SceneError(f"{where}.{key}: the list of values is empty")
        vals = tuple(noise_value(f"{where}.{key}[{i}]", keys[key], v)
                     for i, v in enumerate(value))
        sweep = Sweep(section="noise", key=key, values=vals)
        table[key] = vals[0]
    return noise_from_table(where, table), sweep


def _check_wall_energy(where: str, system: System) -> None:
    """Each wall at a finite spring energy U(at) = sum_j k_(2j+1) at^(2j+2) / (2j+2): a wall
    whose energy overflows a float (at = -1e300) would fail deep in a solver (exit 3)."""
    k = system.restoring_law
    for w in system.walls:
        try:
            u = sum(c * w.at ** (2 * j + 2) / (2 * j + 2) for j, c in enumerate(k))
        except OverflowError:
            u = math.inf
        if not math.isfinite(u):
            raise SceneError(f"{where}.{w.side}_wall.at = {show(w.at)}: the spring's energy U(at) "
                             "overflows; allowed: a position of finite energy (a wall that "
                             "far is no wall: leave its table out)")


def _check_wall_spelling(where: str, table: Mapping[str, Any]) -> None:
    """One spelling of the walls: the tables, or the paper's ``r`` and ``barrier``."""
    tables = [t for t in WALL_TABLES if t in table]
    old = [k for k in ("r", "barrier") if k in table]
    if tables and old:
        raise SceneError(f"{where}.{old[0]} and {where.split(': ')[-1]}.{tables[0]} both set "
                         f"the walls; give one spelling (a wall table has its own r; "
                         f"barrier = false is no table)")


def _check_laws(where: str, table: Mapping[str, Any], kwargs: Mapping[str, Any]) -> None:
    """One spelling per law; the restoring law gives one well (restoring_problem)."""
    for name, (law, index, _) in ALIASES.items():
        if name in table and law in table:
            raise SceneError(f"{where}.{name} and {where.split(': ')[-1]}.{law} both set the "
                             f"{law} law; give one (the paper's {name} is the coefficient "
                             f"{law}[{index}] = {_alias_formula(name)})")
    k = kwargs.get("restoring") or (kwargs.get("omega0", 1.0) ** 2, kwargs.get("alpha", 0.6))
    if isinstance(kwargs.get("alpha"), list | tuple) or isinstance(kwargs.get("omega0"),
                                                                   list | tuple):
        return  # a sweep: each value is checked by Scene.variants
    problem = restoring_problem(tuple(k))
    if problem is not None:
        key = "restoring" if "restoring" in table else "alpha"
        raise SceneError(f"{where}.{key} = {list(k) if key == 'restoring' else kwargs.get(key)}"
                         f": {problem}")


def load_scene(path: str | Path | Traversable) -> Scene:
    """Read a scene file, or a shipped scene by its bare name ("paper-base", "hard/r-low";
    see :func:`shipped_name`). A path (anything ending in ``.toml``, absolute, or starting
    with ``.``) must exist: a wrong path is an error, not another scene of that name. Raises
    :class:`SceneError` (one line) on any problem."""
    p: Path | Traversable = path if isinstance(path, Traversable) else Path(path)
    if not is_toml_file(p, SceneError, "scene"):
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
    return scene_from_dict(read_toml(p)[1], source=p.name)



