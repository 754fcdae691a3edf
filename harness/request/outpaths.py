"""Output paths checked before any work (issue 11; split from validate.py): a file option
must not name a directory, a folder option must not name a file, names and whole paths within
the file system's limits, the nearest existing folder must accept a new file (probed with a
temporary file that is removed at once, the way the atomic writers create theirs), and no
output may replace one of the run's own inputs. Each problem raises :class:`InputError` in
one line naming the option."""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from vifpk.harness.request.errors import InputError

# --------------------------------------------------------------------------------------------
# output paths
NAME_BYTES = 200  # one file or folder name; the writers add hidden siblings beside it


#                  (".NAME.partial-<run id>", ".NAME.<hex>.tmp") within the usual 255-byte limit
PATH_BYTES = 3800  # a whole path, below the usual 4096 with room for those siblings


def _short(path: Any) -> str:
    text = str(path)
    return text if len(text) <= 80 else text[:60] + "..." + text[-12:]


def _lengths(path: Path, option: str) -> None:
    """Every name in the path within NAME_BYTES, the whole path within PATH_BYTES."""
    for part in path.parts:
        n = len(os.fsencode(part))
        if n > NAME_BYTES:
            raise InputError(f"{option} {_short(path)}: a name in the path is {n} bytes long; "
                             f"allowed: up to {NAME_BYTES} bytes per name")
    n = len(os.fsencode(str(path.absolute())))
    if n > PATH_BYTES:
        raise InputError(f"{option} {_short(path)}: the path is {n} bytes long; allowed: up "
                         f"to {PATH_BYTES} bytes")


def _nearest_existing(path: Path) -> Path:
    p = path.absolute()
    while not p.exists():
        p = p.parent
    return p


def _probe(folder: Path, option: str, path: Path) -> None:
    """A temporary file in ``folder``, removed at once: can the run write there?"""
    if not folder.is_dir():
        raise InputError(f"{option} {_short(path)}: {folder} is not a folder")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".vifpk-probe-", dir=folder)
    except OSError as exc:
        raise InputError(f"{option} {_short(path)}: cannot write in {folder} "
                         f"({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(tmp)


STDOUT = "-"  # a file option's name for the standard output (--json -)


def output_file(path: str | None, option: str) -> None:
    """A file the run will write as a unit (a temporary file beside it, then a rename): a
    regular file or a new name, never a folder, a device, a pipe or a symbolic link (the
    rename would replace the link, e.g. /dev/stdout, instead of writing through it). "-" is
    the standard output (:data:`STDOUT`), written whole at the end."""
    if path is None or path == STDOUT:
        return
    p = Path(path)
    _lengths(p, option)
    if path.endswith(("/", os.sep)):
        raise InputError(f"{option} {path}: ends with a folder separator; give a file name")
    if p.is_symlink():
        raise InputError(f"{option} {_short(path)}: is a symbolic link; give the real file "
                         "path (outputs are written as a temporary file renamed over the name)")
    if p.is_dir():
        raise InputError(f"{option} {path}: is a folder; give a file name")
    if p.exists() and not p.is_file():
        raise InputError(f"{option} {path}: is not a regular file (a device or a pipe); give "
                         "a file name (outputs are written as a unit, then renamed)")
    if p.name in ("", ".", ".."):
        raise InputError(f"{option} {path}: give a file name")
    _probe(_nearest_existing(p.parent), option, p)


def output_folder(path: str | None, option: str, *, replaced: bool = False) -> None:
    """A folder the run will write files into (created if missing). ``replaced``: the run
    swaps the whole folder in at its end, so it must not be the current folder or one that
    holds it (the shell would be left in a deleted folder)."""
    if path is None:
        return
    p = Path(path)
    _lengths(p, option)
    if p.exists() and not p.is_dir():
        raise InputError(f"{option} {path}: exists and is not a folder; give a folder")
    if p.is_symlink():
        raise InputError(f"{option} {path}: is a symbolic link; give the real folder path")
    if replaced:
        here = Path.cwd().resolve()
        full = p.expanduser().resolve()
        if full == here or full in here.parents:
            raise InputError(f"{option} {path}: is the current folder (or holds it); the "
                             "output folder is replaced as a unit at the end, which would "
                             "pull it from under the shell; give a new subfolder, e.g. "
                             f"{option.split()[0]} out")
    _probe(_nearest_existing(p), option, p)


def run_inputs(args: Any, extra: Iterable[tuple[str, Path]] = ()) -> list[tuple[str, Path]]:
    """(what, resolved path) of every file a command reads: its scene file (a shipped one too:
    in a source checkout it is a file of the repository), ``extra`` (a sweep's files, as the
    sweep loader resolved them: harness.sweeps.spec.inputs), and the source of every
    registered model plugin that can be found without importing it."""
    from vifpk.core import registry
    from vifpk.core.guard import source_of
    from vifpk.core.scene import find_scene

    found: list[tuple[str, Path]] = []

    def add(what: str, p: Any) -> None:
        if isinstance(p, Path) and p.is_file():
            found.append((what, p.resolve()))

    scene = getattr(args, "scene", None)
    if isinstance(scene, str):
        with contextlib.suppress(OSError, ValueError):
            add("the scene file", find_scene(scene))
    for what, p in extra:
        add(what, p)
    for entry in registry.models():
        if entry.distribution == registry.DISTRIBUTION:
            continue
        src = source_of(entry.value.split(":")[0].strip())  # no plugin code runs (guard.py)
        if src is not None:
            add(f"the source of model plugin {entry.name!r}", Path(src))
    return found


def outputs_apart_from_inputs(args: Any, *, replaced: bool, names: Iterable[str] = (),
                              extra: Iterable[tuple[str, Path]] = ()) -> None:
    """No output overwrites what the run reads: ``--json`` is not an input file; an ``--out``
    folder the run replaces as a unit (``replaced``) holds no input; one it writes into holds
    no input under one of the ``names`` it writes. ``extra``: more files the run reads (see
    :func:`run_inputs`). One line, exit 2, before any work."""
    inputs = run_inputs(args, extra)
    json_out = getattr(args, "json", None)
    if isinstance(json_out, str):
        target = Path(json_out).expanduser().resolve()
        for what, p in inputs:
            if target == p or target.is_file() and os.path.samefile(target, p):  # hard links
                raise InputError(f"--json {json_out}: is {what} this run reads; give "
                                 "another file name (the output would replace it)")
    out = getattr(args, "out", None)
    if isinstance(out, str):
        folder = Path(out).expanduser().resolve()
        for what, p in inputs:
            inside = folder in p.parents
            if inside and (replaced or any(p == folder / n or folder / n in p.parents
                                           for n in names)):
                raise InputError(f"--out {out}: holds {what} ({_short(p)}), which the run "
                                 f"would {'replace with the folder' if replaced else 'overwrite'}"
                                 "; give another folder")
