"""The cost guard of a direct first-passage run for the front ends without the command's
``--yes`` dialogue (the Python API, the testing API): the command line's price
(harness/cli/timedomain.py: the plan of workflows/passage.py from the request's MFPT
quadratures, request/cost.py: refuse_costly) applied before any R(t) stepping or Monte Carlo,
worded for a Python caller (issue 39, X12: ``vifpk.passage(..., threshold=2.0)`` ran the
exact model's R(t) stepping for minutes, silently).
"""

from __future__ import annotations

import os
from typing import Any

from vifpk.harness.request import cost
from vifpk.harness.request.errors import InputError
from vifpk.harness.workflows.passage import plan, run_seconds


def refuse_costly_direct(req: Any, *, override: str) -> None:
    """InputError (BadInput), one line, when the direct run of ``req`` (a PassageRequest with
    its quadratures, request.timedomain.with_quadratures) is estimated above an hour: the
    models' largest MFPT, the plan, the estimate, and ``method='splitting'``; ``override``
    what else the caller can do, said at the end (e.g. "or yes=True to run it anyway")."""
    sc = req.scene
    p = plan(sc, {m: float(q["value"]) for m, q in req.quadratures.items()},
             paths=req.paths or req.max_paths, horizon=req.horizon)  # growth: its cap
    cores = sc.montecarlo.threads or min(cost.numba_threads_available(), os.cpu_count() or 1)
    what = (f"threshold {req.threshold:g}: the averaged models put the MFPT at up to "
            f"{p['largest_model_mfpt']:.3g} time units, so the first-passage Monte Carlo "
            f"({p['paths']} paths to a horizon of {p['horizon']:.3g}, dt {p['dt']:g}) is out "
            "of reach as a direct simulation (method='splitting' estimates the MFPT at rare "
            "thresholds)")
    try:
        cost.refuse_costly(lambda sp: run_seconds(p, 1 + len(req.models),
                                                  sp or cost.MC_STEPS_PER_CORE, cores),
                           what, False)
    except InputError as exc:  # the guard's estimate, the ending a Python caller can act on
        head = str(exc).split("; allowed without --yes")[0]
        raise InputError(f"{head}; allowed: up to 1 hour ({override})") from None
