"""The scene's other sections: the noise, the numerical settings of the averaged models and of
the Monte Carlo (the one set of its defaults), and the observables (data and validation)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any

from . import registry
from .checks import (
    SceneError,
    _auto_or,
    _bool,
    _floor,
    _int_at_least,
    _int_between,
    _meta,
    _nonneg,
    _positive,
    _tail,
)
from .protocols import ParamsByName, show, suggest


def noise_kind(where: str, name: Any) -> Any:
    """The registered noise kind ``name`` (vifpk.core.protocols.NoiseKind), or SceneError
    naming ``where`` ("file: noise.kind") with the registered kinds and a did-you-mean."""
    try:
        return registry.noise_kind(name)
    except registry.UnknownName as e:
        raise SceneError(f"{where} = {name!r}: {e}") from None


def _defaults(kind: str) -> tuple[tuple[str, float], ...]:
    return tuple((p.name, float(p.default)) for p in registry.noise_kind(kind).params
                 if p.default is not None)


@dataclass(frozen=True, kw_only=True)
class Noise(ParamsByName):
    """Excitation xi(t) (the scene's ``[noise]``): a registered ``kind``
    (vifpk.core.registry.noise_kind) and its declared parameters' values, (name, value) in
    the kind's declared order (OU: D, alpha1; white: D). A parameter reads as an attribute
    (``noise.D``); :attr:`values` has them by name."""

    kind: str = "ou"
    params: tuple[tuple[str, float], ...] = ()

    def __post_init__(self) -> None:
        if not self.params:
            object.__setattr__(self, "params", _defaults(self.kind))

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, **self.values}


def noise_keys(kind: Any) -> dict[str, Any]:
    """The keys of ``[noise]`` for ``kind`` (its declared Params by name), after ``kind``."""
    return {p.name: p for p in kind.params}


def noise_fields() -> dict[str, Any]:
    """Every registered kind's declared parameters by name (vifpk.core.protocols.Param: what
    a dataclass field's ``metadata`` and ``type`` say), the first kind's where two declare one
    name: the keys ``[noise]`` may have in some kind."""
    out: dict[str, Any] = {}
    for name in registry.noise_kind_names():
        for p in registry.noise_kind(name).params:
            out.setdefault(p.name, p)
    return out


def noise_value(where: str, param: Any, value: Any) -> float:
    """One value of a kind's parameter, checked against its declaration (SceneError naming
    ``where`` with the allowed range)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SceneError(f"{where} = {value!r} must be {param.allowed}")
    if param.check(value) is not None:
        raise SceneError(f"{where} = {show(float(value))} is out of range; allowed: "
                         f"{param.allowed}")
    return float(value)


def noise_from_table(where: str, table: Mapping[str, Any]) -> Noise:
    """A validated Noise from ``[noise]`` (``where``: "file: noise"); every key of the kind
    is validated from its declaration alone (a plugin's kind as vifpk's own): an unknown key
    names the kind's keys (did-you-mean), a missing one without default is named, each value
    in its declared range."""
    kind = noise_kind(f"{where}.kind", table.get("kind", "ou"))
    keys = noise_keys(kind)
    values = []
    for key in table:
        if key != "kind" and key not in keys:
            others = [k for k in registry.noise_kind_names()
                      if key in noise_keys(registry.noise_kind(k))]
            hint = (f"it belongs to kind = {' | '.join(repr(k) for k in others)}, not "
                    f"{kind.name!r}" if others else suggest(key, ["kind", *keys]))
            raise SceneError(f"{where}.{key}: unknown key for kind = {kind.name!r}; {hint}")
    for name, p in keys.items():
        if name in table:
            values.append((name, noise_value(f"{where}.{name}", p, table[name])))
        elif p.default is None:
            raise SceneError(f"{where}.{name} is missing: the {kind.name} noise needs it "
                             f"({p.doc}); allowed: {p.allowed}")
        else:
            values.append((name, float(p.default)))
    return Noise(kind=kind.name, params=tuple(values))


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


#: the step of the Monte Carlo runs for which dt "auto" (a step tuned to a stationary
#: target floor) has no meaning: first passage, splitting, transient snapshots
#: (harness/door/timedomain.py time_step) and the fixed-step ladder of ``vifpk
#: workprecision``, where the scene gives no step. It was MonteCarloSettings.dt's default
#: before issue 44 made that "auto".
FIXED_DT = 0.01


@dataclass(frozen=True, kw_only=True)
class MonteCarloSettings:
    """Monte Carlo of the original system: the one set of defaults (montecarlo.Settings has
    none); the study behind them is in docs/montecarlo.md."""

    paths: int = field(default=1024, metadata=_meta(_int_at_least(2), "independent paths"))
    # "auto" (issue 44): the step from the accuracy asked for (montecarlo/tuning.py: the
    # largest step whose predicted bias is half the target floor, DEFAULT_FLOOR without one),
    # checked at run time; a step the scene gives stays as written
    dt: float | str = field(default="auto", metadata=_meta(
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


#: the most points x theta_nodes an averaging grid may have: the exact model's orbit averages
#: hold points x 2 theta_nodes numbers at once (100001 x 64: 3.1 GB peak, 76 s measured; the
#: shipped default is 801 x 64 = 5.1e4)
AVERAGING_SIZE = 6_500_000


def _check_harmonics(where: str, kwargs: Mapping[str, Any]) -> None:
    """The exact model's orbit harmonics are integrals over a quarter orbit by Gauss-Legendre
    with theta_nodes nodes; harmonic n = 2 * harmonics turns through harmonics * pi there.
    Measured (paper-base and a pure quintic spring, A = 1 and 2): up to 3/4 of the nodes
    sigma_E^2 keeps 1e-10 or better; at 1.5 x the nodes it is wrong by 1e-3 and the harmonic
    sum goes negative. So harmonics <= 3 theta_nodes / 4."""
    h = kwargs.get("harmonics", AveragingSettings.harmonics)
    t = kwargs.get("theta_nodes", AveragingSettings.theta_nodes)
    n = kwargs.get("points", AveragingSettings.points)
    if isinstance(n, int) and isinstance(t, int) and n * t > AVERAGING_SIZE:
        raise SceneError(f"{where}.points x theta_nodes = {n} x {t} = {n * t:.3g} is too "
                         f"large: the orbit averages hold points x 2 theta_nodes numbers at "
                         f"once (3.1 GB of memory measured at 100001 x 64); allowed: up to "
                         f"{AVERAGING_SIZE:.3g}")
    if isinstance(h, int) and isinstance(t, int) and 4 * h > 3 * t:
        raise SceneError(f"{where}.harmonics = {h} is more than theta_nodes = {t} resolve; "
                         f"allowed: at most 3/4 of theta_nodes ({3 * t // 4}); raise "
                         f"theta_nodes to {-(-4 * h // 3)} or more with it")
