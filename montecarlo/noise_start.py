"""The compiled start of a path's noise state (its kind's ``state_start``,
vifpk.core.protocols.MonteCarloNoise), chosen by the class of the kernels' record like the
other pieces (montecarlo/pieces.py). Its own module so that geometry.orbit_start can call it
(pieces.py imports geometry)."""

from __future__ import annotations

from numba.extending import overload


def noise_start(rec, s0, s1, s2, s3):  # pragma: no cover
    raise NotImplementedError


@overload(noise_start)
def _ol_start(rec, s0, s1, s2, s3):
    """One draw of the path's noise state from its stationary law (the kind's
    ``state_start``: a Gaussian, a uniform phase, or nothing): (xi, s0, s1, s2, s3)."""
    from .pieces import _module_of
    from .rng import normal, uniform
    return _module_of(rec).state_start(normal, uniform)
