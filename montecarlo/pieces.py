"""The compiled pieces of the physics (vifpk.physics), chosen when a kernel is specialised.

Each noise kind declares its Monte Carlo pieces as plain Python (its ``montecarlo`` record,
vifpk.core.protocols.MonteCarloNoise); here they become numba overloads of generic functions
keyed by the class of the kernels' record, so a kernel written once calls
``noise_velocity(rec, ...)`` and numba compiles the kind the record belongs to (and nothing of
the others). The walls' impact laws (vifpk.core.protocols.ImpactLaw) are chosen the same way:
the record class names the lower and upper laws and carries each law's declared parameters as
fields ``lo_law_<name>`` / ``up_law_<name>``, whatever the law declares. A record class without
pieces fails to compile naming it; ``make_record`` raises before any compilation for a kind
without Monte Carlo pieces (physics.noise.NoPiece, one line naming kind and solver).
"""

from __future__ import annotations

import math
from collections import namedtuple
from typing import Any

from numba.extending import overload

from vifpk.core import registry
from vifpk.physics import impact
from vifpk.physics import noise as noise_kinds

from ._jit import jit
from .geometry import restoring
from .plan import SOLVER, bounds, fold, noise_piece

#: The kernels' physics record, flat (numba's parallel loops take no tuple nested in a tuple):
#: these fields, then the walls' law parameters (``lo_law_<p>``, ``up_law_<p>``), then the
#: noise kind's own (its Record's). A switched-off effect is None (mu, khi, dhi, ev, bridge,
#: lo, up): numba compiles a specialisation per record type and, where a helper takes the
#: field as an argument, prunes the effect's code.
#: the most impacts one drift sub-step takes between two walls: walls so close that a path
#: meets them more often within h/2 (walls 2e-50 apart with r = 1: ~1e46 impacts a step, an
#: impact rate no event-driven simulation resolves at any dt) make the path non-finite, and the
#: run stops in one line naming the walls (montecarlo/failures.py walls_cause), where the loop
#: would never end. Walls 2e-6 apart take ~12 a sub-step at dt 0.01 (issue 45).
WALL_HITS_MAX = 10_000

BASE_FIELDS = ("c1", "c2", "w0sq", "alpha", "f", "mu", "khi", "dhi", "ev",
               "bridge",  # first passage's bridge correction (MonteCarloNoise.bridge)
               "xi_sd",  # a Gaussian noise state's stationary standard deviation (0: none)
               # walls: position (None: no wall), g at the wall (its spring force, for the
               # chatter guard)
               "lo", "lo_g", "up", "up_g",
               "x_lo", "x_hi",  # the walls' positions, -inf / inf without (orbit starts)
               # parametric Stratonovich white noises over a half step: sqrt(2 D (h/2)) on
               # the spring (pk) and on the damping (pc); None: off
               "pk", "pc",
               "fold")  # orbit starts: fold y -> |y| (one wall at 0: exact), else reject

_CLASSES: dict[tuple[str, str | None, str | None], type] = {}
_PIECES: dict[type, Any] = {}  # record class -> the noise kind's MonteCarloNoise
_LAWS: dict[type, tuple[str | None, str | None]] = {}  # record class -> (lower, upper) law


def _law_fields(prefix: str, law: str | None) -> tuple[str, ...]:
    if law is None:
        return ()
    return tuple(f"{prefix}_law_{p.name}" for p in impact.law(law, solver=SOLVER).params)


def _ident(name: str) -> str:
    """``name`` as a part of a Python identifier (numba's cache names a record class by it):
    ASCII letters and digits kept, every other character (``-``, ``.``, ``_``, ...) written
    as ``_<hex code>_``, so ``bounded-copy`` is ``bounded_2d_copy`` and no two names meet."""
    return "".join(c if c.isascii() and c.isalnum() else f"_{ord(c):x}_" for c in name)


def record_class(kind: str, lower: str | None = None, upper: str | None = None) -> type:
    """The record class of a noise kind and the walls' impact laws (None: no wall):
    BASE_FIELDS + the laws' parameters + the kind's Record fields (a module global
    ``Record_<kind>_<lower>_<upper>``, each name made an identifier by ``_ident``, so numba's
    cache can name it). NoPiece for a kind
    without Monte Carlo pieces, NoLaw for a law that is not registered (one line each)."""
    key = (kind, lower, upper)
    if key not in _CLASSES:
        mc = noise_kinds.pieces(kind, SOLVER)
        own = tuple(mc.Record._fields)
        walls = _law_fields("lo", lower) + _law_fields("up", upper)
        clash = set(own) & set(BASE_FIELDS + walls)
        if clash:
            raise noise_kinds.NoPiece(
                f"noise kind {kind!r}: its Monte Carlo Record field {sorted(clash)[0]!r} "
                "clashes with the kernels' own; prefix its fields with the kind's name")
        name = "Record_" + "_".join(_ident(str(n)) for n in key)
        if name in (c.__name__ for c in _CLASSES.values()):
            raise noise_kinds.NoPiece(
                f"noise kind {kind!r} with laws {lower!r}, {upper!r}: its record class name "
                f"{name} is another kind's or law's; rename the kind or the law")
        cls = namedtuple(name, BASE_FIELDS + walls + own)  # noqa: PYI024
        cls.__module__ = __name__
        globals()[cls.__name__] = cls
        _CLASSES[key] = cls
        _PIECES[cls] = mc
        _LAWS[cls] = (lower, upper)
    return _CLASSES[key]


def make_record(noise: Any, base: dict[str, Any], laws: tuple[Any, Any], h: float) -> Any:
    """The record: ``base`` (BASE_FIELDS' values by name), the walls (lower, upper:
    vifpk.core.walls.Wall or None) and the kind's coefficients for step h."""
    cls = record_class(noise.kind, *(w.law if w is not None else None for w in laws))
    walls = tuple(float(v) for w in laws if w is not None for _, v in w.params)
    return cls(*(base[k] for k in BASE_FIELDS), *walls,
               *noise_kinds.pieces(noise.kind, SOLVER).record(noise.values, base["f"], h))


def record(phys: dict[str, Any], h: float) -> Any:
    """The kernels' one physics record for step h (pieces.BASE_FIELDS, the walls' law
    parameters, then the noise kind's coefficients): a flat named tuple whose class names
    the noise kind and the laws."""
    base = {k: phys[k] for k in ("c1", "c2", "w0sq", "alpha", "f", "mu", "khi", "dhi", "ev")}
    base["bridge"] = noise_piece(phys, "bridge") or None  # 0 (no noise): E is C^1
    base["xi_sd"] = noise_piece(phys, "start_sd") or 0.0
    for key in ("lo", "up"):
        w = phys["lower" if key == "lo" else "upper"]
        at = float(w.at) if w is not None else None
        base.update({key: at,
                     f"{key}_g": float(restoring(at, phys["w0sq"], phys["alpha"], phys["khi"]))
                     if w is not None else 0.0})
    base["x_lo"], base["x_hi"] = bounds(phys)
    base["fold"] = fold(phys)
    for key, name in (("pk", "D_k"), ("pc", "D_c")):
        base[key] = math.sqrt(phys[name] * h) if phys.get(name) is not None else None
    return make_record(phys["noise"], base, (phys["lower"], phys["upper"]), h)


for _kind in noise_kinds.kinds_with(SOLVER):
    for _lo in (None, *registry.impact_law_names()):
        for _up in (None, *registry.impact_law_names()):
            try:
                record_class(_kind, _lo, _up)
            except (noise_kinds.NoPiece, impact.NoLaw):
                continue  # named when a scene asks for it


def __getattr__(name: str) -> Any:
    """A stand-in for a record class this process does not have (PEP 562): numba's on-disk
    cache index of a kernel lists the record classes it was compiled for in ANY process (a
    kind or law of a plugin since uninstalled, or installed in another environment sharing the
    cache), and unpickling that index looks each one up here. Every registered kind's and
    law's classes exist from import on (above), so a stand-in is never a class this process
    compiles for: its cached entries are simply not used."""
    if name.startswith("Record_"):
        cls = namedtuple(name, ("unavailable",))  # noqa: PYI024
        cls.__module__ = __name__
        globals()[name] = cls
        return cls
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    return _module_of(rec).press


@overload(noise_velocity)
def _ol_velocity(rec, v, xi, g, k, mu, at_wall, h, half, s0, s1, s2, s3):
    from .kernels import velocity_flow
    from .rng import normal
    return _module_of(rec).velocity(velocity_flow, normal)


@overload(noise_advance)
def _ol_advance(rec, xi, s0, s1, s2, s3):
    from .rng import normal
    return _module_of(rec).advance(normal)


@overload(noise_energy)
def _ol_energy(rec, h, half, k, mu, vb, vc, vk, vd, ve, xi):
    return _module_of(rec).energy


# ------------------------------------------------------------------------------- walls
_LAW_FNS: dict[str, Any] = {}
_AT_WALL: dict[tuple[str, str], Any] = {}


def _law_fns(name: str) -> Any:
    """The law's restitution e(v, *params), compiled once."""
    if name not in _LAW_FNS:
        _LAW_FNS[name] = jit(impact.law(name, solver=SOLVER).restitution)
    return _LAW_FNS[name]


def _at_wall(name: str, prefix: str) -> Any:
    """``e(rec, v)``: the law's restitution at speed v with its parameters read from the
    record's fields ``<prefix>_law_<param>`` in declared order (written for the law's own
    parameters, whatever it declares; numba compiles it into the caller)."""
    key = (name, prefix)
    if key not in _AT_WALL:
        args = "".join(f", rec.{f}" for f in _law_fields(prefix, name))
        ns: dict[str, Any] = {"e": _law_fns(name)}
        exec(f"def at_wall(rec, v):\n    return e(v{args})\n", ns)  # noqa: S102
        _AT_WALL[key] = ns["at_wall"]
    return _AT_WALL[key]


def lower_e(rec, v):  # pragma: no cover
    raise NotImplementedError


def upper_e(rec, v):  # pragma: no cover
    raise NotImplementedError


@overload(lower_e)
def _ol_lower_e(rec, v):
    return _at_wall(_LAWS[rec.instance_class][0], "lo")


@overload(upper_e)
def _ol_upper_e(rec, v):
    return _at_wall(_LAWS[rec.instance_class][1], "up")


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
        def low(rec, x, v, tau, press_lo, press_up, h):
            xn = x + v * tau
            if xn >= rec.lo:
                return xn, v, 0, 0, 0.0
            return reflect(x, v, tau, rec.lo, lower_e(rec, -v), press_lo,
                           h)
        return low
    if lower is None:
        def high(rec, x, v, tau, press_lo, press_up, h):
            xn = x + v * tau
            if xn <= rec.up:
                return xn, v, 0, 0, 0.0
            return reflect(x, v, tau, rec.up, upper_e(rec, v), press_up,
                           h)
        return high
    def both(rec, x, v, tau, press_lo, press_up, h):
        # every impact of the free flight x + v t inside the sub-step, in turn: the flight is
        # exact, so a gap crossed several times within h/2 (walls 2e-6 apart, issue 45) is
        # resolved as it is (one impact at a time before: the mass left the gap and the run
        # blew up or pinned the impacts at one per half step); the chatter guard still rests
        # a mass whose rebound is too slow for one step
        xn = x + v * tau
        imp, ch, lost = 0, 0, 0.0
        while xn < rec.lo or xn > rec.up:
            if imp >= WALL_HITS_MAX:  # see WALL_HITS_MAX: the path is stopped, not hung
                return math.nan, math.nan, imp, ch, lost
            lower = xn < rec.lo
            at = rec.lo if lower else rec.up
            t_hit = (at - x) / v
            x, v, i1, c1, l1 = reflect(x, v, tau, at,
                                       lower_e(rec, -v) if lower else upper_e(rec, v),
                                       press_lo if lower else press_up, h)
            imp, ch, lost = imp + i1, ch + c1, lost + l1
            if c1 > 0 or v == 0.0:
                return x, v, imp, ch, lost
            tau = tau - t_hit
            x = at
            xn = x + v * tau
        return xn, v, imp, ch, lost
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
