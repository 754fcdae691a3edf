"""The jit helpers of vifpk: numba.njit with on-disk caching, and the blocks of a run spread
over threads.

``cache=True`` works only for top-level functions of importable modules, so every kernel is a
module-level function. Effects a scene switches off are passed as ``None``: numba compiles a
separate specialisation per argument type and prunes ``if arg is None`` branches at compile
time, so a kernel for mu = 0 contains no friction code (checked in tests/test_montecarlo.py).

numba's on-disk cache judges a kernel fresh by its own file's stamp only, while a kernel inlines
code of other modules (the pieces, the physics layer's laws and noise kinds, a plugin's kind):
an edit there left the cached, OLD kernel running. Every vifpk kernel's cache is therefore
stamped also with ``sources_stamp()``, a hash of the code it may inline (``_stamped``).

A cache HIT of a vifpk kernel loads its object code without numba's registry refresh
(``_light``): the refresh imports all of numba's lowering registries and, through them,
scipy.linalg, which a warm run paid before its first kernel (0.73-0.79 s CPU; 0.06 s without).
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from importlib import metadata
from pathlib import Path
from typing import Any, TypeVar

import numba
import numpy as np

F = TypeVar("F", bound=Callable[..., Any])

#: the entry-point groups whose objects' compiled pieces a kernel inlines (vifpk.core.registry's
#: NOISE_GROUP and LAW_GROUP, read by name: this module loads nothing of the registry)
_PLUGIN_GROUPS = ("vifpk.noise_kinds", "vifpk.impact_laws")
_STAMP: list[str] = []


def _kernel_sources() -> list[Path]:
    """The files a kernel's compiled code may come from: every module of this package (the
    kernels, the pieces), of vifpk.physics (spring, laws, noise kinds) and each registered noise
    kind's or impact law's module (a plugin's compiled pieces)."""
    here = Path(__file__).resolve().parent
    spec = importlib.util.find_spec("vifpk.physics")
    roots = [here] + ([Path(spec.origin).parent] if spec and spec.origin else [])
    files = {f for root in roots for f in root.rglob("*.py")}
    installed = metadata.entry_points()  # one scan of the metadata for both groups
    for group in _PLUGIN_GROUPS:
        for ep in installed.select(group=group):
            try:
                origin = importlib.util.find_spec(ep.module).origin
            except (ImportError, ValueError, AttributeError):
                continue  # a plugin that cannot be found is named by the registry
            if origin and origin.endswith(".py"):
                files.add(Path(origin).resolve())
    return sorted(files)


def sources_stamp() -> str:
    """sha1 of the contents of ``_kernel_sources()`` (computed once a process): a kernel's
    cache entry is fresh only for the code it was compiled from."""
    if not _STAMP:
        h = hashlib.sha1()
        for f in _kernel_sources():
            h.update(f.name.encode())
            h.update(f.read_bytes())
        _STAMP.append(h.hexdigest())
    return _STAMP[0]


def _stamped(base: type) -> type:
    """numba's cache locator ``base`` for vifpk's own kernels, its source stamp extended by
    ``sources_stamp()`` (a stale entry is simply recompiled and overwritten); other functions
    are left to numba's own locators (``from_function`` returns None)."""

    class Stamped(base):  # type: ignore[misc, valid-type]
        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            if not str(getattr(py_func, "__module__", "")).startswith("vifpk."):
                return None
            return super().from_function(py_func, py_file)

        def get_source_stamp(self) -> Any:
            return (super().get_source_stamp(), sources_stamp())

    Stamped.__name__ = Stamped.__qualname__ = f"Stamped{base.__name__}"
    return Stamped


def _install_stamped_locators() -> None:
    from numba.core.caching import CacheImpl

    classes = CacheImpl._locator_classes
    if not any(c.__name__.startswith("Stamped") for c in classes):
        classes[:0] = [_stamped(c) for c in list(classes)]


_install_stamped_locators()


def _light_cache(dispatcher: Any) -> Any:
    """``dispatcher`` with its on-disk cache loaded without numba's registry refresh: its
    FunctionCache's class is swapped for ``_light()``'s subclass (any other cache is left)."""
    from numba.core.caching import FunctionCache

    cache = getattr(dispatcher, "_cache", None)
    if type(cache) is FunctionCache and hasattr(cache, "_load_overload"):
        cache.__class__ = _light()
    return dispatcher


#: the symbols a cached entry may need that numba registers only while refreshing (its string
#: hash's secrets, numba.cpython.hashing, one of the registries the refresh imports); numba
#: registers every other external symbol when its context is made (C helpers, libm), with its
#: runtime (``rtsys.initialize``) or by the entry's own ``reload_init`` (the parallel layer)
_REFRESH_SYMBOLS = (b"_numba_hashsecret_",)
_LIGHT: list[type] = []


def _light() -> type:
    """numba's FunctionCache whose cache HIT skips ``target_context.refresh()`` (made once).

    The refresh imports every lowering registry of numba (numba.np.arraymath's BLAS check
    imports all of scipy.linalg), 0.6-0.8 s CPU before a warm run's first kernel loads, while
    a cached entry is object code that needs numba's runtime (NRT) and the symbols numba
    registered when its context was made. An entry whose code names a symbol of
    ``_REFRESH_SYMBOLS`` (or whose form is not the one expected) is loaded after the full
    refresh, as numba does; a miss compiles through numba's compiler, which refreshes both
    contexts itself."""
    if _LIGHT:
        return _LIGHT[0]
    from numba.core.caching import FunctionCache
    from numba.core.runtime import rtsys

    class Light(FunctionCache):
        def load_overload(self, sig: Any, target_context: Any) -> Any:
            try:
                rtsys.initialize(target_context)
                with self._guard_against_spurious_io_errors():
                    return self._load_light(sig, target_context)
            except AttributeError:
                # a numba whose private cache API differs from the one read here (numba
                # >= 0.59 is allowed): numba's own load, with its full refresh
                return super().load_overload(sig, target_context)

        def _load_light(self, sig: Any, target_context: Any) -> Any:
            if not self._enabled:
                return None
            data = self._cache_file.load(self._index_key(sig, target_context.codegen()))
            if data is None:
                return None
            if not _self_contained(data):
                target_context.refresh()
            return self._impl.rebuild(target_context, data)

    _LIGHT.append(Light)
    return Light


def _self_contained(data: Any) -> bool:
    """A cached CompileResult (numba's ``CompileResult._reduce``: its library first, as
    (name, "object", (object code, bitcode))) whose object code names no ``_REFRESH_SYMBOLS``."""
    try:
        code = data[0][2][0]
    except (IndexError, KeyError, TypeError):
        return False
    return isinstance(code, bytes) and not any(s in code for s in _REFRESH_SYMBOLS)


def jit(fn: F | None = None, *, parallel: bool = False, inline: str = "never",
        nogil: bool = False) -> Any:
    """``numba.njit(cache=True, ...)``; usable bare or with arguments. ``error_model="numpy"``
    (no division checks); ``inline="always"`` inlines at numba-IR level (tiny helpers);
    ``nogil`` releases the GIL (a block kernel that :func:`over_blocks` runs on threads)."""
    deco = numba.njit(cache=True, parallel=parallel, error_model="numpy", inline=inline,
                      nogil=nogil)
    if fn is None:
        return lambda f: _light_cache(deco(f))
    return _light_cache(deco(fn))


def over_blocks(kernel: Callable[..., Any], n_blocks: int, *args: Any) -> None:
    """``kernel(first, every, *args)`` on ``n = min(numba.get_num_threads(), n_blocks)``
    threads, first = 0 .. n - 1 and every = n: thread t runs blocks t, t + n, ..., each block
    whole on one thread. ``kernel`` is a ``jit(nogil=True)`` function that writes only its
    blocks' rows, so the result is the same for any thread count. Plain threads instead of a
    ``prange`` wrapper: the wrapper's parallel compile cost ~3.6 s of the ~12 s each new
    kernel specialisation took (docs/performance.md). One call costs n kernel dispatches and,
    with n > 1, one hand-over to a pool kept for this process (the blocks run in the caller's
    thread when n = 1)."""
    n = min(numba.get_num_threads(), n_blocks)
    if n <= 1:
        kernel(np.int64(0), np.int64(1), *args)
        return
    pool = _pool(n)
    futures = [pool.submit(kernel, np.int64(t), np.int64(n), *args) for t in range(n)]
    try:
        for f in futures:
            f.result()
    except BaseException:  # Ctrl-C while waiting: start no further call
        for f in futures:
            f.cancel()
        raise


_POOLS: dict[tuple[int, int], ThreadPoolExecutor] = {}


def _pool(n: int) -> ThreadPoolExecutor:
    """The process's pool of n threads (made once; keyed by pid too: a forked child, e.g. a
    sweep's process-pool worker, inherits the parent's pool object but not its threads)."""
    key = (os.getpid(), n)
    pool = _POOLS.get(key)
    if pool is None:
        pool = _POOLS[key] = ThreadPoolExecutor(n, thread_name_prefix="vifpk-blocks")
    return pool
