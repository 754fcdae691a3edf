"""Averaged amplitude models of the vibro-impact oscillator (closed form and exact averages).

``solve(scene, model=NAME)`` returns ``Result(data, info)`` (vifpk.core.result) for any
registered model with a closed form (vifpk.core.registry: ``paper``, ``exact``, ``corrected``,
plugins); ``build_model`` gives the drift m(A) and diffusion sigma^2(A) that the FPK and the
averaged-SDE Monte Carlo use.
"""

from .solve import NoClosedForm, build_model, has_closed_form, solve
from .stationary import DensityDoesNotDecay, NoStationaryDensity

__all__ = ["DensityDoesNotDecay", "NoClosedForm", "NoStationaryDensity", "build_model",
           "has_closed_form", "solve"]
