"""The door's scope for one run's averaged-model coefficients (issue 44, the main job)."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def shared_coefficients() -> Iterator[None]:
    """Within the block, the averaged models' costly coefficients (the exact orbit's averages
    and sigma_E^2, which the exact, compounded and corrected models share) are computed once
    per amplitude grid and handed to every solver that asks again: the closed form, the FPK
    and the averaged SDE each get the model's drift and diffusion as before, bit for bit
    (``averaging.memo``). A workflow enters it for one run (harness/workflows/check.py)."""
    from vifpk.averaging.memo import shared

    with shared():
        yield


def carried(fn: Callable[..., Any]) -> Callable[..., Any]:
    """``fn`` for another thread, inside this thread's scope of shared coefficients (if any):
    what the check solves beside its Monte Carlo shares the run's coefficients."""
    from vifpk.averaging.memo import carry

    return carry(fn)
