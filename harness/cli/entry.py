"""The console script's first lines: Ctrl-C and SIGTERM are answered before the heavy imports.

``vifpk`` imports numpy, scipy, numba and every registered workflow before its own handlers
are in place (``outputs/signals.py``, installed by ``app.main``); a Ctrl-C in that first second
or two used to end in a KeyboardInterrupt traceback, and a SIGTERM in no message at all
(issue 39, X11). Nothing has been written before ``app.main`` runs a command, so a signal
here prints one line and ends the process at once (``os._exit``: 130 for SIGINT, 143 for
SIGTERM, as the commands do). The handler must not raise: an exception raised while a C
extension is being imported (numpy's ``_multiarray_umath`` importing ``datetime``) is turned
into an ImportError by that extension and ends in a traceback, exit 1 (seen in CI, 2026-11-28).
``app.main`` calls :func:`release` (passed to it) just before it installs the command's own
handlers.
"""

from __future__ import annotations

import gc
import os
import signal
import sys
from typing import Any

NOTHING = "vifpk: interrupted; nothing was written\n"

_saved: dict[int, Any] = {}


def _early(signum: int, frame: object) -> None:
    os.write(2, NOTHING.encode())
    os._exit(128 + signum)


def guard() -> None:
    """Early handlers for SIGTERM and (unless it is ignored, as in a background job) SIGINT."""
    for signum in (signal.SIGINT, signal.SIGTERM):
        before = signal.getsignal(signum)
        if signum == signal.SIGINT and before is not signal.default_int_handler:
            continue  # SIG_IGN inherited: keep it (signals.install does the same)
        _saved[signum] = before
        signal.signal(signum, _early)


def release() -> None:
    """Back to the handlers the process had before :func:`guard` (no-op in-process)."""
    while _saved:
        signum, before = _saved.popitem()
        signal.signal(signum, before)


def main() -> int:
    """``vifpk``: app.main behind an interruption guard for its imports and its parser.

    The command done (its outputs written and closed), the objects it leaves are frozen
    (``gc.freeze``), so the interpreter's exit does not walk them for cycles: numba's and
    numpy's hundreds of thousands of objects took 0.2-0.4 s CPU to finalise after a warm
    ``vifpk solve`` (the process's CPU after main returned; 0.02 s frozen: issue 44,
    docs/performance.md). atexit handlers run as before; what is not collected is garbage
    in cycles, which the process's end returns to the system anyway."""
    guard()
    try:
        from vifpk.harness.cli import app

        return app.main(release_guard=release)
    finally:
        release()
        gc.freeze()


if __name__ == "__main__":  # pragma: no cover - the console script calls main()
    sys.exit(main())
