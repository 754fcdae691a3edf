"""Averaged amplitude models of the vibro-impact oscillator (closed form and exact averages).

``solve(scene, model="paper"|"exact"|"corrected")`` returns ``Result(data, info)``;
``build_model`` gives the drift m(A) and diffusion sigma^2(A) that the FPK and the averaged-SDE
Monte Carlo use.
"""

from .solve import MODELS, Result, build_model, solve
from .stationary import NoStationaryDensity

__all__ = ["MODELS", "NoStationaryDensity", "Result", "build_model", "solve"]
