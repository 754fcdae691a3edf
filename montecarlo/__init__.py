"""numba Monte Carlo of the original non-smooth vibro-impact system (impacts, stick-slip,
OU or white noise), and of an averaged 1-D amplitude SDE. Imports no other vifpk package.
"""

from .simulate import (
                       OBSERVABLES,
                       BudgetExhausted,
                       Result,
                       Settings,
                       SimulationDiverged,
                       block_seeds,
                       effects,
                       sampling_plan,
                       simulate,
                       step_size,
)

__all__ = ["OBSERVABLES", "BudgetExhausted", "Result", "Settings", "SimulationDiverged",
           "block_seeds", "effects", "sampling_plan", "simulate", "step_size"]
