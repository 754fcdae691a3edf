"""The door's boundary: what a solver's failure becomes when it leaves the door
(:class:`SolverFailure`, the one place exceptions are mapped), and the one BLAS thread every
door call runs with (so results do not depend on the executor). Every door function of
door/solvers.py and door/timedomain.py is a :func:`boundary`.
"""

from __future__ import annotations

import functools
import importlib.machinery
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
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
    """BLAS on one thread for the call (threadpoolctl): every BLAS library loaded in the
    process, numpy's from the start and one loaded during the call from the moment it is.
    Every door call sets it, nested ones too (no hidden "already inside the door" state: a
    nested limit costs ~30 us and restores the outer one on exit, measured with threadpoolctl
    3.8).

    Why: OpenBLAS cuts a matrix product differently with its thread count, so the closed forms
    (orbit harmonics, phase-space quadratures: ``@`` on (points x nodes) arrays) moved by ~1e-15
    between a serial sweep (2 BLAS threads) and a dask worker (1: dask's nanny sets
    OPENBLAS_NUM_THREADS=1); tests/test_adaptive.py's bit-for-bit comparison of executors
    failed on it. With one thread everywhere the results are the same on every executor; the
    products are small (milliseconds), so nothing is lost.

    scipy's BLAS (a wheel carries its own OpenBLAS, apart from numpy's) is loaded by the
    first of scipy's extension modules that links it (scipy.special, scipy.linalg, ...), not
    by ``import scipy``. The guard loads nothing itself: a call that uses no scipy (the
    stationary Monte Carlo: numba and numpy) no longer pays ``import scipy.linalg`` (0.3-0.8 s
    CPU, issue 44). Instead, inside a door call, each extension module loaded is followed by
    a look at the process's mapped files (/proc/self/maps, ~1 ms): a new BLAS among them
    is put on one thread at once, before any code of the call can use it, until the outermost
    door call ends (:class:`_Watch`; tests/test_door_blas.py). Where the loaded objects cannot
    be listed (no /proc/self/maps: not Linux), the guard imports scipy.linalg before it looks,
    as it always did, so scipy's BLAS is in from the first call."""
    with _LOCK:
        if _SCOPES:  # a BLAS that arrived in another thread's call, not yet taken by its
            _arrived()  # _arrived: the outermost scope takes it first (review45)
        scope = ExitStack()
        scope.enter_context(_controller().limit(limits=1, user_api="blas"))
        _SCOPES.append(scope)
        if len(_SCOPES) == 1 and _CTL[1] is not None:
            _Watch.install()
    try:
        yield
    finally:
        with _LOCK:
            _SCOPES.pop().close()  # the limits it set, the latest first
            if not _SCOPES:
                _Watch.remove()


#: the active door scopes, outermost first: each holds the limits it set (the outermost also
#: those of the BLAS libraries loaded inside it, _arrived), undone when it ends
_SCOPES: list[ExitStack] = []
_LOCK = threading.RLock()
#: [the threadpoolctl controller, the loaded BLAS-like objects it was made with (None: they
#: cannot be listed here)]
_CTL: list[Any] = [None, None]
#: what a BLAS library's file name holds (threadpoolctl's prefixes: libopenblas,
#: libscipy_openblas, libblas, libcblas, libflexiblas, libmkl_rt, libblis)
BLAS_NAMES = ("blas", "mkl", "blis")


def _controller() -> Any:
    """The threadpoolctl controller over the BLAS libraries loaded (finding them costs ~7 ms,
    a limit through it ~30 us), made again when a new one is loaded."""
    names = _blas_objects()
    if _CTL[0] is not None and names == _CTL[1]:
        return _CTL[0]
    import numpy  # noqa: F401 - numpy's BLAS, loaded before the controller looks

    if names is None:  # no list of loaded objects: scipy's BLAS loaded before the look
        import scipy.linalg  # noqa: F401
    else:
        names = _blas_objects()
    from threadpoolctl import ThreadpoolController

    _CTL[:] = [ThreadpoolController(), names]
    return _CTL[0]


def _arrived() -> None:
    """After an extension module was loaded inside a door call (_Watch): a BLAS library it
    brought in is put on one thread until the outermost door call ends."""
    with _LOCK:
        if not _SCOPES or _blas_objects() == _CTL[1]:
            return
        known = {lib.filepath for lib in _CTL[0].lib_controllers}
        ctl = _controller()
        new = [lib.filepath for lib in ctl.lib_controllers if lib.filepath not in known]
        if new:
            _SCOPES[0].enter_context(ctl.select(filepath=new).limit(limits=1, user_api="blas"))


#: where the process's mapped files are listed (Linux); elsewhere the guard falls back to
#: importing scipy.linalg first (:func:`_controller`)
MAPS = "/proc/self/maps"


def _blas_objects() -> frozenset[str] | None:
    """The loaded shared objects whose file name says BLAS (BLAS_NAMES), read from the
    process's memory map (MAPS), or None where it cannot be read.

    Not dl_iterate_phdr: it holds the loader's lock while its callback runs, and a Python
    callback may hand the GIL over (every 5 ms) to a thread that then waits for that lock in
    dlopen (an extension module imported) while holding the GIL: a deadlock, seen in `vifpk
    check` (review45 reproduced it with ctypes.PyDLL as well). Reading the map takes no lock
    and runs no Python inside libc (threadpoolctl >= 3.7 reads it for the same reason)."""
    try:
        with open(MAPS, "rb") as maps:
            text = maps.read()
    except OSError:
        return None
    # a line: address perms offset dev inode [pathname]; the pathname may hold spaces
    fields = (line.split(None, 5) for line in text.splitlines())
    names = {f[5] for f in fields if len(f) == 6 and f[5].startswith(b"/")}
    return frozenset(n for n in (x.decode(errors="replace") for x in names)
                     if any(b in n.rsplit("/", 1)[-1].lower() for b in BLAS_NAMES))


class _Watch:
    """A meta path finder, first in sys.meta_path while a door call runs: it finds what the
    finders after it find, and where that is an extension module (whose loading may load a
    shared library: scipy's BLAS comes in so), :func:`_arrived` runs right after the module's
    shared object is loaded."""

    @classmethod
    def install(cls) -> None:
        if cls not in sys.meta_path:
            sys.meta_path.insert(0, cls)  # type: ignore[arg-type]

    @classmethod
    def remove(cls) -> None:
        if cls in sys.meta_path:
            sys.meta_path.remove(cls)  # type: ignore[arg-type]

    @classmethod
    def find_spec(cls, fullname: str, path: Any = None, target: Any = None) -> Any:
        finders = sys.meta_path
        after = finders[finders.index(cls) + 1:] if cls in finders else []
        for finder in after:
            find = getattr(finder, "find_spec", None)
            spec = find(fullname, path, target) if find is not None else None
            if spec is not None:
                break
        else:
            return None
        if isinstance(spec.loader, importlib.machinery.ExtensionFileLoader):
            make = spec.loader.create_module

            def create_module(sp: Any) -> Any:
                module = make(sp)  # the shared object and what it links, loaded
                _arrived()
                return module

            spec.loader.create_module = create_module  # type: ignore[method-assign]
        return spec


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
