"""The door to the original system's own Fokker-Planck equation in (x, v) (``fpk2d``, issue
46): the stationary law of the original system with no averaging and no sampling noise, for
the scenes it has generators for, and the one-line reason where it has none.
"""

from __future__ import annotations

from typing import Any

from vifpk.harness.door.boundary import SolverFailure, boundary

from vifpk.core.result import Result
from vifpk.core.scene import no_noise


@boundary
def original_fpk_problem(scene: Any) -> str | None:
    """None when the original system's FPK (``fpk2d``) has a generator for every effect the
    scene switches on, else why not, in one line naming the kind or law (checked before any
    work: the request layer refuses the scene with it)."""
    from vifpk import fpk2d

    try:
        fpk2d.coefficients(scene.system, scene.noise, getattr(scene, "parametric", None))
    except fpk2d.Unsupported as exc:
        return str(exc)
    return None


@boundary
def original_fpk_solution(scene: Any, *, cells: int | None = None, accuracy: float | None = None,
                          **options: Any) -> Result:
    """The stationary law of the ORIGINAL system by its own Fokker-Planck equation in (x, v)
    (``fpk2d.stationary``: no averaging, no sampling noise; its discretisation error estimated
    by refinement, ``info["discretisation_error"]``). ``cells``: per axis (default: from
    ``accuracy``, the L1 of p(A) asked, default ORIGINAL_FPK_ACCURACY)."""
    from vifpk import fpk2d
    from vifpk.core.defaults import ORIGINAL_FPK_ACCURACY

    if no_noise(scene.system):
        raise SolverFailure(no_noise(scene.system))
    return fpk2d.stationary(scene.system, scene.noise, getattr(scene, "parametric", None),
                            cells=cells, accuracy=accuracy or ORIGINAL_FPK_ACCURACY,
                            **options)
