"""A run's memo of the exact model's orbit averages and external-noise sigma_E^2, by amplitude
grid (issue 44, the main job).

A check asks the same coefficients many times: the closed form's reach scan three times, the
FPK's drift and diffusion on the same cell faces, the averaged SDE's relaxation grid and table
with drift and diffusion each, and the ``exact``, ``compounded`` and ``corrected`` models on
the same grids, whose orbits and sigma_E^2 are the same functions (they differ in the impact
loss only). Inside :func:`shared` (the check enters it through the door,
harness/door/solvers.py ``shared_coefficients``) each distinct (model parameters, grid) is
computed once and handed out again: the very arrays, so every result is bit for bit what it is
without the memo (tests/test_coefficient_memo.py). Outside it nothing is kept.

The memo is a ``contextvars.ContextVar``: a thread started inside the scope does not see it
(it computes, as without one), and two runs in two threads keep apart, unless the work handed
to the thread is wrapped by :func:`carry` (the check solves the models beside its Monte Carlo:
both threads then share the one memo; two threads asking the same entry at once may both
compute it, the same bits). It holds at most MAX_ENTRIES results (the oldest dropped first);
arrays handed out are read-only.
"""

from __future__ import annotations

import hashlib
import threading
from collections.abc import Callable, Hashable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Any

import numpy as np

#: results kept in one scope (a paper-base check makes ~60 distinct ones, ~30 MB)
MAX_ENTRIES = 256

_MEMO: ContextVar[dict[Hashable, Any] | None] = ContextVar("vifpk_averaging_memo",
                                                           default=None)
_MISSING = object()
_LOCK = threading.Lock()  # the memo's dict between threads that share it (carry)


@contextmanager
def shared() -> Iterator[None]:
    """Within this block, the exact model's orbit averages and sigma_E^2 are computed once per
    (model parameters, amplitude grid). Nested blocks share the outermost one's memo."""
    if _MEMO.get() is not None:
        yield
        return
    token = _MEMO.set({})
    try:
        yield
    finally:
        _MEMO.reset(token)


def carry(fn: Callable[..., Any]) -> Callable[..., Any]:
    """``fn`` to be called in another thread, inside the memo in force here (if any): the
    thread shares this scope's memo instead of computing everything again."""
    memo = _MEMO.get()

    def carried(*args: Any, **kwargs: Any) -> Any:
        token = _MEMO.set(memo)
        try:
            return fn(*args, **kwargs)
        finally:
            _MEMO.reset(token)

    return carried


def active() -> bool:
    """Whether a memo is in force here."""
    return _MEMO.get() is not None


def _frozen(value: Any) -> Any:
    """``value`` with its arrays read-only (dicts and lists copied, so a caller's new key or
    item never reaches the memo)."""
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
        return value
    if isinstance(value, dict):
        return {k: _frozen(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_frozen(v) for v in value]
    return value


def _copy(value: Any) -> Any:
    """A memo entry as handed out: its dicts and lists new, its arrays the same."""
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_copy(v) for v in value]
    return value


def recall(what: str, params: Hashable, A: np.ndarray, compute: Callable[[], Any]) -> Any:
    """``compute()``, or its result for the same ``what``, ``params`` and amplitudes ``A``
    (shape, dtype and every bit; keyed by a blake2b digest of the bytes) when a memo is in
    force (:func:`shared`) and holds it."""
    memo = _MEMO.get()
    if memo is None:
        return compute()
    A = np.ascontiguousarray(A)
    key = (what, params, A.shape, A.dtype.str,
           hashlib.blake2b(A.tobytes(), digest_size=20).digest())
    with _LOCK:
        held = memo.get(key, _MISSING)
    if held is _MISSING:
        held = _frozen(compute())
        with _LOCK:
            if len(memo) >= MAX_ENTRIES:
                del memo[next(iter(memo))]
            memo[key] = held
    return _copy(held)
