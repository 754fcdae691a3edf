"""Ctrl-C, SIGTERM and SIGHUP for every command: stop within seconds, clean up, say what was
kept.

``install()`` (the console script only, not in-process calls) makes SIGTERM and SIGHUP (a
closed terminal) raise
:class:`Terminated`, a ``KeyboardInterrupt``, so every ``except KeyboardInterrupt`` and
``finally`` runs for either signal, and starts a watchdog thread: the signal's wakeup byte
reaches it even while the main thread is inside a long numba or C call; it gives the main
thread ``GRACE`` seconds to unwind, then runs the registered cleanups (stop worker processes,
release output-folder locks), prints the current message and exits with 128 + the signal
number (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP).

What a run keeps on interruption depends on the command; the command says so by setting
:func:`set_message` (a function returning the one line): a check or solve keeps nothing, a
sweep keeps its finished points.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

GRACE = 1.5  # seconds the main thread gets to unwind before the watchdog exits

_state: dict[str, Any] = {"message": lambda: "vifpk: interrupted; nothing was written",
                          "announced": False, "signum": signal.SIGINT, "grace": GRACE}
_cleanups: dict[int, Callable[[], None]] = {}
_deferred: dict[str, Any] = {"depth": 0, "pending": None}  # see deferred()
_lock = threading.Lock()
_keep: list[Any] = []


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, handled like Ctrl-C (exit 143 or 129 instead of 130)."""


def exit_code() -> int:
    return 128 + int(_state["signum"])


def message() -> str:
    """The one line for the interruption now (the command's own, else 'nothing written')."""
    try:
        text = _state["message"]()
    except Exception:  # noqa: BLE001 - a message must never fail the exit
        text = "vifpk: interrupted"
    if _state["signum"] == signal.SIGTERM:
        text = text.replace("interrupted", "terminated (SIGTERM)", 1)
    elif _state["signum"] == getattr(signal, "SIGHUP", None):
        text = text.replace("interrupted", "hung up (SIGHUP: the terminal closed)", 1)
    return text


def set_message(fn: Callable[[], str]) -> None:
    _state["message"] = fn


def set_grace(seconds: float) -> None:
    """How long the main thread may take to unwind (e.g. closing a dask cluster)."""
    _state["grace"] = seconds


def reset() -> None:
    """Back to the default message (and no cleanups): in-process callers and tests."""
    _state.update(message=lambda: "vifpk: interrupted; nothing was written", announced=False,
                  signum=signal.SIGINT, grace=GRACE)
    _cleanups.clear()


def announce(stream: Any = None) -> None:
    """Print the message once (the main thread's path); the watchdog then stays quiet."""
    with _lock:
        if _state["announced"]:
            return
        _state["announced"] = True
    try:  # after SIGHUP the terminal may be gone: the exit code still says it
        print(fresh_line() + message(), file=stream or sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


def on_interrupt(fn: Callable[[], None]) -> int:
    """Register a cleanup the watchdog runs before a forced exit; returns its handle."""
    handle = id(fn)
    _cleanups[handle] = fn
    return handle


def forget(handle: int) -> None:
    _cleanups.pop(handle, None)


def fresh_line() -> str:
    """Start the message on its own line after a half-drawn progress bar: clear the line on
    a terminal, else begin a new one."""
    try:
        return "\r\033[K" if sys.stderr.isatty() else "\n"
    except (AttributeError, ValueError):
        return "\n"


def _term_handler(signum: int, frame: Any) -> None:
    _state["signum"] = signum
    if _deferred["depth"]:
        _deferred["pending"] = Terminated
        return
    raise Terminated


def _int_handler(signum: int, frame: Any) -> None:
    _state["signum"] = signum
    if _deferred["depth"]:
        _deferred["pending"] = KeyboardInterrupt
        return
    raise KeyboardInterrupt


@contextmanager
def deferred() -> Iterator[None]:
    """A critical section: a signal of :func:`install`'s handlers that arrives inside it is
    raised when it ends, not between two of its instructions. For the few lines whose state
    a cleanup must see whole (an output folder's lock file: opened, locked, recorded). The
    watchdog still forces the exit ``GRACE`` seconds after the signal, so a section must be
    short. Without ``install()`` (in-process callers) Python's own handler is not deferred."""
    _deferred["depth"] += 1
    try:
        yield
    finally:
        _deferred["depth"] -= 1
    pending = _deferred["pending"] if _deferred["depth"] == 0 else None
    if pending is not None:
        _deferred["pending"] = None
        raise pending


def install() -> None:
    """Handlers for SIGINT, SIGTERM, SIGHUP and the watchdog (main thread only; else
    nothing). SIGHUP keeps a handler someone set (e.g. nohup's SIG_IGN)."""
    import socket
    import time

    if threading.current_thread() is not threading.main_thread():
        return
    r, w = socket.socketpair()
    w.setblocking(False)
    try:
        signal.set_wakeup_fd(w.fileno(), warn_on_full_buffer=False)
    except ValueError:
        return
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, _int_handler)
    signal.signal(signal.SIGTERM, _term_handler)
    wanted = {signal.SIGINT, signal.SIGTERM}
    hup = getattr(signal, "SIGHUP", None)  # POSIX: a closed terminal, treated as SIGTERM
    if hup is not None and signal.getsignal(hup) is signal.SIG_DFL:
        signal.signal(hup, _term_handler)
        wanted.add(hup)

    def watch() -> None:
        while True:
            data = r.recv(16)
            got = [s for s in data if s in wanted]
            if got:
                _state["signum"] = got[0]
                time.sleep(_state["grace"])
                for fn in list(_cleanups.values()):
                    try:
                        fn()
                    except Exception:  # noqa: BLE001,S110 - exiting regardless
                        pass
                if not _state["announced"]:
                    try:
                        os.write(2, (fresh_line() + message() + "\n").encode())
                    except OSError:  # the terminal is gone (SIGHUP)
                        pass
                os._exit(exit_code())

    _keep.extend((r, w))  # open for the life of the process
    threading.Thread(target=watch, name="vifpk-interrupt", daemon=True).start()
