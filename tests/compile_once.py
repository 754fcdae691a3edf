"""Each numba specialisation compiled once per test session, not once per xdist worker.

With ``-n 2`` both workers often need the same kernel specialisation at about the same time in
a fresh clone (numba's on-disk cache is empty): both compiled it, and the second copy was
written over the first. :func:`install` (called by tests/conftest.py in an xdist worker) wraps
``numba``'s ``Dispatcher.compile`` in an exclusive file lock named after the function, so a
worker that needs a function the other is compiling waits, then finds it in the on-disk cache
(``cache=True``: the wrapped call looks there first) instead of compiling it again. Locks are
taken caller before callee (numba compiles a callee while typing its caller) and our call graph
has no cycles, so two workers cannot wait on each other; a function already locked by this
process (a nested compile of itself) is not locked again. ``VIFPK_COMPILE_LOG=FILE`` appends a
line per compile (worker, function, seconds, and whether the cache answered) to FILE.
"""

from __future__ import annotations

import fcntl
import os
import re
import tempfile
import threading
import time
from pathlib import Path

_held: set[str] = set()
_guard = threading.Lock()


def install(run_id: str) -> None:
    """Wrap Dispatcher.compile for this process; locks live in a folder named by ``run_id``."""
    from numba.core.dispatcher import Dispatcher

    if getattr(Dispatcher.compile, "_compile_once", False):
        return
    folder = Path(tempfile.gettempdir()) / f"vifpk-compile-{run_id}"
    folder.mkdir(exist_ok=True)
    original = Dispatcher.compile
    log = os.environ.get("VIFPK_COMPILE_LOG")
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")

    def compile(self, sig):  # noqa: ANN001, ANN202 - numba's own signature
        func = getattr(self, "py_func", None)
        name = (f"{getattr(func, '__module__', '?')}.{getattr(func, '__qualname__', '?')}"
                if func is not None else repr(self))
        with _guard:
            mine = name not in _held
            if mine:
                _held.add(name)
        if not mine:
            return original(self, sig)
        path = folder / (re.sub(r"[^A-Za-z0-9_.-]", "_", name)[:200] + ".lock")
        t0 = time.perf_counter()
        misses = sum(self._cache_misses.values())
        try:
            with open(path, "a") as fh:
                fcntl.flock(fh, fcntl.LOCK_EX)
                waited = time.perf_counter() - t0
                try:
                    return original(self, sig)
                finally:
                    fcntl.flock(fh, fcntl.LOCK_UN)
                    if log:
                        compiled = sum(self._cache_misses.values()) > misses
                        with open(log, "a") as out:
                            out.write(f"{worker} {name} waited={waited:.2f} "
                                      f"total={time.perf_counter() - t0:.2f} "
                                      f"{'compiled' if compiled else 'cache'}\n")
        finally:
            with _guard:
                _held.discard(name)

    compile._compile_once = True  # type: ignore[attr-defined]
    Dispatcher.compile = compile
