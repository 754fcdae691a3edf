"""The RuntimeWarnings of a run, counted (issue 38: the command line caught every one and
dropped them when the run ended finite, so an overflow that produced the numbers was never
seen).

The command line records a run's warnings into one :class:`RunWarnings` it hands the command
(``args.run_warnings``); a command that writes metrics.json stores :meth:`RunWarnings.records`
under ``runtime_warnings``: one entry per distinct (category, message, where), sorted by
where, category and message (not by when it was first seen: the check's parts run side by side,
so that order could change from run to run; issue 44), with how many times it was raised::

    "runtime_warnings": [{"category": "RuntimeWarning",
                          "message": "overflow encountered in exp",
                          "where": "averaging/paper.py:165", "count": 3}]

The key is absent when the warnings were not recorded (a report written from the Python API),
and an empty list when they were and there was none. Warnings of other categories keep the
filters they had (and stay out of the count).
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

KEY = "runtime_warnings"


class RunWarnings:
    """The warnings recorded while :meth:`recording` is active (a tracker passed explicitly,
    not global state: the command line makes one a run)."""

    def __init__(self) -> None:
        self.caught: list[warnings.WarningMessage] = []

    @contextmanager
    def recording(self) -> Iterator[RunWarnings]:
        """Record every warning raised inside (RuntimeWarnings every time, not once per
        place); none is printed."""
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RuntimeWarning)
            self.caught = caught
            yield self

    def runtime(self) -> list[warnings.WarningMessage]:
        return [w for w in self.caught if issubclass(w.category, RuntimeWarning)]

    def records(self) -> list[dict[str, Any]]:
        """The RuntimeWarnings so far, counted by (category, message, where), sorted by
        (file, line number, category, message): the same list whichever thread warned first."""
        out: dict[tuple[str, int, str, str], dict[str, Any]] = {}
        for w in self.runtime():
            file = "/".join(str(w.filename).split("/")[-2:])
            key = (file, int(w.lineno or 0), w.category.__name__, str(w.message))
            if key not in out:
                out[key] = {"category": key[2], "message": key[3], "where": f"{file}:{key[1]}",
                            "count": 0}
            out[key]["count"] += 1
        return [out[k] for k in sorted(out)]

    def first(self) -> str:
        """' (numpy: overflow encountered in multiply, averaging/paper.py:165)' or '': the
        first warning, for the one line of a run that failed."""
        if not self.caught:
            return ""
        w = self.caught[0]
        where = "/".join(str(w.filename).split("/")[-2:])
        return f" (numpy: {w.message}, {where}:{w.lineno})"
