"""The 1-D amplitude FPK in conservative flux form: its direct stationary solve, and py-pde
time stepping (on request for the stationary law; transients and first passage).

Generic in the drift m(A) and diffusion sigma^2(A); imports no other vifpk package.
``stationary(m, sigma2, ...)``, ``transient(...)`` and ``reliability(...)`` (first passage,
absorbing wall) return ``Result(data, info)``; ``mfpt(...)`` the Pontryagin quadrature.
"""

from vifpk.core.protocols import SolverSpec

from .passage import QUAD_ORDER, mfpt, reliability
from .scheme import ORDER, STEPPERS, CoefficientError, Discretisation, FPKFailure, discretise
from .solve import Result, choose_domain, stationary, transient

#: vifpk's own FPK solver, registered in pyproject.toml's ``vifpk.solvers`` group: what
#: ``vifpk solve --solver fpk`` runs and what ``vifpk check`` measures against each model's
#: closed form (metrics.json: ``discretisation_error``).
SOLVER = SolverSpec("fpk", "Scharfetter-Gummel finite volumes in flux form, the stationary "
                    "state solved directly (time stepping with py-pde on request)",
                    stationary=stationary,
                    metric="discretisation_error")

__all__ = ["ORDER", "SOLVER", "STEPPERS", "CoefficientError", "Discretisation", "FPKFailure",
           "Result", "QUAD_ORDER", "choose_domain", "discretise", "mfpt", "reliability",
           "stationary", "transient"]
