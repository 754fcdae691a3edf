"""The run's own timing record, ``info["timing"]``: wall and CPU seconds of each stage.

A ``Laps`` is started when the run is; each stage ends with ``lap(name)``, which adds the wall
(time.perf_counter) and CPU (time.process_time: every thread of the process) seconds since the
previous lap to the stage's entry, so the stages add up to the whole. CPU seconds are what a
shared machine's load does not inflate; wall seconds are what the user waits for. Stages of a
stationary run (simulate.py): "plan", "kernel" (compiled, or loaded from numba's cache),
"scale_pilot", "relaxation_pilot" (burn-in "auto"), "burn_in", "sampling", "densities",
"certificate", "dt_check" (the step check's coarse run: its own record is in
info["dt_check"]["timing"]) and "result". ``vifpk solve`` adds the process's own, so every
fixed cost it pays before its output is written is one entry: "startup" (the interpreter and
the imports, before the command ran), "request" (validation and pricing: the first door call
imports the solver, numba among it), "door" (the door call around the run: its wall and CPU
less the run's own "total"), "record" (the JSON record built: provenance, arrays to lists)
and "process" (the process's clocks since it started, just before the record is written:
startup + request + door + total + record). What comes after, the write and the
interpreter's exit, is in no record (docs/performance.md measures it).
"""

from __future__ import annotations

import time
from typing import Any


def now() -> tuple[float, float]:
    """(wall, CPU) seconds on the process's clocks."""
    return time.perf_counter(), time.process_time()


class Laps:
    """Stage seconds, wall and CPU, in the order the stages ran."""

    def __init__(self) -> None:
        self.stages: dict[str, dict[str, float]] = {}
        self._last = self._start = now()

    def lap(self, name: str) -> None:
        """End stage ``name`` here (a stage run twice adds up)."""
        t = now()
        rec = self.stages.setdefault(name, {"wall": 0.0, "cpu": 0.0})
        rec["wall"] += t[0] - self._last[0]
        rec["cpu"] += t[1] - self._last[1]
        self._last = t

    def record(self) -> dict[str, Any]:
        """{"stages": {name: {"wall", "cpu"}}, "total": {"wall", "cpu"}} (JSON-ready)."""
        t = now()
        return {"stages": {k: dict(v) for k, v in self.stages.items()},
                "total": {"wall": t[0] - self._start[0], "cpu": t[1] - self._start[1]}}
