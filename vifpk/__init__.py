"""vifpk: how wrong is a stochastic-averaging approximation?

The public Python API (docs/api.md). Names are imported on first use (PEP 562 module
``__getattr__``), so ``import vifpk`` and ``import vifpk.core`` stay light: neither imports a
solver nor the harness until a name that needs one is asked for.

The workflows' functions are not listed here: they come from the workflow registry
(``vifpk.workflows`` entry points, vifpk.core.registry.workflows), as the command line's
subcommands do. A registered workflow with an ``api`` is ``vifpk.<its name>`` (``vifpk.solve``,
``vifpk.check``, ...) and ``vifpk.run(name, ...)``; one with an ``assertion`` (its tolerance
test) is ``vifpk.<the assertion's name>`` (``vifpk.assert_averaging_error``, ...).
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

# public name -> (module, attribute); docs/api.md documents each
_API: dict[str, tuple[str, str]] = {
    # scenes
    "Scene": ("vifpk.core.scene", "Scene"),
    "SceneError": ("vifpk.core.scene", "SceneError"),
    "load_scene": ("vifpk.core.scene", "load_scene"),
    "scene_from_dict": ("vifpk.core.scene", "scene_from_dict"),
    "scene": ("vifpk.api", "scene"),
    # any registered workflow by name (the workflows' own functions: _registered)
    "run": ("vifpk.api", "run"),
    # results
    "Result": ("vifpk.core.result", "Result"),
    "Status": ("vifpk.core.result", "Status"),
    # the model registry
    "model_names": ("vifpk.core.registry", "model_names"),
    "models": ("vifpk.core.registry", "models"),
    "build_model": ("vifpk.core.registry", "build_model"),
    # tolerance tests (numpy.testing style); the workflows' own come from the registry
    "assert_density_close": ("vifpk.harness.testing", "assert_density_close"),
}


def _registered() -> dict[str, Any]:
    """The registered workflows' functions by public name: each workflow's ``api`` under its
    name, its ``assertion`` under the assertion's own name (vifpk.core.protocols.Workflow), in
    registry order (vifpk's own first): a name already taken keeps its first meaning, and the
    fixed names above (``scene``, ``run``, ...) come before any workflow's."""
    from vifpk.core.protocols import resolved
    from vifpk.core.registry import workflows

    out: dict[str, Any] = {}
    for w in workflows():
        api, assertion = (resolved(getattr(w, k, None)) for k in ("api", "assertion"))
        if api is not None:
            out.setdefault(w.name, api)
        name = getattr(assertion, "__name__", None)  # a partial has none: not exposed
        if isinstance(name, str) and name.isidentifier() and not name.startswith("_"):
            out.setdefault(name, assertion)
    return out


def __getattr__(name: str) -> Any:
    if name == "__all__":  # every public name, the registry's included (loads the registry)
        return sorted({*_API, *_registered()})
    if name in _API:
        module, attr = _API[name]
        value = getattr(import_module(module), attr)
    elif not name.startswith("_") and name in (found := _registered()):
        value = found[name]
    else:
        raise AttributeError(f"module 'vifpk' has no attribute {name!r}")
    globals()[name] = value  # cache: the next access is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__getattr__("__all__")})
