"""py-pde time stepping of the 1-D amplitude FPK in conservative flux form.

Generic in the drift m(A) and diffusion sigma^2(A); imports no other vifpk package.
``stationary(m, sigma2, ...)``, ``transient(...)`` and ``reliability(...)`` (first passage,
absorbing wall) return ``Result(data, info)``; ``mfpt(...)`` the Pontryagin quadrature.
"""

from .passage import QUAD_ORDER, mfpt, reliability
from .scheme import ORDER, CoefficientError, Discretisation, discretise
from .solve import Result, choose_domain, stationary, transient
from .stepper import STEPPERS, FPKFailure

__all__ = ["ORDER", "STEPPERS", "CoefficientError", "Discretisation", "FPKFailure", "Result",
           "QUAD_ORDER", "choose_domain", "discretise", "mfpt", "reliability", "stationary",
           "transient"]
