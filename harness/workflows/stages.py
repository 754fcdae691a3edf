"""A workflow's stages: their progress lines and seconds, and work run beside them.

:class:`Stages` prints one line a stage on the terminal (``[i/n] name ... 1.2 s``) and keeps
each stage's wall seconds (metrics.json ``timings.stages``). :class:`Beside` runs a function
in a thread beside the caller's own stages (issue 44, the main job): the Monte Carlo's numba
kernels release the GIL, so on two cores the averaged models' closed forms and FPKs (numpy and
Python) run while the original system is simulated. Stages run beside others are reported
with :meth:`Stages.beside`: their lines are printed by the caller's thread at its next line
(a Monte Carlo's progress bar is never cut by another thread's line), and their seconds
overlap the others' (the stages' seconds then add up to more than the wall time).
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from typing import Any


class Stages:
    """Progress on the terminal: one line a stage, with its time."""

    def __init__(self, total: int, quiet: bool):
        self.total, self.quiet, self.i = total, quiet, 0
        self.t = self.start = time.perf_counter()
        self.name = ""
        self.label = ""
        self.seconds: dict[str, float] = {}  # stage -> wall seconds (metrics.json "timings")
        self._beside: list[tuple[str, float]] = []
        self._lock = threading.Lock()

    def _end(self, now: float) -> None:
        """The stage's time; on a terminal the label is written again from the line's start
        ("\\r"), since a progress bar drawn on the same line (the Monte Carlo's) erases it
        when it closes."""
        again = f"\r{self.label}" if sys.stderr.isatty() else ""
        print(f"{again} {now - self.t:.1f} s", file=sys.stderr, flush=True)

    def flush(self) -> None:
        """The lines of the stages that ended beside this thread's, in the order they ended."""
        with self._lock:
            done, self._beside = self._beside, []
        for name, seconds in done:
            self.i += 1
            if not self.quiet:
                print(f"[{self.i}/{self.total}] {name} ... {seconds:.1f} s (beside the others)",
                      file=sys.stderr, flush=True)

    def __call__(self, name: str) -> None:
        now = time.perf_counter()
        if self.name:
            self.seconds[self.name] = self.seconds.get(self.name, 0.0) + now - self.t
            if not self.quiet:
                self._end(now)
        self.flush()
        self.i += 1
        self.t, self.name = now, name
        self.label = f"[{self.i}/{self.total}] {name} ..."
        if not self.quiet:
            print(self.label, end="", file=sys.stderr, flush=True)

    def beside(self, name: str, seconds: float) -> None:
        """A stage that took ``seconds`` in another thread (any thread may call this)."""
        with self._lock:
            self.seconds[name] = self.seconds.get(name, 0.0) + seconds
            self._beside.append((name, seconds))

    def done(self) -> None:
        now = time.perf_counter()
        if self.name:
            self.seconds[self.name] = self.seconds.get(self.name, 0.0) + now - self.t
            if not self.quiet:
                self._end(now)
            self.name = ""
        self.flush()


class Beside:
    """``fn(*args)`` in a daemon thread (hand it ``harness.door.coefficients.carried(fn)`` for
    it to share the run's coefficients). :meth:`result` waits for it and returns its value or
    raises what it raised. A daemon: a run stopped by Ctrl-C in the caller's thread does not
    wait for it at exit: the check hands it the closed forms and the FPK solves (bounded work)
    and the averaged SDEs' lanes (simulations; after Ctrl-C in API use the lane running then
    ends in the background)."""

    def __init__(self, fn: Callable[..., Any], *args: Any, name: str = "vifpk-beside"):
        self._value: Any = None
        self._error: BaseException | None = None
        self._done = threading.Event()

        def target() -> None:
            try:
                self._value = fn(*args)
            except BaseException as exc:  # noqa: BLE001 - handed to the caller by result()
                self._error = exc
            finally:
                self._done.set()

        self._thread = threading.Thread(target=target, name=name, daemon=True)
        self._thread.start()

    def wait(self) -> None:
        self._done.wait()

    def failed(self) -> BaseException | None:
        """What it raised, once it has ended (None: nothing, or still running)."""
        return self._error if self._done.is_set() else None

    def result(self) -> Any:
        self._done.wait()
        if self._error is not None:
            raise self._error
        return self._value
