"""The compiled pieces of the physics (vifpk.physics), chosen when a kernel is specialised.

Each noise kind's module (vifpk/physics/noise/<kind>.py) declares its Monte Carlo pieces as
plain Python; here they become numba overloads of four generic functions keyed by the class of
the kind's record (``MCRecord``), so a kernel written once calls ``noise_velocity(rec, ...)`` and
numba compiles the kind the record belongs to (and nothing of the others). A record class
without pieces fails to compile naming it; ``make_record`` raises before any compilation for a
kind without Monte Carlo pieces (physics.noise.NoPiece, one line naming kind and solver).
"""

from __future__ import annotations

import math
from collections import namedtuple
from typing import Any

from numba.extending import overload

from vifpk.core.registry import IMPACT_LAW_NAMES
from vifpk.physics import impact
from vifpk.physics import noise as noise_kinds

from ._jit import jit
from .geometry import restoring
from .plan import SOLVER, bounds, fold, noise_piece

#: The kernels' physics record, flat (numba's parallel loops take no tuple nested in a tuple):
#: these fields, then the noise kind's own (its MCRecord's). A switched-off effect is None
#: (mu, khi, dhi, ev, bridge, lo, up): numba compiles a specialisation per record type and,
#: where a helper takes the field as an argument, prunes the effect's code.
BASE_FIELDS = ("c1", "c2", "w0sq", "alpha", "f", "mu", "khi", "dhi", "ev",
               "bridge",  # first passage's bridge correction (mc_bridge; None: none)
               "xi_sd",  # the noise state's stationary standard deviation (0: no state)
               # walls: position (None: no wall), restitution r, the law's yield speed
               # (None: unused), g at the wall (its spring force, for the chatter guard)
               "lo", "lo_r", "lo_vy", "lo_g", "up", "up_r", "up_vy", "up_g",
               "x_lo", "x_hi",  # the walls' positions, -inf / inf without (orbit starts)
               # parametric Stratonovich white noises over a half step: sqrt(2 D (h/2)) on
               # the spring (pk) and on the damping (pc); None: off
               "pk", "pc",
               "fold")  # orbit starts: fold y -> |y| (one wall at 0: exact), else reject

_CLASSES: dict[tuple[str, str | None, str | None], type] = {}
_PIECES: dict[type, Any] = {}  # record class -> the noise kind's module
_LAWS: dict[type, tuple[str | None, str | None]] = {}  # record class -> (lower, upper) law


def record_class(kind: str, lower: str | None = None, upper: str | None = None) -> type:
    """The record class of a noise kind and the walls' impact laws (None: no wall):
    BASE_FIELDS + the kind's MCRecord fields (a module global ``Record_<kind>_<lower>_<upper>``,
    so numba's cache can name it). NoPiece for a kind without Monte Carlo pieces, NoLaw for
    a law without a module."""
    key = (kind, lower, upper)
    if key not in _CLASSES:
        fields = noise_kinds.piece(kind, SOLVER, "MCRecord")._fields
        for name in (lower, upper):
            if name is not None:
                impact.law(name)
        cls = namedtuple(f"Record_{kind}_{lower}_{upper}",  # noqa: PYI024
                         BASE_FIELDS + tuple(fields))
        cls.__module__ = __name__
        globals()[cls.__name__] = cls
        _CLASSES[key] = cls
        _PIECES[cls] = noise_kinds.module(kind)
        _LAWS[cls] = (lower, upper)
    return _CLASSES[key]


def make_record(noise: Any, base: dict[str, Any], laws: tuple[str | None, str | None],
                h: float) -> Any:
    """The record: ``base`` (BASE_FIELDS' values by name), the walls' ``laws`` (lower, upper;
    None: no wall) and the kind's coefficients for step h."""
    return record_class(noise.kind, *laws)(
        *(base[k] for k in BASE_FIELDS),
        *noise_kinds.piece(noise.kind, SOLVER, "record")(noise, base["f"], h))


def record(phys: dict[str, Any], h: float) -> Any:
    """The kernels' one physics record for step h (pieces.BASE_FIELDS, then the noise kind's
    coefficients from its module): a flat named tuple whose class is the noise kind's."""
    base = {k: phys[k] for k in ("c1", "c2", "w0sq", "alpha", "f", "mu", "khi", "dhi", "ev")}
    base["bridge"] = noise_piece(phys, "bridge") or None  # 0 (no noise): E is C^1
    base["xi_sd"] = noise_piece(phys, "start_sd") or 0.0
    for key in ("lo", "up"):
        w = phys["lower" if key == "lo" else "upper"]
        at = float(w.at) if w is not None else None
        base.update({key: at, f"{key}_r": float(w.r) if w is not None else 0.0,
                     f"{key}_vy": None if w is None or w.v_yield is None else float(w.v_yield),
                     f"{key}_g": float(restoring(at, phys["w0sq"], phys["alpha"], phys["khi"]))
                     if w is not None else 0.0})
    base["x_lo"], base["x_hi"] = bounds(phys)
    base["fold"] = fold(phys)
    for key, name in (("pk", "D_k"), ("pc", "D_c")):
        base[key] = math.sqrt(phys[name] * h) if phys.get(name) is not None else None
    laws = tuple(w.law if w is not None else None for w in (phys["lower"], phys["upper"]))
    return make_record(phys["noise"], base, laws, h)



for _kind in noise_kinds.kinds_with(SOLVER, "record"):
    for _lo in (None, *IMPACT_LAW_NAMES):
        for _up in (None, *IMPACT_LAW_NAMES):
            record_class(_kind, _lo, _up)


def _module_of(rec_type: Any) -> Any:
    cls = getattr(rec_type, "instance_class", None)
    if cls not in _PIECES:
        raise TypeError(f"no Monte Carlo noise pieces for a record of type {rec_type}")
    return _PIECES[cls]


# the generic functions (their bodies are never run by Python: numba uses the overloads)
def noise_press(rec, xi):  # pragma: no cover
    raise NotImplementedError


def noise_velocity(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):  # pragma: no cover
    raise NotImplementedError


def noise_advance(rec, xi, s0, s1, s2, s3):  # pragma: no cover
    raise NotImplementedError


def noise_energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi):  # pragma: no cover
    raise NotImplementedError


@overload(noise_press)
def _ol_press(rec, xi):
    return _module_of(rec).mc_press


@overload(noise_velocity)
def _ol_velocity(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):
    from .kernels import velocity_flow
    from .rng import normal
    return _module_of(rec).mc_velocity(velocity_flow, normal)


@overload(noise_advance)
def _ol_advance(rec, xi, s0, s1, s2, s3):
    from .rng import normal
    return _module_of(rec).mc_advance(normal)


@overload(noise_energy)
def _ol_energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi):
    return _module_of(rec).mc_energy


# ------------------------------------------------------------------------------- walls
_LAW_FNS: dict[str, Any] = {}


def _law_fns(name: str) -> Any:
    """The law's restitution e(|v|), compiled once."""
    if name not in _LAW_FNS:
        _LAW_FNS[name] = jit(impact.law(name).restitution)
    return _LAW_FNS[name]


@jit
def reflect(x, v, tau, at, e, press, h):
    """The impact at the wall ``at`` inside a drift of length tau from x at velocity v (the
    root of x + v t = at is exact: x is linear in the drift): v -> w = -e v and the rest of
    the sub-step is completed, or, when the rebound speed |w| is below press h (the chatter
    guard: the next flight would be shorter than one step), the mass rests on the wall.
    Returns (x, v, impacts, chatter entries, kinetic energy lost: (1 - e^2) v^2 / 2 at an
    impact, the law's energy_loss, all of v^2/2 when resting: the limit of the Zeno
    sequence)."""
    t_hit = (at - x) / v
    w = -e * v
    if press > 0.0 and abs(w) < press * h:
        return at, 0.0, 1, 1, 0.5 * v * v
    return at + w * (tau - t_hit), w, 1, 0, 0.5 * (1.0 - e * e) * v * v


def wall_drift(rec, x, v, tau, press_lo, press_up, h):  # pragma: no cover
    raise NotImplementedError


def wall_side(rec, x):  # pragma: no cover
    raise NotImplementedError


@overload(wall_drift)
def _ol_wall_drift(rec, x, v, tau, press_lo, press_up, h):
    """x += v tau with the record's walls (their laws' restitution and loss, chosen here)."""
    lower, upper = _LAWS[rec.instance_class]
    if lower is None and upper is None:
        def free(rec, x, v, tau, press_lo, press_up, h):
            return x + v * tau, v, 0, 0, 0.0
        return free
    if upper is None:
        e_lo = _law_fns(lower)

        def low(rec, x, v, tau, press_lo, press_up, h):
            xn = x + v * tau
            if xn >= rec.lo:
                return xn, v, 0, 0, 0.0
            return reflect(x, v, tau, rec.lo, e_lo(-v, rec.lo_r, rec.lo_vy), press_lo,
                           h)
        return low
    e_up = _law_fns(upper)
    if lower is None:
        def high(rec, x, v, tau, press_lo, press_up, h):
            xn = x + v * tau
            if xn <= rec.up:
                return xn, v, 0, 0, 0.0
            return reflect(x, v, tau, rec.up, e_up(v, rec.up_r, rec.up_vy), press_up,
                           h)
        return high
    e_lo = _law_fns(lower)

    def both(rec, x, v, tau, press_lo, press_up, h):
        # one impact per drift sub-step (a flight across the gap inside h/2 is not resolved)
        xn = x + v * tau
        if xn < rec.lo:
            return reflect(x, v, tau, rec.lo, e_lo(-v, rec.lo_r, rec.lo_vy), press_lo,
                           h)
        if xn > rec.up:
            return reflect(x, v, tau, rec.up, e_up(v, rec.up_r, rec.up_vy), press_up,
                           h)
        return xn, v, 0, 0, 0.0
    return both


@overload(wall_side)
def _ol_wall_side(rec, x):
    """Which wall the mass is resting on: 1 the lower (x == lo exactly), -1 the upper, 0
    none (the sign of the force that presses it on)."""
    lower, upper = _LAWS[rec.instance_class]
    if lower is None and upper is None:
        return lambda rec, x: 0
    if upper is None:
        return lambda rec, x: 1 if x == rec.lo else 0
    if lower is None:
        return lambda rec, x: -1 if x == rec.up else 0

    def both(rec, x):
        if x == rec.lo:
            return 1
        if x == rec.up:
            return -1
        return 0
    return both
