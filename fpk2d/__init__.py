"""The stationary Fokker-Planck equation of the ORIGINAL system in (x, v) (issue 46)::

    x'' + d(x) x' + e(x') x' + g(x) + mu sgn(x') = f xi(t)  (+ parametric white noises),

white external noise, walls anywhere with any impact law (the non-local inflow condition of
the impact map), solved without sampling noise: the fourth independent truth beside the
averaged models' closed forms, their FPK (``fpk``) and the Monte Carlo. Imports only
``vifpk.core`` and ``vifpk.physics``. Derivation and measurements: docs/fpk2d.md.
"""

from .physics import SOLVER, Coefficients, Unsupported, coefficients
from .scheme import ORDER, Grid, kink_flux, make_grid, operator
from .solve import FPK2DFailure, Solution, choose_energy, solve_grid, stationary

__all__ = ["ORDER", "SOLVER", "Coefficients", "FPK2DFailure", "Grid", "Solution",
           "Unsupported", "choose_energy", "coefficients", "kink_flux", "make_grid",
           "operator", "solve_grid", "stationary"]
