"""numba Monte Carlo of the original non-smooth vibro-impact system (impacts, stick-slip,
OU or white noise), and of an averaged 1-D amplitude SDE. Imports no other vifpk package.
"""

from .passage import PassageSettings, StartRejected, first_passage, sample_starts
from .plan import Plan, physics, plan, sampling_plan, step_size
from .sde_time import sde_first_passage, sde_snapshots
from .simulate import (
                       OBSERVABLES,
                       BudgetExhausted,
                       Settings,
                       SimulationDiverged,
                       block_seeds,
                       effects,
                       simulate,
)
from .transient import snapshots

__all__ = ["OBSERVABLES", "BudgetExhausted", "PassageSettings", "Plan", "Settings",
           "SimulationDiverged", "StartRejected", "block_seeds", "effects", "first_passage",
           "physics", "plan", "sample_starts", "sampling_plan", "sde_first_passage",
           "sde_snapshots", "simulate", "snapshots", "step_size"]
