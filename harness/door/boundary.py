"""The door's boundary: what a solver's failure becomes when it leaves the door
(:class:`SolverFailure`, the one place exceptions are mapped), and the one BLAS thread every
door call runs with (so results do not depend on the executor). Every door function of
door/solvers.py and door/timedomain.py is a :func:`boundary`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from vifpk.core.guard import PluginError
from vifpk.core.registry import UnknownName
from vifpk.core.result import BadInput


class SolverFailure(RuntimeError):
    """A solver could not produce a trustworthy result; the message says why (one line)."""


#: The solver packages: a RuntimeError raised in one of them is its own failure (FPKFailure,
#: NoStationaryDensity, SimulationDiverged, BudgetExhausted, StartRejected, ...).
SOLVER_PACKAGES = ("vifpk.averaging", "vifpk.fpk", "vifpk.fpk2d", "vifpk.montecarlo")


def solver_failure(exc: BaseException) -> SolverFailure | None:
    """The SolverFailure an exception raised inside a solver call stands for, or None when it
    is not a solver's numerical failure (issue 38: exceptions are mapped here, at the solver
    boundary, and nowhere else; the command line maps SolverFailure to exit 3 and lets
    anything else reach its internal-error branch: exit 1, the traceback under ``--debug``).

    Mapped, a solver's numerical failure only:

    - ArithmeticError: FloatingPointError (numpy errors under ``np.errstate``), overflow,
      division by zero, the FPK's CoefficientError;
    - a RuntimeError of a solver package's own type (FPKFailure, NoStationaryDensity,
      SimulationDiverged, BudgetExhausted, StartRejected, ...);
    - a non-finite result a solver reports as a plain ValueError raised in its own code whose
      message says a value is not finite (montecarlo/averaged_sde.py "drift or diffusion is
      not finite on the table", fpk/passage.py "no positive finite mass"): those solvers have
      no exception type of their own for it yet.

    Not mapped: BadInput (exit 2), UnknownName, PluginError (names the plugin), SolverFailure
    itself, and every other exception, any other ValueError included: a numpy shape error,
    a solver's argument check reached with arguments the request layer should have refused,
    a bug (it used to read "the solver could not produce a result", exit 3)."""
    if isinstance(exc, (SolverFailure, BadInput, UnknownName, PluginError)):
        return None
    if isinstance(exc, ArithmeticError):
        return SolverFailure(f"numerical failure: {exc}; the scene's magnitudes or the step are "
                             "most likely too extreme")
    if isinstance(exc, RuntimeError) and type(exc).__module__.startswith(SOLVER_PACKAGES):
        return SolverFailure(str(exc))
    if type(exc) is ValueError and _raised_in_a_solver(exc) and _says_not_finite(str(exc)):
        return SolverFailure(str(exc))
    return None


#: What a solver's plain ValueError says when a value it computed is not finite.
NOT_FINITE = ("not finite", "no positive finite mass")


def _says_not_finite(text: str) -> bool:
    return any(s in text for s in NOT_FINITE)


def _raised_in_a_solver(exc: BaseException) -> bool:
    """Whether the innermost Python frame of ``exc``'s traceback is a solver package's code
    (its own ``raise``, or a numpy call made there)."""
    tb = exc.__traceback__
    if tb is None:
        return False
    while tb.tb_next is not None:
        tb = tb.tb_next
    return str(tb.tb_frame.f_globals.get("__name__", "")).startswith(SOLVER_PACKAGES)


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """BLAS on one thread for the call (threadpoolctl). Every door call sets it, nested ones
    too (no hidden "already inside the door" state: a nested limit costs ~17 us and restores
    the outer one on exit, measured with threadpoolctl 3.8).

    Why: OpenBLAS cuts a matrix product differently with its thread count, so the closed forms
    (orbit harmonics, phase-space quadratures: ``@`` on (points x nodes) arrays) moved by ~1e-15
    between a serial sweep (2 BLAS threads) and a dask worker (1: dask's nanny sets
    OPENBLAS_NUM_THREADS=1); tests/test_adaptive.py's bit-for-bit comparison of executors
    failed on it. With one thread everywhere the results are the same on every executor; the
    products are small (milliseconds), so nothing is lost."""
    with _blas().limit(limits=1, user_api="blas"):
        yield


@functools.cache
def _blas() -> Any:
    """One threadpoolctl controller a process (finding the libraries costs ~5 ms, a limit
    through it ~20 us), made after scipy.linalg is loaded, so that both BLAS libraries the
    solvers use, numpy's and scipy's, are in it."""
    import scipy.linalg  # noqa: F401 - loads scipy's BLAS before the controller looks
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def boundary(fn: Callable[..., Any]) -> Callable[..., Any]:
    """A door function: a solver's failure inside it leaves as SolverFailure (see
    :func:`solver_failure`), chained to the original for ``--debug``; it runs with BLAS on
    one thread (:func:`one_blas_thread`), so its numbers do not depend on the executor."""

    @functools.wraps(fn)
    def door(*args: Any, **kwargs: Any) -> Any:
        try:
            with one_blas_thread():
                return fn(*args, **kwargs)
        except Exception as exc:
            mapped = solver_failure(exc)
            if mapped is None:
                raise
            raise mapped from exc

    return door
