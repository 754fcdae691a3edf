"""Output folders written as a unit, and held by one run at a time.

A report folder ``DIR`` is never updated file by file. A run

1. takes the folder's lock ``.DIR.lock`` beside ``DIR`` (an ``flock`` on a file that names the
   holder's pid and run id): a second run into the same folder is refused with a message naming
   the holder; a lock file whose holder died is stale (the kernel dropped its ``flock``) and is
   taken over;
2. removes what killed runs left beside ``DIR`` (``.DIR.partial-*``, ``.DIR.old-*``; with the
   lock held nobody else can be writing them);
3. builds the whole new set in ``.DIR.partial-<run id>`` beside ``DIR`` (same file system);
4. swaps it in with **one** rename: on Linux ``renameat2(RENAME_EXCHANGE)`` exchanges the two
   folders atomically (``DIR`` is at every instant the complete old set or the complete new
   set), then the old set, now at the partial path, is deleted. Where the exchange is not
   available (other systems, file systems without it) the fallback is ``DIR -> .DIR.old-<id>``,
   ``.DIR.partial-<id> -> DIR``: between the two renames ``DIR`` is briefly absent (never a
   mix), and the next run that finds ``DIR`` absent beside an ``.DIR.old-*`` renames it back
   before anything else. A folder that does not exist yet is created by the single rename.

``DIR`` stays a real directory (no symlink), so ``rm -r DIR``, ``cp -r`` and archive tools work
as before. Only a folder that is empty or looks like an earlier output of the same kind (its
entries a subset of the allowed names) is replaced: ``--out ~`` must not delete a home folder.

Every file is created with ``open``/``mkdir`` defaults, so modes follow the umask (0644/0755
under the usual umask 022), unlike ``tempfile`` (0600/0700).
"""

from __future__ import annotations

import ctypes
import errno
import json
import os
import shutil
import socket
import sys
from collections.abc import Callable, Collection, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from vifpk.core.result import BadInput

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX
    fcntl = None  # type: ignore[assignment]

_RENAME_EXCHANGE = 2
_AT_FDCWD = -100
_held: dict[Path, int] = {}  # folders this process holds -> lock fd (re-entrant holding)


class FolderBusy(BadInput):
    """Another live run holds the output folder (exit 2: choose another ``--out`` or wait)."""


class FolderRefused(BadInput):
    """The output path cannot be replaced: a file, or a folder holding other things."""


def _hook(moment: str) -> None:
    """Test hook: with ``VIFPK_TEST_PAUSE=<moment>`` the writing stops at that moment until the
    file named by ``VIFPK_TEST_PAUSE_FILE`` exists (kill tests SIGKILL the process there)."""
    if os.environ.get("VIFPK_TEST_PAUSE") != moment:
        return
    import time

    flag = os.environ.get("VIFPK_TEST_PAUSE_FILE", "")
    Path(flag + ".reached").write_text(str(os.getpid()))
    while not Path(flag).exists():
        time.sleep(0.01)


def lock_path(folder: str | Path) -> Path:
    folder = Path(folder)
    return folder.parent / f".{folder.name}.lock"


def resolve(folder: str | Path) -> Path:
    p = Path(folder).expanduser()
    return p.parent.resolve() / p.name if p.name not in ("", ".", "..") else p.resolve()


def _holder(fd: int) -> dict[str, Any]:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        return json.loads(os.read(fd, 4096).decode("utf-8") or "{}")
    except (OSError, ValueError):
        return {}


@contextmanager
def hold(folder: str | Path, *, run_id: str = "", allowed: Collection[str] | None = None,
         kind: str | None = None) -> Iterator[Path]:
    """Hold ``folder`` for this run: refuse if another live run holds it, take over a stale
    lock, clear what killed runs left, and check that the folder may be replaced.

    ``kind`` (a key of :data:`KINDS`): a non-empty folder must hold that kind of output.
    Yields the resolved folder path. Re-entrant within one process. The folder's
    replaceability is checked before the lock (a refusal leaves no lock file) and again under
    it, after the recovery (the folder a killed run's leftovers restore is the one that will be
    replaced). The lock file is removed on exit, and by the interrupt watchdog
    (harness/outputs/signals.py) when Ctrl-C or SIGTERM force an exit; a run killed with
    SIGKILL leaves the file, which the next run finds stale.
    """
    from vifpk.harness.outputs import signals

    target = resolve(folder)
    if target in _held:
        yield target
        return
    check_replaceable(target, allowed, kind)  # early: a refusal creates no lock file
    made_parent = not target.parent.exists()
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise FolderRefused(f"{folder}: cannot create its parent folder ({exc.strerror})"
                            ) from None
    # the lock's state lives in ``box`` from the moment its file is opened, and the lines
    # that open, lock and record it are a critical section (a signal inside it is raised
    # when it ends): the cleanup below always finds what to undo (a SIGHUP that landed
    # between the file's creation and its recording left an empty .DIR.lock)
    box: dict[str, Any] = {}

    def emergency() -> None:  # the watchdog's forced exit: leave no lock, no partial set
        shutil.rmtree(target.parent / f".{target.name}.partial-{run_id}", ignore_errors=True)
        if box.get("locked"):
            lock_path(target).unlink(missing_ok=True)

    handle = signals.on_interrupt(emergency)
    try:
        with signals.deferred():
            _acquire(target, run_id, box)
            _held[target] = box["fd"]
        recover(target)
        # again under the lock, on what recovery restored: a run killed between its two
        # renames left DIR absent and its old set at .DIR.old-*, which the check above could
        # not see (a sweep's folder restored here must not be replaced by a check report)
        check_replaceable(target, allowed, kind)
        yield target
    finally:
        signals.forget(handle)
        _held.pop(target, None)
        _release(target, box)
        if made_parent and not target.exists():
            try:
                target.parent.rmdir()  # nothing was written: leave no empty parent behind
            except OSError:
                pass


def _release(target: Path, box: dict[str, Any]) -> None:
    """Undo what ``_acquire`` got into ``box``: the lock file removed while still locked (a
    waiter that opened it retries on the new file), or, never locked, removed if this run
    created it; the descriptor closed."""
    fd = box.pop("fd", None)
    if fd is None:
        return
    if box.get("locked") or box.get("created"):
        lock_path(target).unlink(missing_ok=True)
    os.close(fd)


def _acquire(target: Path, run_id: str, box: dict[str, Any]) -> None:
    """Take the folder's lock into ``box`` (``fd``; ``created`` once this run made the file,
    ``locked`` once it holds the flock), so a cleanup interrupted at any point knows what to
    undo; refuse if a live run holds it."""
    lp = lock_path(target)
    while True:
        box.pop("created", None)
        try:
            try:
                box["fd"] = os.open(lp, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o666)
                box["created"] = True
            except FileExistsError:
                box["fd"] = os.open(lp, os.O_RDWR)
        except FileNotFoundError:
            continue  # its holder removed it between the two opens: try again
        except OSError as exc:
            raise FolderRefused(f"{target}: cannot create the lock file {lp.name} beside it "
                                f"({exc.strerror})") from None
        fd = box["fd"]
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                h = _holder(fd)
                box.pop("created", None)  # a live run's file: never ours to remove
                os.close(box.pop("fd"))
                who = f"pid {h['pid']}" if "pid" in h else "pid unknown"
                if h.get("run_id"):
                    who += f", run {h['run_id']}"
                raise FolderBusy(f"{target}: another vifpk run is writing this folder ({who}); "
                                 "wait for it to finish or choose another --out") from None
        # the holder before us may have unlinked the file we opened: lock the current one
        try:
            same = os.path.samestat(os.fstat(fd), os.stat(lp))
        except FileNotFoundError:
            same = False
        if not same:
            box.pop("created", None)  # that file is gone or replaced: not ours to remove
            os.close(box.pop("fd"))
            continue
        box["locked"] = True
        stale = _holder(fd)
        if stale.get("pid"):
            print(f"vifpk: note: {lp} was left by pid {stale['pid']}"
                  + (f" (run {stale['run_id']})" if stale.get("run_id") else "")
                  + ", which ended without releasing it; taking it over", file=sys.stderr)
        os.ftruncate(fd, 0)
        os.lseek(fd, 0, os.SEEK_SET)
        os.write(fd, (json.dumps({"pid": os.getpid(), "run_id": run_id,
                                  "host": socket.gethostname()}) + "\n").encode())
        return


#: the outputs vifpk writes into a folder, each told by the entries it always holds (any one)
KINDS = {"passage report": ("passage.npz",), "transient report": ("transient.npz",),
         "check report": ("metrics.json",), "sweep": ("points", "sweep.nc"),
         "work-precision run": ("workprecision.json",), "figures": ("figures.json",)}


def _temporary(name: str) -> bool:
    """A temporary file of an atomic write (vifpk/core/io.py: ``.NAME.<hex>.tmp<suffix>``)."""
    return name.startswith(".") and ".tmp" in name


def kind_of(names: Collection[str]) -> str | None:
    """The kind of output a folder holding ``names`` is, or None."""
    for kind, marks in KINDS.items():
        if any(m in names for m in marks):
            return kind
    return None


def check_replaceable(target: Path, allowed: Collection[str] | None,
                      kind: str | None = None) -> None:
    """Refuse a path that is a file, a folder holding entries an output never writes, or a
    non-empty folder that is not an earlier output of ``kind`` (a sweep folder and a report
    folder are told apart: neither replaces the other)."""
    if target.is_symlink() or (target.exists() and not target.is_dir()):
        raise FolderRefused(f"{target}: exists and is not a folder; choose a folder path")
    if allowed is None or not target.is_dir():
        return
    try:
        names = [n for n in os.listdir(target)
                 if not n.startswith(".partial-") and not _temporary(n)]
    except OSError as exc:
        raise FolderRefused(f"{target}: cannot read it ({exc.strerror})") from None
    found = kind_of(names)
    if kind is not None and names and found != kind:
        what = f"is a {found} folder" if found else "does not hold an earlier " + kind
        raise FolderRefused(f"{target}: {what} ({', '.join(sorted(names)[:3])}"
                            + (", ..." if len(names) > 3 else "") + f"); a {kind} is written "
                            "only into a new or empty folder or an earlier one of its own; "
                            "choose another --out")
    foreign = sorted(n for n in names if n not in allowed)
    if foreign:
        raise FolderRefused(f"{target}: holds files this command does not write ("
                            + ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
                            + "), which replacing the folder would delete; choose a new or "
                              "empty folder")


def _siblings(target: Path, kind: str) -> list[Path]:
    prefix = f".{target.name}.{kind}-"
    try:
        return sorted(p for p in target.parent.iterdir() if p.name.startswith(prefix))
    except FileNotFoundError:
        return []


def recover(target: Path) -> None:
    """Undo what a killed run left (call with the lock held): restore an old set whose swap
    was cut between its two renames, and delete partial and old sets."""
    olds = _siblings(target, "old")
    if olds and not target.exists():
        os.rename(olds[-1], target)
        olds = olds[:-1]
    for p in olds + _siblings(target, "partial"):
        shutil.rmtree(p, ignore_errors=True)


def _fsync_tree(root: Path) -> None:
    for dirpath, _dirs, files in os.walk(root):
        for name in files:
            fd = os.open(os.path.join(dirpath, name), os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        fd = os.open(dirpath, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _exchange(a: Path, b: Path) -> bool:
    """Atomically exchange two paths (Linux renameat2); False where that is not available."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        fn = libc.renameat2
    except (OSError, AttributeError):
        return False
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    if fn(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(err, os.strerror(err), str(b))


def swap_in(new: Path, target: Path, *, run_id: str) -> None:
    """Make the complete folder ``new`` the folder ``target`` (see the module docstring)."""
    _fsync_tree(new)
    _hook("before-swap")
    if not target.exists():
        os.rename(new, target)
    elif _exchange(new, target):
        _hook("after-swap")
        shutil.rmtree(new, ignore_errors=True)  # the old set, now at the partial path
    else:
        old = target.parent / f".{target.name}.old-{run_id}"
        os.rename(target, old)
        _hook("between-renames")
        os.rename(new, target)
        shutil.rmtree(old, ignore_errors=True)
    fd = os.open(target.parent, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_folder(folder: str | Path, fill: Callable[[Path], Any], *, run_id: str,
                 allowed: Collection[str] | None = None) -> Path:
    """Write a whole output folder as a unit: ``fill(tmp)`` writes every file into a fresh
    folder beside ``folder``, which then replaces ``folder`` in one step. Returns the folder."""
    with hold(folder, run_id=run_id, allowed=allowed) as target:
        tmp = target.parent / f".{target.name}.partial-{run_id}"
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir()
        try:
            fill(tmp)
            swap_in(tmp, target, run_id=run_id)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return target
