"""One result type for every solver, the status it ends in, and warnings as records.

``Result(data, info)``: ``data`` maps an observable to a density record ``{"x", "p"}`` (a
Monte Carlo histogram adds ``"edges"``, ``"err"``); ``info`` holds settings, timings,
diagnostics and ``info["status"]``, the JSON form of a :class:`Status` (``Status.record``).

:class:`Status` members carry their message (as diffrax's ``RESULTS`` do), so the words of an
outcome are written once and code asks ``status.ok`` instead of reading sentences.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Any, NamedTuple


class BadInput(ValueError):
    """Input that cannot be used (a scene field, an option, an output folder): the message is
    one line naming it and what is allowed; the command line exits with code 2."""


class CostRefused(BadInput):
    """A run refused for its price once a measured quantity (the relaxation time behind an
    automatic burn-in) shows it costs more than its caller allowed (a plain limit, e.g.
    montecarlo.Settings.max_path_steps). A cost refusal like the up-front guard's: the
    command line exits with code 2. The numbers travel with it, so the caller can word the
    price and its ways out."""

    def __init__(self, message: str, **numbers: float) -> None:
        super().__init__(message)
        self.numbers = numbers


@dataclass(frozen=True, kw_only=True)
class Resolved:
    """What a simulation resolved from its settings (issue 38): the step ``dt`` ("auto" made a
    number), the ``burn_in`` ("auto" made a time), the sampled ``time``, ``paths``, ``blocks``
    and ``sample_every`` it ran with. A workflow that continues or repeats a run reads these
    typed fields, never a setting out of ``info`` (which keeps them for the JSON record)."""

    dt: float
    burn_in: float
    time: float
    paths: int
    blocks: int
    sample_every: float


class Result(NamedTuple):
    """A solver's output: densities by observable, what the run did (``info``), and for a
    simulation what it resolved (``resolved``: typed; None for a closed form or a grid)."""

    data: dict[str, dict[str, Any]]
    info: dict[str, Any]
    resolved: Resolved | None = None


class Status(Enum):
    """How a solver run ended: ``code`` (a stable word), ``message`` (for people), ``ok`` (the
    numbers asked for exist and may be used as what they say they are).

    Set where the outcome is decided: ``CENSORED`` by the first passage of the original system
    (montecarlo/passage.py) and of the averaged SDE (montecarlo/sde_time.py) when paths reach
    the horizon without passing (the mean is then a restricted mean, ``info["censored"]`` says
    how many); ``NOT_EQUILIBRATED`` and ``STOPPED`` by the stationary Monte Carlo
    (montecarlo/assemble.py) when its equilibration certificate fails
    (``info["convergence"]["equilibrated"]`` False) or its budget ends the run before the
    target floor (``info["convergence"]["reached"]`` False); ``TIMED_OUT`` by the averaged SDE's
    splitting (montecarlo/splitting.py) when AMS runs reach their time limit. Outcomes that
    leave no numbers stay exceptions, mapped to exit 3 at the door: a diverged simulation
    (``SimulationDiverged``) and a budget spent before the first sampled window
    (``BudgetExhausted``, montecarlo/failures.py)."""

    DENSITY = ("density", "stationary density computed", True)
    SNAPSHOTS = ("snapshots", "transient snapshots computed", True)
    SIMULATED = ("simulated", "simulated", True)
    PASSAGE = ("passage", "first passage computed", True)
    CENSORED = ("censored", "simulated; some paths did not pass within the horizon (censored): "
                "the mean first-passage time is a restricted mean", True)
    NOT_EQUILIBRATED = ("not_equilibrated", "simulated; the equilibration certificate failed: "
                        "the densities may still carry the start", True)
    STOPPED = ("stopped", "simulated; the budget ended the run before its target noise floor",
               True)
    TIMED_OUT = ("timed_out", "some splitting runs reached their time limit before the "
                 "threshold or the low level: the estimate is biased low", False)
    NOT_FINITE = ("not_finite", "density is negative or not finite", False)

    def __init__(self, code: str, message: str, ok: bool):
        self.code, self.message, self.ok = code, message, ok

    def record(self, detail: str = "") -> dict[str, Any]:
        """The JSON form stored as ``info["status"]``: ``{"ok", "message", "code"}``."""
        message = f"{self.message} ({detail})" if detail else self.message
        return {"ok": self.ok, "message": message, "code": self.code}


@dataclass(frozen=True)
class WarningRecord:
    """A warning a workflow raises about its result: a stable ``kind`` (what code acts on)
    and a ``text`` (what people read). ``str()`` is the text."""

    kind: str
    text: str

    def __str__(self) -> str:
        return self.text

    @property
    def title(self) -> str:
        """The kind in words ("strong_damping" -> "strong damping")."""
        return self.kind.replace("_", " ")
