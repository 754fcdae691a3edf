"""The jit helpers of vifpk: numba.njit with on-disk caching, and the blocks of a run spread
over threads.

``cache=True`` works only for top-level functions of importable modules, so every kernel is a
module-level function. Effects a scene switches off are passed as ``None``: numba compiles a
separate specialisation per argument type and prunes ``if arg is None`` branches at compile
time, so a kernel for mu = 0 contains no friction code (checked in tests/test_montecarlo.py).
"""

from __future__ import annotations

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
    """``kernel(b, *args)`` for every block b (an int64) on ``numba.get_num_threads()``
    threads, each block whole on one thread. ``kernel`` is a ``jit(nogil=True)`` function
    that writes only its own block's rows, so the result is the same for any thread count
    and any order. Plain threads instead of a ``prange`` wrapper: the wrapper's parallel
    compile cost ~3.6 s of the ~12 s each new kernel specialisation took (docs/performance.md);
    the blocks' work is the same either way."""
    n = min(numba.get_num_threads(), n_blocks)
    if n <= 1:
        for b in range(n_blocks):
            kernel(np.int64(b), *args)
        return
    with ThreadPoolExecutor(n, thread_name_prefix="vifpk-block") as pool:
        futures = [pool.submit(kernel, np.int64(b), *args) for b in range(n_blocks)]
        try:
            for f in futures:
                f.result()
        except BaseException:  # Ctrl-C while waiting: start no further block
            for f in futures:
                f.cancel()
            raise
