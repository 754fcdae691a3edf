"""Atomic output: write to a temporary file beside the target, then rename.

A run interrupted half-way leaves the previous file (or none), never a truncated one. The
temporary file is created with mode 0666 minus the umask (like any ``open``), not with
``tempfile``'s 0600, so the file that lands has the mode every other output has.
Whole folders (the check report) are written as a unit by :mod:`harness.outdir`.
"""

from __future__ import annotations

import json
import math
import os
import secrets
import struct
import zlib
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


def temp_beside(path: Path) -> tuple[Path, int]:
    """A new hidden temporary file beside ``path`` (its folder created), opened for writing:
    (its path, the file descriptor). Mode 0666 minus the umask, as any ``open``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    while True:
        tmp = path.parent / f".{path.name}.{secrets.token_hex(4)}.tmp"
        try:
            return tmp, os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue


def write_atomic(path: str | Path, data: bytes | str) -> Path:
    """Write ``data`` to ``path`` atomically (same-directory temp file + os.replace)."""
    path = Path(path)
    raw = data.encode("utf-8") if isinstance(data, str) else data
    tmp, fd = temp_beside(path)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(raw)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def dumps(obj: Any) -> str:
    """The JSON text of every vifpk output: plain types, indent 1, no NaN, newline at the end.
    Deterministic for equal input (dict order as built, floats in shortest repr)."""
    return json.dumps(jsonable(obj), indent=1, allow_nan=False) + "\n"


def write_json(path: str | Path, obj: Any) -> Path:
    return write_atomic(path, dumps(obj))


def png_with_text(png: bytes, text: dict[str, str]) -> bytes:
    """A PNG with ``tEXt`` chunks (keyword, Latin-1 text) inserted after its header chunk, so an
    image carries the run id of the report it belongs to (PNG spec, section 11.3.4.3)."""
    if png[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    end = 8 + 12 + struct.unpack(">I", png[8:12])[0]  # signature + IHDR (length, type, crc)
    chunks = b""
    for key, value in text.items():
        body = b"tEXt" + key.encode("latin-1") + b"\0" + value.encode("latin-1", "replace")
        chunks += struct.pack(">I", len(body) - 4) + body + struct.pack(">I", zlib.crc32(body))
    return png[:end] + chunks + png[end:]
