"""Before any work: whether the closed form's grid can hold a scene's stationary law (issue
45), asked by the request layer (harness/request/validate.py ``law_in_reach``)."""

from __future__ import annotations

from typing import Any

from vifpk.harness.door.boundary import boundary

from vifpk.core import registry


@boundary
def law_reach(scene: Any, model: str = "exact", scan: int = 512) -> tuple[bool, float] | None:
    """(held, fall): whether the model's stationary law falls by e^60 below its maximum before
    A = 1e4, as the closed form's grid needs (vifpk.averaging.stationary.reach, the scan the
    closed form itself runs; the FPK's grid ends at the same A), and the largest fall its
    scan saw. None where the model does not apply or has no closed form. The request asks
    it before any work for a scene whose law has a power-law tail (issue 45)."""
    from vifpk.averaging.stationary import reach

    from vifpk import averaging

    if registry.model_applies(model, scene) is not None:
        return None
    m = averaging.build_model(scene, model)
    if not averaging.has_closed_form(m):
        return None
    found = reach(m, scan=scan)
    return found.held, found.fall
