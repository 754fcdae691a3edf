"""The tolerance question a check asks (``--tolerance``, ``--tolerance-metric``,
``--tolerance-observable``, ``--confidence``), checked when it is built: part of the request,
so harness/request/prepare.py builds it before any work. The verdict that answers it is
harness/workflows/tolerance.py."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from vifpk.core.defaults import DENSITY_OBSERVABLES, TOLERANCE, TOLERANCE_CONFIDENCE
from vifpk.core.result import BadInput

METRICS = ("L1", "ks", "w1", "hellinger")
OBSERVABLES = DENSITY_OBSERVABLES
#: the largest value each distance between two densities can take (harness/workflows/compare.py):
#: L1 = int |p - q| <= 2, KS = max |F - G| <= 1, Hellinger = sqrt(1 - int sqrt(p q)) <= 1;
#: W1 is unbounded. A tolerance at or above the maximum holds for any pair (issue 39, K05).
METRIC_MAXIMUM = {"L1": 2.0, "ks": 1.0, "hellinger": 1.0}


class ToleranceError(BadInput):
    """A tolerance option out of its range (one line naming it and the range; exit 2)."""


@dataclass(frozen=True, kw_only=True)
class Tolerance:
    """The question: is ``metric`` of p(``observable``) at most ``value``, at ``confidence``?"""

    value: float = TOLERANCE
    metric: str = "L1"
    observable: str = "A"
    confidence: float = TOLERANCE_CONFIDENCE

    def __post_init__(self) -> None:
        if not (isinstance(self.value, int | float) and math.isfinite(self.value)
                and self.value > 0):
            raise ToleranceError(f"--tolerance must be a number > 0 (the largest accepted "
                                 f"averaging error), not {self.value!r}")
        if self.metric not in METRICS:
            raise ToleranceError(f"--tolerance-metric must be one of {METRICS}, "
                                 f"not {self.metric!r}")
        top = METRIC_MAXIMUM.get(self.metric)
        if top is not None and self.value >= top:
            raise ToleranceError(f"--tolerance must be > 0 and < {top:g} for "
                                 f"--tolerance-metric {self.metric} (which is at most {top:g}: "
                                 f"a tolerance of {top:g} or more holds for any two densities), "
                                 f"not {self.value!r}")
        if self.observable not in OBSERVABLES:
            raise ToleranceError(f"--tolerance-observable must be one of {OBSERVABLES}, "
                                 f"not {self.observable!r}")
        if not (isinstance(self.confidence, int | float) and 0.5 < self.confidence < 1):
            raise ToleranceError(f"--confidence must be between 0.5 and 1 (exclusive), "
                                 f"not {self.confidence!r}")

    def record(self) -> dict[str, Any]:
        return asdict(self)

    def words(self) -> str:
        return (f"{self.metric}({self.observable}) <= {self.value:g} at "
                f"{100 * self.confidence:g}% confidence")
