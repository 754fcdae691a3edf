"""Timing the way DiffEqDevTools does it: a warm-up call (compile time reported apart), then
the minimum of repeats; a failed run is recorded as NaN rather than raised."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any


def timed(fn: Callable[[], Any], *, repeats: int = 5) -> dict[str, float]:
    """{"first": seconds of the first (cold) call, "min": min of ``repeats`` warm calls}."""
    try:
        t0 = time.perf_counter()
        fn()
        first = time.perf_counter() - t0
        best = math.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn()
            best = min(best, time.perf_counter() - t0)
    except Exception:  # noqa: BLE001 - a failed run is a NaN on the diagram, not a crash
        return {"first": math.nan, "min": math.nan}
    return {"first": first, "min": best}
