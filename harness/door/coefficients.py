"""The door's scope for one run's averaged-model coefficients (issue 44, the main job)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager


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
