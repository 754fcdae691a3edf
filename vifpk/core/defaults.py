"""Defaults that more than one module uses: each written here once.

A default that belongs to one module stays there; one that two modules share (a solver and
the harness that estimates its cost, a workflow and the command line that documents it) lives
here, with where it comes from.
"""

from __future__ import annotations

from pathlib import Path

#: Cells of the FPK of an averaged model when none is asked for (``vifpk solve --solver fpk``,
#: the cross-check's discretisation error, ``fpk.stationary``); docs/fpk.md measures its error
#: (second order in the cell width, tests/test_fpk.py).
FPK_CELLS = 400
#: Cells of the FPK direct solve that gives p(A) of a model with no closed form (a plugin
#: giving only drift and diffusion): twice FPK_CELLS, so the reference is the finer grid.
REFERENCE_CELLS = 800
#: The L1 error of p(A) the original system's FPK (``vifpk solve --solver original-fpk``,
#: vifpk.fpk2d) is run to when no grid is given: its resolution follows from it (Richardson's
#: estimate, docs/fpk2d.md); a tenth of the Monte Carlo floors a check reaches in seconds
#: (~0.005), so as the check's truth its own error is negligible beside theirs.
ORIGINAL_FPK_ACCURACY = 5e-4
#: Burn-in = BURN_FACTOR x the relaxation time tau (montecarlo/tuning.py: the start's offset
#: from equilibrium decays as exp(-t / tau), so e^-6 = 2.5e-3 of it is left).
BURN_FACTOR = 6.0
#: The averaged models a cross-check (and a sweep of cross-checks) runs when none is named,
#: in this order: report columns follow it (the averaged SDEs' seeds follow each model's name,
#: harness.workflows.check.sde_seed, never its place in the list).
CHECK_MODELS = ("paper", "exact", "corrected")
#: The observables every solver gives as densities (closed forms, FPK, Monte Carlo), compared
#: by check and by the tolerance tests.
DENSITY_OBSERVABLES = ("A", "x1", "x2")
#: The models a bifurcation search runs when none is named (the paper's and the exact one).
BIFURCATION_MODELS = ("paper", "exact")
#: The tolerance verdict's defaults (issue 29; harness/workflows/tolerance.py, ``vifpk check
#: --tolerance``, the ``tolerance`` of check sweeps): the largest averaging error a user
#: accepts, on L1 of p(A) (L1 / 2 = 1% of the probability mass misplaced), and the confidence
#: at which a model is called inside or outside it.
TOLERANCE = 0.02
#: The bound of the smallest error class of an L1 of p(A) a check reports ("small" below it,
#: at most 5% of the probability mass misplaced; harness/workflows/verdict.py): also the most
#: L1 bias the step rule's model (montecarlo/tuning.py ``predicted_bias``) may put on the
#: Monte Carlo at a given --dt (harness/request/validate.py; issue 45), lest its own bias be
#: read as a model's error of that size.
SMALL_L1 = 0.1
TOLERANCE_CONFIDENCE = 0.95


def cache_dir() -> Path:
    """The one folder vifpk caches in (the machine's measured Monte Carlo speed, the testing
    API's Monte Carlo references): ``$VIFPK_CACHE`` when set, else the platform's user cache
    folder for vifpk (platformdirs: ``$XDG_CACHE_HOME/vifpk``, by default ``~/.cache/vifpk``,
    on Linux), read at each call so that a changed environment is followed."""
    import os

    from platformdirs import user_cache_dir

    env = os.environ.get("VIFPK_CACHE")
    return Path(env) if env else Path(user_cache_dir("vifpk", appauthor=False))
