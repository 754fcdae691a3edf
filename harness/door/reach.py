"""Before any work (issue 45), asked by the request layer (harness/request/validate.py):
whether the closed form's grid can hold a scene's stationary law (``law_reach``), and the
Monte Carlo's own bias at a given step by the step rule's model (``step_bias``,
``step_limit``: montecarlo/tuning.py ``predicted_bias``, read, not restated)."""

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


@boundary
def step_bias(scene: Any, dt: float) -> float:
    """The L1 bias of p(A) the step rule's model puts on the original system's Monte Carlo at
    step ``dt`` (vifpk.montecarlo.tuning.predicted_bias, before the pilot: the rate of the
    provisional rule, max(sqrt(k1), 1) in the base scene's unit, and the held noise's
    term)."""
    from vifpk.montecarlo import physics, tuning

    return float(tuning.predicted_bias(physics(scene.system, scene.noise, scene.parametric),
                                       None, float(dt)))


@boundary
def step_limit(scene: Any, allowed: float, dt: float) -> float:
    """The largest step below ``dt`` whose :func:`step_bias` is within ``allowed`` (bisection
    in log dt: the model grows with dt), to 1e-4 relative."""
    lo, hi = dt * 1e-6, dt
    while hi / lo > 1 + 1e-4:
        mid = (lo * hi) ** 0.5
        lo, hi = (mid, hi) if step_bias(scene, mid) <= allowed else (lo, mid)
    return lo
