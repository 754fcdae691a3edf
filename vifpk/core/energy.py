"""Whether a system can hold its energy: the orbit-averaged energy balance at large amplitude,
which decides before any work whether a stationary density can exist."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .registry import IMPACT_LAW_PARAMS
from .system import _trim
from .tail import Tail, parametric_tail


@dataclass(frozen=True)
class EnergyBalance:
    """Which effects win the orbit-averaged energy balance at large amplitude (see
    :func:`energy_balance`): ``grows`` (no stationary density), ``tie`` (gains and losses of
    the same leading degree: their constants decide), ``degree`` the leading power's exponent,
    ``gains`` and ``losses`` the fields at that degree, ``terms`` every (field, exponent,
    sign) and ``text`` the verdict in words (one line)."""

    grows: bool
    tie: bool
    degree: int
    gains: tuple[str, ...]
    losses: tuple[str, ...]
    terms: tuple[tuple[str, int, int], ...]
    text: str
    #: the parametric tail (vifpk.core.tail.Tail) where a parametric noise is of the top degree
    tail: Any = None


def energy_balance(system: Any, parametric: Any = None) -> EnergyBalance:
    """Does a mechanism remove energy at large amplitude faster than the noise feeds it?

    With H = x'^2 / 2 + U(x), dH/dt = -(d(x) + e(x'^2)) x'^2 - mu |x'| + f x' xi, and each
    impact with the wall takes (1 - r^2) H. The noise input per unit time is bounded at large
    amplitude (f^2 D for white noise, exactly, Ito; less for the OU band once the orbit's
    frequency leaves it). Along the orbit of amplitude A with the spring's top term
    k_{2n+1} x^{2n+1} (U(A) ~ A^{2n+2}): x ~ A, x' ~ sqrt(2 U(A)) ~ A^{n+1}, and the period
    (between impacts with the wall) T(A) ~ A / A^{n+1} = A^{-n}. The orbit-averaged powers:

        damping  d_{2j} <x^{2j} x'^2>    ~ d_{2j} A^{2j + 2n + 2}
        velocity e_{2m} <x'^{2m} x'^2>   ~ e_{2m} A^{(2m + 2)(n + 1)}
        friction mu <|x'|>               ~ mu A^{n + 1}
        impacts  (1 - r^2) H / T(A)      ~ (1 - r^2) A^{3n + 2}   (barrier and r < 1)

    (the orbit averages are positive constants times these powers). The term of the highest
    exponent decides: a positive coefficient (a loss) outgrows the bounded input, so the energy
    is held and a stationary density exists; a negative one (a gain: c1 > 0 with nothing of
    higher degree, or a negative leading velocity_damping) outgrows every loss, and so does the
    noise input when no term is left at all (no damping, mu = 0, r = 1 or no barrier): the
    energy grows without bound and no stationary density exists (``grows``). Gains and losses
    of the same top degree (a linear spring with c1 > 0, c2 = 0 and impacts r < 1: both
    ~ A^2) balance by their constants: ``tie``, not decided here (the averaged model decides).
    Derived here from the energy equation above (the sign of the orbit-averaged energy drift
    at large amplitude, as first-order stochastic averaging would give it); docs/edges.md,
    "No stationary density".

    Walls on both sides (issue 37) hold x in [a, b]: x stays bounded while x' ~ A^{n+1}, so
    every damping term ~ A^{2n+2}, the period ~ A^{-(n+1)} and the impacts (1 - e^2) H / T ~
    A^{3n+3}. A wall whose law takes a speed (registry.IMPACT_LAW_PARAMS: "johnson") loses
    (1 - e^2) -> 1 of the energy at high impact speed even with r = 1. Parametric noises
    (``parametric``: the scene's section) feed energy that grows with the amplitude
    (D_k <g(x)^2>, D_c <d(x)^2 x'^2>); they are counted as gains of their degree that never
    decide alone: at or above the top loss they make a ``tie`` (the averaged model decides),
    since a multiplicative noise also spreads the law without making its mean energy grow.
    A parametric tie with a loss of the same degree is then decided by the constants
    (vifpk.core.tail.parametric_tail, wall-free or one wall): the averaged energy's law decays
    as E^-kappa, so it ``grows`` (no stationary law) when kappa <= 1, and holds otherwise
    (``tail``; E[H] is infinite when kappa <= 2). A parametric gain of a degree above every
    loss stays a tie: the law is E^-kappa beyond the crossover energy only, the averaged model
    decides on its grid.
    """
    k = _trim(tuple(system.restoring_law))
    n = max(len(k) - 1, 0)
    walls = tuple(getattr(system, "walls", ()))
    bounded = len(walls) == 2  # both sides: x stays in [a, b]
    paper_k = not getattr(system, "restoring", ())
    paper_d = not getattr(system, "damping", ())
    terms: list[tuple[str, int, int]] = []
    d_law = tuple(system.damping_law)
    for j, c in enumerate(d_law):
        if c != 0.0:
            name = (("system.c1" if j == 0 else "system.c2") if paper_d and j < 2
                    else f"system.damping[{j}]")
            terms.append((name, (2 * n + 2) if bounded else 2 * j + 2 * n + 2,
                          1 if c > 0 else -1))
    for i, c in enumerate(system.velocity_law):
        if c != 0.0:
            terms.append((f"system.velocity_damping[{i}]", (2 * i + 4) * (n + 1),
                          1 if c > 0 else -1))
    if system.mu > 0:
        terms.append(("system.mu", n + 1, 1))
    for w in walls:
        if w.r < 1.0 or "v_yield" in IMPACT_LAW_PARAMS.get(w.law, ()):
            name = "system.r" if getattr(system, "r", None) is not None else (
                f"system.{w.side}_wall")
            terms.append((name, (3 * n + 3) if bounded else 3 * n + 2, 1))
    gains_p: list[tuple[str, int]] = []
    if parametric is not None and getattr(parametric, "stiffness", 0.0) > 0.0:
        gains_p.append(("parametric.stiffness", 0 if bounded else 4 * n + 2))
    if parametric is not None and getattr(parametric, "damping", 0.0) > 0.0:
        top_d = max((j for j, c in enumerate(d_law) if c != 0.0), default=None)
        if top_d is not None:
            gains_p.append(("parametric.damping",
                            (4 * n + 4) if bounded else 4 * top_d + 2 * n + 2))
    spring = (f"system.restoring[{n}]" if not paper_k else
              "system.alpha" if n == 1 else "system.omega0")
    if gains_p and terms:
        top_loss = max(p for _, p, s in terms) if terms else 0
        reach = [nm for nm, p in gains_p if p >= top_loss]
        if reach:
            losses = tuple(nm for nm, p, s in terms if p == top_loss and s > 0)
            tail = parametric_tail(system, parametric)
            if tail is not None:
                return _decided(tail, top_loss, tuple(reach), losses, tuple(terms))
            text = (f"the parametric noise ({', '.join(reach)}) feeds energy that grows with "
                    f"the amplitude as fast as the losses ({', '.join(losses) or 'none'}): "
                    "their constants decide whether the energy is held")
            return EnergyBalance(False, True, top_loss, tuple(reach), losses, tuple(terms),
                                 text)
    if not terms:
        wall = ("system.r = 1" if walls and getattr(system, "r", None) is not None
                else "elastic walls" if walls else "no barrier")
        text = (f"nothing removes energy at large amplitude (no damping law, no "
                f"velocity_damping, system.mu = 0, {wall}): the noise feeds the energy "
                "without bound, so there is no stationary density")
        return EnergyBalance(True, False, 0, (), (), (), text)
    top = max(p for _, p, _ in terms)
    gains = tuple(nm for nm, p, s in terms if p == top and s < 0)
    losses = tuple(nm for nm, p, s in terms if p == top and s > 0)

    def listed(sel: Any) -> str:
        return ", ".join(f"{nm} ~ A^{p}" for nm, p, s in terms if sel(p, s)) or "none"

    if gains and not losses:
        text = (f"at large amplitude A the energy gain of {', '.join(gains)} (power ~ A^{top}"
                f" with the spring's top term {spring}, degree {2 * n + 1}) outgrows every "
                f"loss ({listed(lambda p, s: s > 0)}): the energy grows without bound, so "
                "there is no stationary density")
        return EnergyBalance(True, False, top, gains, (), tuple(terms), text)
    if gains:
        text = (f"at large amplitude A the gain of {', '.join(gains)} and the loss of "
                f"{', '.join(losses)} grow alike (~ A^{top}): their constants decide whether "
                "the energy is held")
        return EnergyBalance(False, True, top, gains, losses, tuple(terms), text)
    text = (f"at large amplitude A the loss of {', '.join(losses)} (~ A^{top}) outgrows the "
            "bounded noise input and every gain")
    return EnergyBalance(False, False, top, (), losses, tuple(terms), text)


def _decided(tail: Tail, degree: int, gains: tuple[str, ...], losses: tuple[str, ...],
             terms: tuple[tuple[str, int, int], ...]) -> EnergyBalance:
    """The verdict of a parametric tie from its tail (vifpk.core.tail)."""
    law = f"the averaged energy's law decays as E^-{tail.kappa:.3g} at large E"
    mean = "" if tail.mean_finite else "; its mean energy is infinite (past mean-square stability)"
    if not tail.top_losses:
        where = (f"beyond E ~ {tail.crossover:.3g}" if tail.crossover
                 else "beyond an energy too small for double precision" if tail.crossover == 0.0
                 else "at large amplitude")
        verdict = ("no stationary law strictly: the law describes the motion below that "
                   "energy (metastable)" if not tail.normalisable else "a stationary law exists")
        text = (f"the parametric noise ({', '.join(gains)}) outgrows every loss {where}: {law}, "
                f"{verdict}{mean}")
        return EnergyBalance(False, True, degree, gains, (), terms, text, tail)
    if not tail.normalisable:
        text = (f"the parametric noise ({', '.join(gains)}) outweighs the losses of the same "
                f"degree ({', '.join(losses)}): {law} (kappa <= 1), so there is no stationary "
                "law")
        return EnergyBalance(True, False, degree, gains, losses, terms, text, tail)
    text = (f"the losses ({', '.join(losses)}) hold the parametric noise ({', '.join(gains)}) "
            f"of the same degree: {law} (kappa > 1){mean}")
    return EnergyBalance(False, False, degree, gains, losses, terms, text, tail)
