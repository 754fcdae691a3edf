"""vifpk: how wrong is a stochastic-averaging approximation?

The public Python API (docs/api.md). Names are imported on first use (PEP 562 module
``__getattr__``), so ``import vifpk`` and ``import vifpk.core`` stay light: neither imports a
solver nor the harness until a name that needs one is asked for.
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
    # workflows
    "solve": ("vifpk.api", "solve"),
    "check": ("vifpk.api", "check"),
    "sweep": ("vifpk.api", "sweep"),
    "passage": ("vifpk.api", "passage"),
    "transient": ("vifpk.api", "transient"),
    # results
    "Result": ("vifpk.core.result", "Result"),
    "Status": ("vifpk.core.result", "Status"),
    # the model registry
    "model_names": ("vifpk.core.registry", "model_names"),
    "models": ("vifpk.core.registry", "models"),
    "build_model": ("vifpk.core.registry", "build_model"),
    # tolerance tests (numpy.testing style)
    "assert_density_close": ("vifpk.harness.testing", "assert_density_close"),
    "assert_averaging_error": ("vifpk.harness.testing", "assert_averaging_error"),
    "assert_mfpt_close": ("vifpk.harness.testing", "assert_mfpt_close"),
    "assert_relaxation_close": ("vifpk.harness.testing", "assert_relaxation_close"),
}

__all__ = sorted(_API)


def __getattr__(name: str) -> Any:
    try:
        module, attr = _API[name]
    except KeyError:
        raise AttributeError(f"module 'vifpk' has no attribute {name!r}") from None
    value = getattr(import_module(module), attr)
    globals()[name] = value  # cache: the next access is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
