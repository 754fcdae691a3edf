"""The console script's first lines: Ctrl-C and SIGTERM are answered before the heavy imports.

``vifpk`` imports numpy, scipy, numba and every registered workflow before its own handlers
are in place (``outputs/signals.py``, installed by ``app.main``); a Ctrl-C in that first second
or two used to end in a KeyboardInterrupt traceback, and a SIGTERM in no message at all
(issue 39, X11). Nothing has been written before ``app.main`` runs a command, so an interruption
here says so in one line and exits 130 (SIGINT) or 143 (SIGTERM), as the commands do.
"""

from __future__ import annotations

import os
import signal
import sys

NOTHING = "vifpk: interrupted; nothing was written\n"


class _EarlyTerm(BaseException):
    """SIGTERM before the command's own handlers: unwinds the imports like Ctrl-C."""


def _term(signum: int, frame: object) -> None:
    raise _EarlyTerm


def main() -> int:
    """``vifpk``: app.main behind an interruption guard for its imports and its parser."""
    signal.signal(signal.SIGTERM, _term)  # app.main replaces it with the command's own
    try:
        from vifpk.harness.cli import app

        return app.main()
    except KeyboardInterrupt:  # Ctrl-C before app.main's own try (imports, the parser)
        os.write(2, NOTHING.encode())
        return 130
    except _EarlyTerm:
        os.write(2, NOTHING.encode())
        return 143


if __name__ == "__main__":  # pragma: no cover - the console script calls main()
    sys.exit(main())
