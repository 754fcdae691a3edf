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
