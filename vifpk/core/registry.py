"""Registries: the names of solvers, noise kinds, impact laws, averaged models and workflows.

Each list is written here once; every package reads it from here (a solver checks its input
against it, the scene schema validates against it, the command line offers it).

Averaged models are registered by entry point, in the group ``vifpk.models``::

    [project.entry-points."vifpk.models"]
    mymodel = "mypackage.model:build"      # build(scene, **options) -> model

The object a factory returns follows the averaged-model protocol (docs/testing.md):
``drift(A)`` and ``diffusion(A)`` (arrays in, arrays out), optionally ``period(A)`` and
``log_stationary_parts(A)`` (a closed form, averaging/stationary.py). vifpk's own models
(``paper``, ``exact``, ``corrected``) are registered the same way in vifpk's pyproject.toml,
so a new built-in model is its own file plus one line there.

Every registration is read from the installed metadata (vifpk's own too: a line added to
pyproject.toml is seen after ``pip install -e .``), so an editable install and a wheel see the
same entries in the same order: vifpk's own by name, then other distributions' by name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from importlib import import_module, metadata
from typing import Any

#: The two solvers every cross-check has: an averaged model's closed form and the simulation
#: of the original system. The solvers of a model's FPK sit between them in ``solver_names()``:
#: registered in the ``vifpk.solvers`` entry-point group (vifpk's own: ``fpk``).
CLOSED_FORM, ORIGINAL = "averaging", "montecarlo"
#: The original system's own Fokker-Planck equation in (x, v) (vifpk.fpk2d, issue 46): no
#: averaging and no sampling noise, for the scenes it has generators for (white noise).
ORIGINAL_FPK = "original-fpk"
#: Kinds of excitation xi(t): Ornstein-Uhlenbeck ("real") noise, Gaussian white noise.
NOISE_KINDS = ("ou", "white")
#: The exact averaged model's treatments of the impact term (averaging/exact.py,
#: ``energy_terms``): not physical laws (those are IMPACT_LAW_NAMES).
IMPACT_LAWS = ("exact", "transformed", "compounded")
#: Physical impact laws a wall can have (vifpk.core.walls; each its module
#: vifpk/physics/impact/<name>.py) and the wall parameters each takes beyond r: Newton's
#: constant restitution, and Johnson's elastic-plastic restitution that falls as v^(-1/4)
#: above a yield speed. A law that takes ``v_yield`` must have e(v) -> 0 as |v| -> inf: its
#: impacts remove energy at large amplitude even with r = 1 (vifpk.core.energy counts them a
#: loss, vifpk.core.walls requires the parameter), read from here, not from the law's name.
IMPACT_LAW_PARAMS: dict[str, tuple[str, ...]] = {"newton": (), "johnson": ("v_yield",)}
IMPACT_LAW_NAMES = tuple(IMPACT_LAW_PARAMS)

MODEL_GROUP = "vifpk.models"
WORKFLOW_GROUP = "vifpk.workflows"
SOLVER_GROUP = "vifpk.solvers"
DISTRIBUTION = "vifpk"


class UnknownName(ValueError):
    """A name that is not registered; the message is one line listing the registered ones."""


def one_of(what: str, name: Any, allowed: tuple[str, ...] | list[str]) -> str:
    """``name`` if it is in ``allowed``, else UnknownName("<what> must be one of (...), not
    'x'") -- the one wording of every unknown-kind error."""
    if name not in allowed:
        raise UnknownName(f"{what} must be one of {tuple(allowed)}, not {name!r}")
    return name


# ----------------------------------------------------------------------------- models
@dataclass(frozen=True)
class ModelEntry:
    """One registered averaged model: its name, ``module:attribute`` and who registered it."""

    name: str
    value: str
    distribution: str

    @property
    def builtin(self) -> bool:
        return self.distribution == DISTRIBUTION

    def load(self) -> Callable[..., Any]:
        module, _, attr = self.value.partition(":")
        obj: Any = import_module(module.strip())
        for part in attr.strip().split(".") if attr else ():
            obj = getattr(obj, part)
        return obj


def _group(group: str) -> tuple[tuple[ModelEntry, ...], tuple[str, ...]]:
    """(entries, conflicts) of one entry-point group, from the installed metadata only (the
    same in an editable install and a wheel; pyproject.toml is never read at run time): vifpk's
    own first, then other distributions', each by name. A name registered twice keeps its
    first entry; the clash is reported in ``conflicts``."""
    own: list[ModelEntry] = []
    others: list[ModelEntry] = []
    for ep in metadata.entry_points(group=group):
        dist = ep.dist.metadata["Name"] if ep.dist is not None else "?"
        (own if dist == DISTRIBUTION else others).append(ModelEntry(ep.name, ep.value, dist))
    found: dict[str, ModelEntry] = {}
    conflicts = []
    for e in sorted(own, key=lambda e: e.name) + sorted(others,
                                                       key=lambda e: (e.name, e.distribution)):
        if e.name in found:
            conflicts.append(f"{e.name!r} from {e.distribution} (kept the one from "
                             f"{found[e.name].distribution})")
        else:
            found[e.name] = e
    return tuple(found.values()), tuple(conflicts)


@cache
def _entries() -> tuple[tuple[ModelEntry, ...], tuple[str, ...]]:
    """The averaged models' (entries, conflicts) (``_group``)."""
    return _group(MODEL_GROUP)


@cache
def _workflow_load() -> tuple[tuple[tuple[Any, ModelEntry], ...], dict[str, str]]:
    """(loaded, failures): every registered workflow (``vifpk.workflows``) loaded with its
    entry, and, for another distribution's that does not load or is not a Workflow of its
    name, the one-line message naming it (issue 39, W01/W02: a broken plugin must not block
    vifpk's own commands). vifpk's own that does not load raises PluginError (a bug)."""
    from .guard import PluginError, describe, source_of
    from .protocols import Workflow

    loaded, failures = [], {}
    for e in _group(WORKFLOW_GROUP)[0]:
        module, _, attr = e.value.partition(":")
        label = f"workflow {e.name!r} ({e.value}, from {e.distribution})"
        try:
            obj = getattr(import_module(module), attr)
        except (KeyboardInterrupt, GeneratorExit):
            raise
        except BaseException as exc:  # noqa: BLE001 - one line naming the plugin
            text = f"{label} did not load: {describe(exc, source_of(module))}"
            if e.builtin:
                raise PluginError(text) from exc
            failures[e.name] = text
            continue
        if not isinstance(obj, Workflow) or obj.name != e.name:
            text = f"{label} is not a vifpk.core.protocols.Workflow of that name"
            if e.builtin:
                raise PluginError(text)
            failures[e.name] = text
            continue
        loaded.append((obj, e))
    return tuple(loaded), failures


def workflows() -> tuple[Any, ...]:
    """Every registered workflow that loads (``vifpk.workflows``; vifpk.core.protocols.Workflow):
    vifpk's own first, then other distributions', each by name (``_group``). Another
    distribution's entry that does not load is left out and named by
    :func:`workflow_failures`; vifpk's own that does not load raises PluginError."""
    return tuple(w for w, _ in _workflow_load()[0])


def workflow_entry(name: str) -> ModelEntry | None:
    """The registry entry of the loaded workflow ``name`` (None when there is none)."""
    return next((e for w, e in _workflow_load()[0] if w.name == name), None)


def workflow_failures() -> dict[str, str]:
    """Another distribution's workflows that did not load: name -> one line naming it."""
    return dict(_workflow_load()[1])


def workflow(name: str) -> Any:
    """The registered workflow ``name``; UnknownName listing the registered ones otherwise."""
    found = {w.name: w for w in workflows()}
    one_of("workflow", name, tuple(found))
    return found[name]


@cache
def _solver_entries() -> tuple[ModelEntry, ...]:
    return _group(SOLVER_GROUP)[0]


def model_solver_names() -> tuple[str, ...]:
    """The registered solvers of an averaged model's FPK (``vifpk.solvers``; vifpk's own
    first), read without importing one. A plugin registered as ``averaging`` or
    ``montecarlo`` is shadowed by those two (a name keeps its first meaning, as for models)."""
    return tuple(e.name for e in _solver_entries()
                 if e.name not in (CLOSED_FORM, ORIGINAL, ORIGINAL_FPK))


def solver_names() -> tuple[str, ...]:
    """Every solver ``vifpk solve --solver`` offers, in order: the closed form, the registered
    FPK solvers (model_solver_names), the Monte Carlo of the original system, its FPK."""
    return (CLOSED_FORM, *model_solver_names(), ORIGINAL, ORIGINAL_FPK)


@cache
def solver(name: str) -> tuple[Any, ModelEntry]:
    """(the registered FPK solver ``name``, loaded: a vifpk.core.protocols.Solver; its entry).
    UnknownName listing the registered ones; an entry that does not load or is not a Solver of
    its name raises PluginError naming it (and its file)."""
    from .guard import PluginError
    from .protocols import Solver

    found = {e.name: e for e in _solver_entries() if e.name in model_solver_names()}
    one_of("FPK solver", name, tuple(found))
    e = found[name]
    label = f"solver plugin {e.name!r} ({e.value}, from {e.distribution})"
    obj = _import_entry(e, label)
    if not isinstance(obj, Solver) or obj.name != e.name:
        raise PluginError(f"{label} is not a vifpk.core.protocols.Solver of that name")
    return obj, e


def models() -> tuple[ModelEntry, ...]:
    """Every registered averaged model: vifpk's own first, then plugins by name."""
    return _entries()[0]


def model_names() -> tuple[str, ...]:
    return tuple(e.name for e in models())


def model_conflicts() -> tuple[str, ...]:
    """Names registered by more than one distribution (the first registration is used)."""
    return _entries()[1]


def model_entry(name: str) -> ModelEntry:
    """The registered model ``name``; UnknownName listing the registered names otherwise."""
    for e in models():
        if e.name == name:
            return e
    raise UnknownName(f"model must be one of {model_names()}, not {name!r}")


def _plugin_label(entry: ModelEntry) -> str:
    from .guard import source_of

    src = source_of(entry.value.partition(":")[0].strip())
    return f"model plugin {entry.name!r} (from {entry.distribution}" + \
        (f", {src})" if src else ")")


def _load(entry: ModelEntry) -> Any:
    """The entry point's factory. Not importable: UnknownName naming the entry point. A
    plugin whose import raises anything else (or calls sys.exit): PluginError naming it."""
    def missing(exc: BaseException) -> UnknownName:
        return UnknownName(f"model {entry.name!r}: its entry point {entry.value!r} (from "
                           f"{entry.distribution}) cannot be loaded: {exc}")

    return _import_entry(entry, _plugin_label(entry), entry.name, missing=missing)


def _import_entry(entry: ModelEntry, label: str, name: str | None = None, *,
                  missing: Callable[[BaseException], Exception] | None = None) -> Any:
    """The object an entry point names. ``missing``: what an ImportError or AttributeError
    becomes (a model's entry point to a module not installed); else, for another
    distribution's entry, whatever importing it raises (or a sys.exit) is a PluginError
    "<label>: importing it raised ..." naming its file; vifpk's own raise as they are."""
    from .guard import PluginError, describe, plugin_stdout, source_of

    try:
        if entry.builtin:
            return entry.load()
        with plugin_stdout():
            return entry.load()
    except (KeyboardInterrupt, GeneratorExit):
        raise
    except BaseException as exc:  # noqa: BLE001 - the plugin's own failure, named
        if missing is not None and isinstance(exc, ImportError | AttributeError):
            raise missing(exc) from None
        if entry.builtin:
            raise
        src = source_of(entry.value.partition(":")[0].strip())
        raise PluginError(f"{label}: importing it {describe(exc, src)}", name) from exc


def build_model(scene: Any, name: str, **options: Any) -> Any:
    """The averaged model ``name`` for ``scene``: its factory called as
    ``factory(scene, **options)``. A factory that cannot be loaded raises UnknownName naming
    the entry point. A plugin's model (another distribution's) comes guarded
    (vifpk.core.guard): what its factory or methods raise or return out of protocol is a
    PluginError naming the plugin and its file."""
    from .guard import PluginError, describe, guard, plugin_stdout, source_of
    from .result import BadInput

    entry = model_entry(name)
    factory = _load(entry)
    if entry.builtin:
        return factory(scene, **options)
    label = _plugin_label(entry)
    try:
        with plugin_stdout():
            model = factory(scene, **options)
    except (KeyboardInterrupt, GeneratorExit, BadInput):
        raise
    except BaseException as exc:  # noqa: BLE001 - the plugin's own failure, named
        src = source_of(entry.value.partition(":")[0].strip())
        raise PluginError(f"{label}: its factory {describe(exc, src)}", name) from exc
    return guard(model, label, source_of(entry.value.partition(":")[0].strip()), name)


def applicability_of(factory: Any) -> Callable[[Any], str | None] | None:
    """The ``applies(scene)`` a factory offers (vifpk.core.protocols): its own, or that of the
    class whose bound ``from_scene`` it is; None when it offers none (it applies everywhere)."""
    for owner in (factory, getattr(factory, "__self__", None)):
        fn = getattr(owner, "applies", None)
        if callable(fn):
            return fn
    return None


def model_applies(name: str, scene: Any) -> str | None:
    """None when the registered model ``name`` applies to ``scene``, else its one-line reason
    (the model's own ``applies``; vifpk.core.protocols). A plugin's ``applies`` that raises
    is a PluginError naming it."""
    from .guard import PluginError, describe, plugin_stdout, source_of

    entry = model_entry(name)
    try:
        factory = _load(entry)
    except UnknownName:
        return None  # build_model names the broken entry point when the model is built
    fn = applicability_of(factory)
    if fn is None:
        return None
    if entry.builtin:
        return fn(scene)
    try:
        with plugin_stdout():
            why = fn(scene)
    except (KeyboardInterrupt, GeneratorExit):
        raise
    except BaseException as exc:  # noqa: BLE001 - the plugin's own failure, named
        src = source_of(entry.value.partition(":")[0].strip())
        raise PluginError(f"{_plugin_label(entry)}: applies(scene) "
                          f"{describe(exc, src)}", entry.name) from exc
    if why is not None and not isinstance(why, str):
        raise PluginError(f"{_plugin_label(entry)}: applies(scene) returned "
                          f"{type(why).__name__}; it must return None or one line (str)",
                          entry.name)
    return why


def applicable(scene: Any, names: tuple[str, ...]) -> tuple[tuple[str, ...], dict[str, str]]:
    """(the models of ``names`` that apply to ``scene``, in order and once each; why each other
    one does not) -- every workflow's one rule (model_applies)."""
    kept: list[str] = []
    refused: dict[str, str] = {}
    for name in dict.fromkeys(names):
        why = model_applies(name, scene)
        if why is None:
            kept.append(name)
        else:
            refused[name] = why
    return tuple(kept), refused


def refresh() -> None:
    """Forget the registry read so far (after installing a plugin in a running process)."""
    _entries.cache_clear()
    _solver_entries.cache_clear()
    solver.cache_clear()
    _workflow_load.cache_clear()
