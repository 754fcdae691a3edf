"""The one jit helper of vifpk: numba.njit with on-disk caching.

``cache=True`` works only for top-level functions of importable modules, so every kernel is a
module-level function. Effects a scene switches off are passed as ``None``: numba compiles a
separate specialisation per argument type and prunes ``if arg is None`` branches at compile
time, so a kernel for mu = 0 contains no friction code (checked in tests/test_montecarlo.py).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

import numba

F = TypeVar("F", bound=Callable[..., Any])


def jit(fn: F | None = None, *, parallel: bool = False, inline: str = "never") -> Any:
    """``numba.njit(cache=True, ...)``; usable bare or with arguments. ``error_model="numpy"``
    (no division checks); ``inline="always"`` inlines at numba-IR level (tiny helpers)."""
    deco = numba.njit(cache=True, parallel=parallel, error_model="numpy", inline=inline)
    if fn is None:
        return deco
    return deco(fn)
