"""Atomic output: write to a temporary file beside the target, then rename; and figures.

A run interrupted half-way leaves the previous file (or none), never a truncated one. The
temporary file is created with mode 0666 minus the umask (like any ``open``), not with
``tempfile``'s 0600, so the file that lands has the mode every other output has. Every
single-file output goes through :func:`atomic_path` (bytes and text through
:func:`write_atomic`); whole folders (the check report) are written as a unit by
:mod:`harness.outputs.outdir`.

Figures: :func:`figures` makes figures on their own Agg canvas without pyplot (no backend
switched, no global figure registry) and :func:`png_bytes` renders a figure with its PNG text
metadata (matplotlib's ``metadata=``), closing it on every path.
"""

from __future__ import annotations

import io
import json
import math
import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np


def jsonable(obj: Any) -> Any:
    """Plain JSON types from numpy arrays and scalars; non-finite floats become None."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return jsonable(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _temp_beside(path: Path) -> tuple[Path, int]:
    """A new hidden temporary file beside ``path`` (its folder created), opened for writing:
    (its path, the file descriptor). Mode 0666 minus the umask, as any ``open``. The name
    keeps ``path``'s suffix, for writers that read the format from it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    while True:
        tmp = path.parent / f".{path.name}.{secrets.token_hex(4)}.tmp{path.suffix}"
        try:
            return tmp, os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary file beside ``path`` for the block to write (by name: netCDF, savefig,
    numpy); renamed onto ``path`` when the block ends, removed if it raises."""
    path = Path(path)
    tmp, fd = _temp_beside(path)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, path)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        if exc.filename is None:  # ENOSPC from a library's write names no file: name ours
            # (issue 45: a full disk under --out read "cannot write the standard output")
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc
        raise
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_atomic(path: str | Path, data: bytes | str) -> Path:
    """Write ``data`` to ``path`` atomically (:func:`atomic_path`), synced to disk first. A
    write that fails (a full disk: ENOSPC from write or fsync, which name no file) raises an
    OSError naming ``path`` (issue 39, B39: a sweep folder on a full disk was reported as
    "cannot write the standard output")."""
    raw = data.encode("utf-8") if isinstance(data, str) else data
    try:
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            fh.write(raw)
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as exc:
        if exc.filename is None:
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from exc
        raise
    return Path(path)


def dumps(obj: Any) -> str:
    """The JSON text of every vifpk output: plain types, indent 1, no NaN, newline at the end.
    Deterministic for equal input (dict order as built, floats in shortest repr)."""
    return json.dumps(jsonable(obj), indent=1, allow_nan=False) + "\n"


def write_json(path: str | Path, obj: Any) -> Path:
    return write_atomic(path, dumps(obj))


class Figures:
    """New matplotlib figures without pyplot: a ``matplotlib.figure.Figure`` on its own Agg
    canvas, so drawing to files changes no global state (no ``matplotlib.use``, no backend
    switched under a notebook user, no figure registered with pyplot that an exception could
    leave open: an unreferenced figure is freed like any object). The three pyplot names the
    harness draws with, with pyplot's signatures."""

    @staticmethod
    def subplots(nrows: int = 1, ncols: int = 1, *, sharex: bool | str = False,
                 sharey: bool | str = False, squeeze: bool = True,
                 subplot_kw: dict[str, Any] | None = None,
                 gridspec_kw: dict[str, Any] | None = None, **fig_kw: Any) -> tuple[Any, Any]:
        """(figure, axes) as ``pyplot.subplots`` returns them."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(**fig_kw)
        FigureCanvasAgg(fig)
        axes = fig.subplots(nrows, ncols, sharex=sharex, sharey=sharey, squeeze=squeeze,
                            subplot_kw=subplot_kw, gridspec_kw=gridspec_kw)
        return fig, axes

    @staticmethod
    def get_cmap(name: str) -> Any:
        import matplotlib

        return matplotlib.colormaps[name]

    @staticmethod
    def close(fig: Any) -> None:
        """Release ``fig``: a pyplot figure (one a caller made with pyplot) is closed there;
        ours are left as they are (no registry holds them: freed once unreferenced)."""
        import sys

        plt = sys.modules.get("matplotlib.pyplot")  # never imported here
        if plt is not None and getattr(fig.canvas, "manager", None) is not None:
            plt.close(fig)


def figures() -> Figures:
    """The figure factory the harness draws with (:class:`Figures`)."""
    return Figures()


#: The old name (every caller used ``plt = pyplot(); plt.subplots(...)``): the same factory,
#: not matplotlib.pyplot.
pyplot = figures


def png_bytes(fig: Any, *, text: dict[str, str] | None = None, **savefig: Any) -> bytes:
    """The figure as PNG bytes, closed on every path (also when ``savefig`` raises); ``text``:
    PNG text chunks (e.g. the run id of the report it belongs to), written by matplotlib's
    ``savefig(metadata=...)``."""
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format="png", metadata=text, **savefig)
    finally:
        Figures.close(fig)
    return buf.getvalue()
