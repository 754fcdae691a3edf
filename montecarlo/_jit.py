"""The jit helpers of vifpk: numba.njit with on-disk caching, and the blocks of a run spread
over threads.

``cache=True`` works only for top-level functions of importable modules, so every kernel is a
module-level function. Effects a scene switches off are passed as ``None``: numba compiles a
separate specialisation per argument type and prunes ``if arg is None`` branches at compile
time, so a kernel for mu = 0 contains no friction code (checked in tests/test_montecarlo.py).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

import numba
import numpy as np

F = TypeVar("F", bound=Callable[..., Any])


def jit(fn: F | None = None, *, parallel: bool = False, inline: str = "never",
        nogil: bool = False) -> Any:
    """``numba.njit(cache=True, ...)``; usable bare or with arguments. ``error_model="numpy"``
    (no division checks); ``inline="always"`` inlines at numba-IR level (tiny helpers);
    ``nogil`` releases the GIL (a block kernel that :func:`over_blocks` runs on threads)."""
    deco = numba.njit(cache=True, parallel=parallel, error_model="numpy", inline=inline,
                      nogil=nogil)
    if fn is None:
        return deco
    return deco(fn)


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
