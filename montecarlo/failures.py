"""How a Monte Carlo run fails, in one line each: the exceptions of a run that blew up or ran
out of budget, and the words that name the likely cause (the step, or an energy balance that
lets the amplitude grow without bound)."""

from __future__ import annotations

from typing import Any

from vifpk.core.scene import energy_balance


class SimulationDiverged(RuntimeError):
    """The simulation produced a non-finite state, or no sample inside any histogram range.
    The message is one line and names the time step (the usual cause)."""


class BudgetExhausted(RuntimeError):
    """The wall-time budget of a run to a target floor ran out before the first sampling
    window (in the pilots or the burn-in): there is no sample. The message is one line."""


def diverged(h: float, what: str, cause: str = "") -> SimulationDiverged:
    """One line: what blew up, then the likely cause. ``cause``: the scene's large-amplitude
    energy balance when it says the energy may grow without bound (:func:`growth`): that comes
    first, before any advice on the time step."""
    step = (f"try a smaller --dt (e.g. {h / 4:g}) or --dt auto; if a smaller step blows up "
            "too, the amplitude grows without bound and no stationary density exists")
    if cause:
        return SimulationDiverged(f"the Monte Carlo blew up ({what}) at dt = {h:g}: most likely "
                                  f"{cause}; else the time step is too large: {step}")
    return SimulationDiverged(
        f"the Monte Carlo blew up ({what}) at dt = {h:g}: the time step is most likely too "
        f"large for this scene; {step} (negative damping c1 > 0 not held by c2, impacts or "
        "friction)")


def walls_cause(system: Any, h: float) -> str:
    """The words naming two walls closer than a unit-speed path travels in one step h, '' else:
    a path meeting them more than pieces.WALL_HITS_MAX times within a sub-step is stopped
    (non-finite), since its impact rate |v| / gap is beyond what the event-driven step can
    take at any dt."""
    lo, up = getattr(system, "lower_wall", None), getattr(system, "upper_wall", None)
    if lo is None or up is None:
        return ""
    gap = float(up.at) - float(lo.at)
    if not gap < h:
        return ""
    return (f"the walls at {float(lo.at):g} and {float(up.at):g} are {gap:g} apart: a path "
            "meets them more than 10000 times in one step there, an impact rate no "
            "simulation resolves at any dt; allowed: walls farther apart")


def growth(system: Any, parametric: Any = None) -> str:
    """'' when the losses win the large-amplitude energy balance (vifpk.core.scene.
    energy_balance, with the parametric noise), else the words of why the energy may grow."""
    if not hasattr(system, "restoring_law"):  # a duck-typed system with the paper's names
        return ""
    bal = energy_balance(system, parametric)
    if bal.grows:
        return f"the energy grows without bound ({bal.text})"
    if bal.tail is not None and not bal.tie and not bal.tail.mean_finite:
        return f"the parametric noise: {bal.text}"
    if bal.tie:
        return (f"the energy grows without bound: {bal.text}, and here the gain may win (no "
                "stationary density)")
    return ""


def likely_cause(system: Any, parametric: Any, h: float) -> str:
    """What a blow-up at step h most likely comes from, before any advice on the step: walls
    too close for any step (:func:`walls_cause`), else the energy balance (:func:`growth`)."""
    return walls_cause(system, h) or growth(system, parametric)
