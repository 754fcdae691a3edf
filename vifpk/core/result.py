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

    Set where the outcome is decided: ``CENSORED`` by the averaged SDE's first passage
    (montecarlo/sde_time.py) when paths reach the horizon without passing (its mean is then a
    restricted mean, ``info["censored"]`` says how many). Not yet members (issue 38): a
    diverged simulation and a budget spent before the first sampled window are the exceptions
    ``SimulationDiverged`` and ``BudgetExhausted`` (exit 3, montecarlo/simulate.py); a budget
    that stops a run short of its floor is ``info["convergence"]["stopped"]``; an equilibration
    that fails is ``info["convergence"]["equilibrated"]`` (montecarlo/certificate.py); the original
    system's censored paths are ``info["censored"]`` (montecarlo/passage.py)."""

    DENSITY = ("density", "stationary density computed", True)
    SNAPSHOTS = ("snapshots", "transient snapshots computed", True)
    SIMULATED = ("simulated", "simulated", True)
    PASSAGE = ("passage", "first passage computed", True)
    CENSORED = ("censored", "simulated; some paths did not pass within the horizon (censored): "
                "the mean first-passage time is a restricted mean", True)
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
