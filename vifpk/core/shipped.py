"""The shipped scenes (package data ``vifpk.scenes``) and reading a scene or sweep file."""

from __future__ import annotations

import tomllib
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

from .checks import SceneError


def shipped_scenes() -> Traversable:
    """The shipped scenes: package data ``vifpk.scenes`` (the repository's top-level
    ``scenes/``, mapped into the wheel by pyproject.toml), read with importlib.resources. In a
    source checkout on ``sys.path`` that is not installed, the repository's ``scenes/``."""
    try:
        return resources.files("vifpk.scenes")
    except ModuleNotFoundError:
        return Path(__file__).resolve().parents[2] / "scenes"


def shipped_name(text: str) -> bool:
    """True when ``text`` is the name of a shipped scene rather than a path: relative, no
    ``.toml`` suffix, no ``.``/``..``/``~`` parts ("paper-base", "hard/r-low"). A path is a
    path: one that does not exist is an error, never a shipped scene of the same name."""
    parts = text.split("/")
    return bool(text) and not text.endswith(".toml") and not text.startswith(("/", "~")) \
        and all(part and not part.startswith(".") for part in parts) and "\\" not in text


def shipped_names() -> list[str]:
    """The names of the shipped scenes (``hard/...`` and ``systems/...`` included; sweeps
    excluded)."""
    root = shipped_scenes()
    out = []
    for entry in sorted(root.iterdir(), key=lambda e: e.name):
        if entry.is_file() and entry.name.endswith(".toml"):
            out.append(entry.name[:-5])
        elif entry.is_dir() and entry.name in ("hard", "systems"):
            out += [f"{entry.name}/{e.name[:-5]}"
                    for e in sorted(entry.iterdir(), key=lambda e: e.name)
                    if e.name.endswith(".toml")]
    return out


def find_scene(path: str | Path | Traversable) -> Path | Traversable | None:
    """The file a scene path or name stands for, as :func:`load_scene` reads it: the path
    itself when it is a file, else the shipped scene of that bare name (:func:`shipped_name`,
    in :func:`shipped_scenes`); None when there is none."""
    p: Path | Traversable = path if isinstance(path, Traversable) else Path(path)
    if p.is_file():
        return p
    text = str(path)
    if isinstance(path, Traversable) and not isinstance(path, Path) or not shipped_name(text):
        return None
    where = shipped_scenes()
    for part in f"{text}.toml".split("/"):  # one part at a time: a namespace
        where = where / part                # package's MultiplexedPath takes one
    return where if where.is_file() else None


def is_toml_file(p: Path | Traversable, error: type[SceneError], what: str) -> bool:
    """Whether ``p`` is an existing file (False: not there, so maybe a shipped name);
    ``error`` (one line) when it is a folder or cannot even be looked at (e.g. a name longer
    than the file system allows). ``what``: "scene" or "sweep", for the message."""
    try:
        is_dir, is_file = p.is_dir(), p.is_file()
    except OSError as exc:
        raise error(f"{str(p)[:80]}: cannot read ({exc.strerror or exc})") from None
    if is_dir:
        raise error(f"{p}: is a folder; give a {what} file (.toml)")
    return is_file


def read_toml(p: Path | Traversable, error: type[SceneError] = SceneError
              ) -> tuple[str, dict[str, Any]]:
    """The text and the parsed TOML of a scene or sweep file (a UTF-8 BOM is fine); ``error``
    (one line naming the file) when it cannot be read or parsed, deep nesting included."""
    try:
        text = p.read_text(encoding="utf-8-sig")
        return text, tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{p.name}: not valid TOML: {exc}") from None
    except RecursionError:
        raise error(f"{p.name}: not valid TOML: arrays or tables nested too deeply") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise error(f"{p.name}: cannot read: {exc}") from None
