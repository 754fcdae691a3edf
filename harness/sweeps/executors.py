"""Executors of a sweep's points: ``serial``; ``processes:N`` (concurrent.futures, numba
threads per worker = cores // N); ``dask:N`` (a dask.distributed LocalCluster of N workers);
``tcp://HOST:PORT`` (a running dask scheduler). dask's futures carry the points, and dask
reschedules a point whose worker died; the records are written by the process that runs the
sweep, once per point.
"""

from __future__ import annotations

import importlib
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from vifpk.harness.sweeps.errors import SweepError, WorkerLost
from vifpk.harness.sweeps.points import Job, run_point

EXTRA_HINT = "pip install 'vifpk[cluster]'"


# --------------------------------------------------------------------------------------------
# executors
@dataclass(frozen=True, kw_only=True)
class ExecutorSpec:
    kind: str  # serial | processes | dask | tcp
    workers: int = 1
    address: str = ""

    def __str__(self) -> str:
        return {"serial": "serial", "processes": f"processes:{self.workers}",
                "dask": f"dask:{self.workers}"}.get(self.kind, self.address)


def parse_executor(text: str) -> ExecutorSpec:
    """``serial`` | ``processes:N`` | ``dask:N`` | ``tcp://HOST:PORT`` (SweepError if not)."""
    allowed = "allowed: serial, processes:N, dask:N, tcp://HOST:PORT"
    if text == "serial":
        return ExecutorSpec(kind="serial")
    kind, sep, rest = text.partition(":")
    if kind in ("processes", "dask") and sep:
        cores = os.cpu_count() or 1
        if not rest.isdigit() or not 1 <= int(rest) <= cores:
            # a local pool of more workers than cores only splits the same cores (each worker
            # runs numba on cores // N threads, at least one)
            raise SweepError(f"--executor {text}: N must be a whole number from 1 to the "
                             f"{cores} cores of this machine (a larger cluster: tcp://HOST:PORT)"
                             f"; {allowed}")
        spec = ExecutorSpec(kind=kind, workers=int(rest))
    elif kind == "tcp" and rest.startswith("//"):
        from urllib.parse import urlsplit

        where = urlsplit(text)
        try:
            port = where.port
        except ValueError:  # not a number, or out of range
            port = None
        if not where.hostname or port is None or not 1 <= port <= 65535 or where.path \
                or where.query or where.fragment:
            raise SweepError(f"--executor {text}: expected tcp://HOST:PORT with PORT in "
                             "1-65535 (an IPv6 host in brackets: tcp://[::1]:8786)")
        spec = ExecutorSpec(kind="tcp", address=text)
    else:
        raise SweepError(f"--executor {text}: unknown executor; {allowed}")
    if spec.kind in ("dask", "tcp"):
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise SweepError(f"--executor {text}: dask.distributed is not installed; install "
                             f"the 'cluster' extra: {EXTRA_HINT}") from None
    return spec


#: the `sweep` extra's libraries, by the module name each is imported as
SWEEP_LIBRARIES = {"xarray": "xarray", "netCDF4": "netCDF4", "sklearn": "scikit-learn"}


def require_output_libraries(*, surface: bool = False) -> None:
    """sweep.nc needs xarray and netCDF4, an error surface (a band sweep, the surface maps)
    scikit-learn too (dependencies of vifpk; the `sweep` extra names them for old install
    lines): say which are missing before any work. Each is
    imported, not only found: a library that is there but fails to import (a broken
    dependency of its own) is named with the reason."""
    wanted = [m for m in SWEEP_LIBRARIES if surface or m != "sklearn"]
    missing = []
    for module in wanted:
        try:
            importlib.import_module(module)
        except ImportError as exc:
            why = "" if exc.name == module else f": {exc}"
            missing.append(f"{SWEEP_LIBRARIES[module]}{why}")
    if missing:
        need = "sweep.nc and its error surface need" if surface else "sweep.nc needs"
        raise SweepError(f"{need} {', '.join(SWEEP_LIBRARIES[m] for m in wanted)} "
                         f"({'; '.join(missing)} missing): they are vifpk's dependencies; "
                         "install them: pip install "
                         + " ".join(SWEEP_LIBRARIES[m] for m in wanted))


def threads_per_worker(workers: int) -> int:
    """numba threads for each of ``workers`` local workers: cores // workers (at least 1)."""
    return max((os.cpu_count() or 1) // workers, 1)


def _die_with_parent() -> None:
    """Linux: this process gets SIGKILL when the process that started it dies, however it
    dies (SIGKILL included): no worker outlives its sweep (prctl PR_SET_PDEATHSIG)."""
    if not sys.platform.startswith("linux"):
        return
    import ctypes
    import signal

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL), 0, 0, 0)  # 1: SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() == 1:  # the parent died before the call: follow it now
        os._exit(1)


def _init_worker(threads: int) -> None:
    """Process-pool initializer: die with the sweep (:func:`_die_with_parent`); Ctrl-C on
    the terminal's process group is the sweep's to handle (it stops the workers), so the
    worker ignores SIGINT; numba threads per worker (before numba is imported)."""
    import signal

    _die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ["NUMBA_NUM_THREADS"] = str(threads)
    if "numba" in sys.modules:
        import numba

        numba.config.NUMBA_NUM_THREADS = threads
        numba.set_num_threads(threads)


def dask_setup(worker: Any = None) -> None:
    """dask preload of a local cluster's workers (``preload=["vifpk.harness.sweeps.executors"]``):
    Ctrl-C on the terminal's process group is the sweep's to handle; the worker ignores it."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextmanager
def _signals_blocked() -> Iterator[None]:
    """SIGINT blocked in this thread while local workers are started: they inherit the mask
    (fork and exec keep it), so Ctrl-C on the terminal's process group reaches only the
    sweep, which stops them (:meth:`Runner.stop`); a Ctrl-C meanwhile waits, then arrives."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


class Runner:
    """An open executor: ``completed(jobs)`` yields records as points finish."""

    def __init__(self, spec: ExecutorSpec, *, connect_timeout: float = 10.0):
        self.spec = spec
        self.stopped = False
        self.client: Any = None
        self.cluster: Any = None
        self.pool: Any = None
        if spec.kind == "processes":
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            self.pool = ProcessPoolExecutor(
                max_workers=spec.workers, mp_context=multiprocessing.get_context("spawn"),
                initializer=_init_worker, initargs=(threads_per_worker(spec.workers),))
        elif spec.kind == "dask":
            from distributed import Client, LocalCluster

            threads = threads_per_worker(spec.workers)
            import logging

            with _signals_blocked():  # Ctrl-C is the sweep's to handle, not the workers'
                self.cluster = LocalCluster(
                    n_workers=spec.workers, threads_per_worker=1, processes=True,
                    # any free port for its HTTP server: two clusters on one machine do not
                    # collide on 8787 (and warn about it)
                    dashboard_address=":0", host="127.0.0.1", silence_logs=logging.ERROR,
                    env={"NUMBA_NUM_THREADS": str(threads)},
                    preload=["vifpk.harness.sweeps.executors"])
            self.client = Client(self.cluster)
        elif spec.kind == "tcp":
            import socket
            from urllib.parse import urlsplit

            from distributed import Client

            try:
                # a plain TCP probe first: a refused connection is known at once, whereas
                # dask's Client retries it until its timeout runs out
                where = urlsplit(spec.address)
                socket.create_connection((where.hostname, where.port),
                                         timeout=connect_timeout).close()
                self.client = Client(spec.address, timeout=connect_timeout)
            except (OSError, TimeoutError, ValueError) as exc:
                raise SweepError(f"--executor {spec.address}: no dask scheduler answers there "
                                 f"({type(exc).__name__}); start one with `dask scheduler` "
                                 "and workers with `dask worker ADDRESS`") from None

    @property
    def workers(self) -> int:
        if self.client is not None:
            return max(len(self.client.scheduler_info().get("workers", {})), 1)
        return self.spec.workers

    def completed(self, jobs: list[Job], *, retries: int = 2) -> Iterator[dict[str, Any]]:
        """Records in the order the points finish. A worker that dies takes no point with it:
        dask reschedules the point elsewhere; a broken process pool raises WorkerLost."""
        if self.spec.kind == "serial":
            for job in jobs:
                yield run_point(job)
        elif self.pool is not None:
            from concurrent.futures import as_completed
            from concurrent.futures.process import BrokenProcessPool

            with _signals_blocked():  # the pool starts its workers here
                futs = [self.pool.submit(run_point, job) for job in jobs]
            try:
                for f in as_completed(futs):
                    yield f.result()
            except BrokenProcessPool as exc:
                raise WorkerLost(f"a worker process died ({exc})") from None
            finally:
                for f in futs:
                    f.cancel()
        else:
            from distributed import as_completed

            # one dask key per point and fingerprint: dask never runs a key twice at once,
            # reschedules it when its worker dies, and retries it on an exception
            futs = [self.client.submit(run_point, job, key=f"vifpk-{job.key}-"
                                       f"{job.fingerprint[:12]}", retries=retries, pure=False)
                    for job in jobs]
            from distributed import KilledWorker

            try:
                for f in as_completed(futs):
                    yield f.result()
            except KilledWorker as exc:
                raise WorkerLost(f"dask gave up on a point whose workers kept dying ({exc})"
                                 ) from None
            finally:
                self.client.cancel([f for f in futs if not f.done()])

    def stop(self) -> None:
        """Stop at once (Ctrl-C, SIGTERM): cancel what is queued and end the pool's worker
        processes (ProcessPoolExecutor.terminate_workers from Python 3.14, done the same way
        before it); dask's workers are ended by :meth:`close` (and die with this process)."""
        pool = self.pool
        if pool is None:
            return
        self.stopped = True
        procs = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        if hasattr(pool, "terminate_workers"):
            pool.terminate_workers()
        else:
            for proc in procs:
                try:
                    proc.terminate()
                except (OSError, ValueError, AttributeError):
                    pass
        for proc in procs:  # reap them: gone before this process says it stopped
            proc.join(timeout=1.0)

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=not self.stopped, cancel_futures=True)
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()
