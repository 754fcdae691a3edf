"""The scene's range checks: each returns None when a value is fine, else the allowed range in
words (vifpk.core.scene turns that into the one-line SceneError); and SceneError itself."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from .result import BadInput
from .walls import Wall


class SceneError(BadInput):
    """A scene that cannot be used; the message is one line naming the field."""


Check = Callable[[Any], "str | None"]


def _finite(v: float) -> str | None:
    return None if math.isfinite(v) else "a finite number"


def _positive(v: float) -> str | None:
    return None if math.isfinite(v) and v > 0 else "a finite number > 0"


def _nonneg(v: float) -> str | None:
    return None if math.isfinite(v) and v >= 0 else "a finite number >= 0"


def _tail(v: float) -> str | None:
    """The probability mass the amplitude grid may leave beyond A_max: a small tolerance (a
    tail of 0.5 would cut half the density off the grid)."""
    return None if math.isfinite(v) and 0.0 < v <= 1e-3 else "0 < tail <= 0.001"


def _floor(v: float) -> str | None:
    """A target L1 noise floor: an L1 distance between densities is at most 2."""
    return None if math.isfinite(v) and 0.0 <= v < 2.0 else "0 <= floor < 2 (0: none)"


def _wall(v: Any) -> str | None:
    return None if v is None or isinstance(v, Wall) else "a table (vifpk.core.walls)"


def _restitution(v: float) -> str | None:
    return None if math.isfinite(v) and 0 < v <= 1 else "0 < r <= 1"


def _int_at_least(lo: int) -> Check:
    def check(v: Any) -> str | None:
        ok = isinstance(v, int) and not isinstance(v, bool) and v >= lo
        return None if ok else f"a whole number >= {lo}"

    return check


def _int_between(lo: int, hi: int) -> Check:
    def check(v: Any) -> str | None:
        ok = isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi
        return None if ok else f"a whole number from {lo} to {hi}"

    return check


def _one_of(*allowed: str) -> Check:
    def check(v: Any) -> str | None:
        return None if v in allowed else "one of " + ", ".join(repr(a) for a in allowed)

    return check


def _bool(v: Any) -> str | None:
    return None if isinstance(v, bool) else "true or false"


def _auto_or(check: Check) -> Check:
    def auto(v: Any) -> str | None:
        if v == "auto":
            return None
        if isinstance(v, bool) or not isinstance(v, int | float):
            return '"auto" or ' + (check(float("nan")) or "a number")
        problem = check(float(v))
        return None if problem is None else f'"auto" or {problem}'

    return auto


def _meta(check: Check, doc: str) -> dict[str, Any]:
    return {"check": check, "doc": doc}


# --------------------------------------------------------------------------------------------
MAX_TERMS = 10  # polynomial laws: up to 10 coefficients (a restoring force of degree 19)


def _coefficients(allow_empty: bool) -> Check:
    def check(v: Any) -> str | None:
        ok = (isinstance(v, tuple) and (allow_empty or len(v) >= 1) and len(v) <= MAX_TERMS
              and all(isinstance(c, float) and math.isfinite(c) for c in v))
        lo = 0 if allow_empty else 1
        return None if ok else f"a list of {lo} to {MAX_TERMS} finite numbers"

    return check
