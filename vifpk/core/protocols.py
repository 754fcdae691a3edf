"""The typed protocols extensions follow (docs/plugins.md), with their version.

An averaged model is what a factory registered in the ``vifpk.models`` entry-point group
returns (vifpk.core.registry): ``factory(scene, **options) -> model``. What vifpk reads of it:

- ``drift(A)``, ``diffusion(A)``: the averaged amplitude SDE dA = m(A) dt + sigma(A) dW, arrays
  in, arrays out (required);
- ``period(A)`` (optional): the orbit's period, for the mapping of p(A) to phase space;
- ``log_stationary_parts(A)`` (optional): a closed form of the stationary density
  (averaging/stationary.py); without it p(A) comes from the FPK direct solve.

Which scenes a model covers is the factory's to say, before anything is built: a factory (or
the class whose ``from_scene`` it is) may define ``applies(scene) -> None | str`` -- None when
the model applies, else one line saying why not. vifpk asks it through
:func:`vifpk.core.registry.model_applies`; a model without it applies everywhere. Nothing in
vifpk tests a model's *name* to decide where it applies.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any, Protocol, runtime_checkable

#: Bumped when a required member is added or a signature changes (docs/plugins.md lists what
#: each version reads); optional members may be added without a bump.
PROTOCOL_VERSION = 1


@runtime_checkable
class AveragedModel(Protocol):
    """The required part of an averaged model (module docstring)."""

    def drift(self, A: Any) -> Any: ...

    def diffusion(self, A: Any) -> Any: ...


@runtime_checkable
class Applicability(Protocol):
    """A factory, or the class behind it, that says where its model applies."""

    def applies(self, scene: Any) -> str | None: ...


@runtime_checkable
class Solver(Protocol):
    """A solver of an averaged model's stationary amplitude FPK (issue 27), registered in the
    ``vifpk.solvers`` entry-point group (vifpk.core.registry.solvers): ``vifpk solve --solver
    NAME --model M`` runs it, and ``vifpk check`` measures it against every model's closed form
    beside the built-in ``fpk`` (metrics.json: the model's ``solver_errors[NAME]``, or the key
    ``metric`` names).

    ``stationary(drift, diffusion, *, cells)`` gets m(A) and sigma^2(A) of
    dA = m dt + sigma dW (arrays in, arrays out, A > 0) and returns the stationary density
    of A: a pair (A, p) of increasing cell centres and densities (the door checks that p is
    finite, non-negative and of mass 1 on A), or a vifpk.core.result.Result whose data hold
    ``"A"`` and ``"A_cells"`` records ``{"x", "p"}`` (the built-in FPK's)."""

    name: str
    summary: str

    def stationary(self, drift: Any, diffusion: Any, *, cells: int) -> Any: ...


@dataclass(frozen=True)
class SolverSpec:
    """The plain record that satisfies :class:`Solver` (docstring there). ``metric``: the key
    of the model's metrics.json entry its comparison with the closed form is stored under
    (None: ``solver_errors[name]``)."""

    name: str
    summary: str
    stationary: Callable[..., Any]
    metric: str | None = None


@runtime_checkable
class Workflow(Protocol):
    """A workflow (issue 27): a question with a name, registered in the ``vifpk.workflows``
    entry-point group (vifpk.core.registry.workflows). Each front end derives its door from the
    registry: the command line adds ``vifpk NAME`` with ``add_arguments`` and runs ``command``
    (both None: no subcommand), a sweep file's ``workflow = NAME`` runs ``sweep_point(job)``
    at every point (None: not sweepable).

    Optional members (read with ``getattr``; added in protocol version 1 without a bump):
    ``api``, the Python function of the workflow (``vifpk.NAME(...)`` and ``vifpk.run(NAME,
    ...)``), and ``assertion``, its tolerance test (``vifpk.<assertion.__name__>`` and
    ``vifpk.harness.testing.assertion(NAME)``)."""

    name: str
    summary: str
    add_arguments: Callable[[Any], None] | None
    command: Callable[[Any], int] | None
    sweep_point: Callable[[Any], dict[str, Any]] | None


@dataclass(frozen=True)
class Ref:
    """A function named by ``"module:attribute"``, imported when it is first called or
    :func:`resolved`: a workflow's record names its command-line parts, its sweep point and
    its Python function without importing them, so the registry (and ``vifpk --help``) does
    not depend on the layers those live in (issue 38: the built-in records sit with the
    workflows; their argparse builders stay in harness/cli). ``name``: the attribute's own
    name (what ``vifpk.<name>`` exposes an assertion as)."""

    target: str

    @property
    def name(self) -> str:
        return self.target.rpartition(":")[2].rpartition(".")[2]

    def load(self) -> Callable[..., Any]:
        return _load_ref(self.target)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.load()(*args, **kwargs)


@cache
def _load_ref(target: str) -> Callable[..., Any]:
    from importlib import import_module

    module, _, attr = target.partition(":")
    obj: Any = import_module(module)
    for part in attr.split("."):
        obj = getattr(obj, part)
    return obj


def resolved(obj: Any) -> Any:
    """``obj`` itself, or the function a :class:`Ref` names (imported now)."""
    return obj.load() if isinstance(obj, Ref) else obj


@dataclass(frozen=True)
class WorkflowSpec:
    """The plain record that satisfies :class:`Workflow` (docstring there). Each callable may
    be given as a :class:`Ref` (``Ref("pkg.module:function")``), imported on first use."""

    name: str
    summary: str
    add_arguments: Callable[[Any], None] | None = None
    command: Callable[[Any], int] | None = None
    sweep_point: Callable[[Any], dict[str, Any]] | None = None
    api: Callable[..., Any] | None = None
    assertion: Callable[..., Any] | None = None


# ------------------------------------------------------------ noise kinds and impact laws
def show(value: float) -> str:
    """A number as the user wrote it: %g where that reads back as the same float and is no
    longer than Python's shortest round-trip text, else that text (1.0000001 is not "1",
    5e-324 not "4.94066e-324"); -0 is 0."""
    v = float(value)
    if v == 0.0:
        return "0"
    g, r = f"{v:g}", repr(v)
    return g if float(g) == v and len(g) <= len(r) else r


def suggest(key: str, known: tuple[str, ...] | list[str]) -> str:
    """"did you mean 'x'?" for the nearest known key (case ignored: "AT" is "at"), else
    "allowed: a, b, c": the hint of every unknown-key message."""
    lower = {k.lower(): k for k in known}
    close = difflib.get_close_matches(str(key).lower(), list(lower), n=1, cutoff=0.5)
    return f"did you mean '{lower[close[0]]}'?" if close else "allowed: " + ", ".join(known)


def _bound(value: float) -> str:
    """A bound of an allowed range: ``0``, ``1``, ``0.5``."""
    return show(value)


@dataclass(frozen=True, kw_only=True)
class Param:
    """One declared parameter of a noise kind or an impact law: a real number in an interval.

    ``low < value`` (``low <= value`` when ``low_closed``) and ``value <= high`` (``< high``
    when ``high_open``); ``default`` None: the scene must give it. ``physical``: the number is
    a physical magnitude, so the scene's magnitude rule applies to it (a non-zero value within
    1e-100..1e100, harness.request.validate). The scene validates every kind's and law's keys
    from these declarations alone (vifpk.core.sections, vifpk.core.walls)."""

    name: str
    doc: str
    default: float | None = None
    low: float = -math.inf
    high: float = math.inf
    low_closed: bool = False
    high_open: bool = False
    physical: bool = True

    #: the value's type (only real numbers, for now): what a field's ``type`` says
    type = "float"

    @property
    def allowed(self) -> str:
        """The allowed range in words: '0 < r <= 1', 'a finite number > 0'."""
        lo_op = "<=" if self.low_closed else "<"
        hi_op = "<" if self.high_open else "<="
        if math.isfinite(self.low) and math.isfinite(self.high):
            return f"{_bound(self.low)} {lo_op} {self.name} {hi_op} {_bound(self.high)}"
        if math.isfinite(self.low):
            return f"a finite number {'>=' if self.low_closed else '>'} {_bound(self.low)}"
        if math.isfinite(self.high):
            return f"a finite number {hi_op} {_bound(self.high)}"
        return "a finite number"

    def check(self, value: Any) -> str | None:
        """None when ``value`` is allowed, else :attr:`allowed` (the scene's Check shape)."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            return self.allowed
        v = float(value)
        ok = (math.isfinite(v) and (v >= self.low if self.low_closed else v > self.low)
              and (v < self.high if self.high_open else v <= self.high))
        return None if ok else self.allowed

    @property
    def metadata(self) -> dict[str, Any]:
        """What a scene dataclass field's metadata holds (vifpk.core.checks._meta)."""
        return {"check": self.check, "doc": self.doc}


@dataclass(frozen=True, kw_only=True)
class AveragingNoise:
    """A noise kind's pieces for the averaged models (averaging/noise.py reads them). Each
    takes the kind's parameters as keywords (``**params``, the names its ``params`` declare).

    - ``spectral_density(omega, **params)`` (required): the two-sided spectral density
      S(w) = (1/pi) int_0^inf R(t) cos(w t) dt of xi, elementwise on an array;
    - ``flat_level(**params)``: S where S is the same at every w (white); None: not flat;
    - ``rational_parts(**params)``: (c, a2) with w^2 S(w) = c - a2 S(w) for every w (OU);
    - ``correlation_rate(**params)``: 1 / correlation time; None: no correlation time.
    The optional ones are closed-form fast paths: a model that has a general path (the
    harmonic sum of S) must agree with them."""

    spectral_density: Callable[..., Any]
    flat_level: Callable[..., float] | None = None
    rational_parts: Callable[..., tuple[float, float]] | None = None
    correlation_rate: Callable[..., float] | None = None


@dataclass(frozen=True, kw_only=True)
class MonteCarloNoise:
    """A noise kind's pieces for the Monte Carlo (montecarlo/pieces.py compiles them; numba
    inlines them into the kernels' loops). Every compiled piece steps ONE path's scalar state:
    its velocity ``v``, the kind's noise state ``xi`` (one float; a kind without state leaves
    it 0) and its generator state ``s0, s1, s2, s3`` (montecarlo/rng.py), returned updated.

    Python side (run once per scene; ``params`` the kind's values by name, f the noise gain):

    - ``Record``: a NamedTuple class of the step's coefficients; its field names must not
      clash with the kernels' own (montecarlo/pieces.BASE_FIELDS, the walls' ``lo_*``/``up_*``):
      prefix them with the kind's name;
    - ``record(params, f, h) -> Record``: the coefficients for step h;
    - ``start(params, f, gen, n) -> array | None``: n draws of the noise state from its
      stationary law with the numpy Generator ``gen`` (None: no state, xi = 0 and nothing
      drawn), for the stationary runs' starts;
    - ``start_sd(params) -> float | None``: the standard deviation of a Gaussian stationary
      state (None: none); the compiled orbit starts draw xi = start_sd N when it is given;
    - ``bridge(params, f) -> float | None``: the variance rate per v^2 of the energy at the kick
      (first passage's Brownian-bridge correction; white: 2 D f^2), None: E is C^1 in time;
    - ``input_power(params, f) -> float | None``: the exact mean input power, if any.

    Compiled (no annotations: numba matches the parameters to montecarlo/pieces.py's generic
    functions by name; ``rec`` is the kernels' whole record, so the pieces may read ``rec.f``):

    - ``press(rec, xi)``: the noise force pressing the mass onto a wall over the step;
    - ``velocity(flow, normal)`` -> ``stage(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1,
      s2, s3) -> (v, stuck, vc, vk, vd, s0, s1, s2, s3)``: the velocity stage B of the step;
    - ``advance(normal)`` -> ``advance(rec, xi, s0, s1, s2, s3) -> (xi, s0, s1, s2, s3)``;
    - ``energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi)`` -> (work of the noise, damping
      loss, friction loss) over the stage B;
    - ``state_start(normal, uniform)`` -> ``start(rec, s0, s1, s2, s3) -> (xi, s0, s1, s2,
      s3)``: one draw of the state from its stationary law (a kind may need a non-Gaussian
      start: a random phase uniform on [0, 2 pi)).

    Optional (None: the stage's force is exact in law over a step, as white noise's
    increments): ``held_excess(params, omega, h) -> float``, for a kind whose velocity stage
    holds its force f xi over the step (xi sampled once a step, at its middle): the relative
    error S_held(omega) / S(omega) - 1 of the held (zero-order-hold) force's spectrum at the
    orbit frequency omega, sinc^2(omega h / 2) (h / 2 pi) sum_k R(k h) cos(omega k h) over
    the noise's S(omega) (the sampled values' aliases, sum_{k != 0} S(omega + 2 pi k / h):
    about (rate h)^2 / 12 for a spectrum falling as w^-2 beyond its rate). The step rule
    (montecarlo/tuning.py, hold_bias) keeps it within the bias it allows."""

    Record: type
    record: Callable[..., Any]
    start: Callable[..., Any]
    start_sd: Callable[..., float | None]
    bridge: Callable[..., float | None]
    input_power: Callable[..., float | None]
    press: Callable[..., Any]
    velocity: Callable[..., Any]
    advance: Callable[..., Any]
    energy: Callable[..., Any]
    state_start: Callable[..., Any]
    held_excess: Callable[..., float] | None = None


@dataclass(frozen=True, kw_only=True)
class FPK2DNoise:
    """A noise kind's piece for the original system's own Fokker-Planck solver in (x, v)
    (vifpk.fpk2d, issue 46): ``velocity_diffusion(params, f)``, the constant B0 of the
    diffusion B0 d^2p/dv^2 the excitation f xi adds (white: D f^2). A kind with a state of its
    own (OU) has none: that solver refuses it."""

    velocity_diffusion: Callable[..., float]


@runtime_checkable
class NoiseKind(Protocol):
    """A kind of excitation xi(t) (the scene's ``[noise] kind``), registered in the
    ``vifpk.noise_kinds`` entry-point group (vifpk.core.registry.noise_kind). ``params``: its
    keys in the ``[noise]`` table; ``averaging`` and ``montecarlo``: its pieces for those
    solvers (None: that solver refuses a scene of this kind, in one line, before any work).
    The scene's excitation is f xi(t) for every kind. Optional (read with ``getattr``, added
    in protocol version 1 without a bump): ``fpk2d``, a :class:`FPK2DNoise`."""

    name: str
    summary: str
    params: tuple[Param, ...]
    averaging: AveragingNoise | None
    montecarlo: MonteCarloNoise | None


@dataclass(frozen=True, kw_only=True)
class NoiseKindSpec:
    """The plain record that satisfies :class:`NoiseKind` (docstring there)."""

    name: str
    summary: str
    params: tuple[Param, ...]
    averaging: AveragingNoise | None = None
    montecarlo: MonteCarloNoise | None = None
    fpk2d: FPK2DNoise | None = None


@runtime_checkable
class ImpactLaw(Protocol):
    """An impact law of a wall (the scene's ``law`` in a wall table), registered in the
    ``vifpk.impact_laws`` entry-point group (vifpk.core.registry.impact_law): the rebound
    speed is e(v) times the impact speed v. ``params``: its keys in the wall table (besides
    ``at`` and ``law``). The functions take the impact speed and the parameters positionally
    in declared order, plain arithmetic on a float or a numpy array (numba compiles them on
    scalars: the Monte Carlo's walls):

    - ``restitution(v, *params)``: e(v), 0 <= e <= 1 (both solvers);
    - ``energy_loss(v, *params)``: the kinetic energy one impact at speed v takes,
      (1 - e(v)^2) v^2 / 2 (the averaged models);
    - ``limit(*params)``: e as |v| -> inf (the scene's large-amplitude energy balance:
      impacts remove energy at large amplitude when it is below 1);
    - ``constant``: whether e does not depend on v. The averaged models read this declaration
      (a constant-e wall at 0 is the paper's: its closed forms), never a parameter's value
      or the law's name."""

    name: str
    summary: str
    params: tuple[Param, ...]
    constant: bool
    restitution: Callable[..., Any]
    energy_loss: Callable[..., Any]
    limit: Callable[..., float]


@dataclass(frozen=True, kw_only=True)
class ImpactLawSpec:
    """The plain record that satisfies :class:`ImpactLaw` (docstring there)."""

    name: str
    summary: str
    params: tuple[Param, ...]
    constant: bool
    restitution: Callable[..., Any]
    energy_loss: Callable[..., Any]
    limit: Callable[..., float]


class ParamsByName:
    """A noise kind's parameter values, ``params`` ((name, value) pairs, as declared), read by
    name: ``obj.values`` (a dict) and ``obj.D`` (an AttributeError naming the kind for a
    name it does not declare). Shared by the scene's ``[noise]`` section and the averaged
    models' spectrum, which both hold ``kind`` and ``params``."""

    @property
    def values(self) -> dict[str, float]:
        """The kind's parameters by name (the keywords of its pieces)."""
        return dict(self.params)  # type: ignore[attr-defined]

    def __getattr__(self, name: str) -> float:
        if name.startswith("__") or name in ("kind", "params"):
            raise AttributeError(name)
        for key, value in self.__dict__.get("params", ()):
            if key == name:
                return value
        raise AttributeError(f"noise kind {self.__dict__.get('kind')!r} has no parameter "
                             f"{name!r}")
