"""Provenance of a run: which run made an output, from what, with which software.

Every output of vifpk (solve JSON ``info.provenance``, metrics.json ``provenance``, report.html
and report.md, figures/workprecision/sweep outputs) carries the block :func:`collect` returns:

    run_id     a fresh id per run: UTC time to the second plus 6 random hex digits,
               e.g. ``20261123T113512Z-3fa9c1``; every file of one run carries the same id
    created    UTC time, ISO 8601
    vifpk      the installed package version
    git        ``{"commit": sha, "dirty": bool}`` when the code runs from a git checkout, else None
    versions   python, numpy, scipy, numba, py-pde, matplotlib (those that are importable)
    command    the command line, shell-quoted
    scene      ``{"path": ..., "sha256": ...}`` of the scene file read, or None
    overrides  the ``--set`` overrides in the order given

None of these enter a computed number: results are a function of (scene, settings, seed) only,
which is why metrics.json keeps this block apart (issue 11: byte-identical metrics once
``provenance`` and ``timings`` are removed).
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
import platform
import secrets
import shlex
import subprocess
import sys
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from functools import lru_cache
from importlib import metadata
from pathlib import Path
from typing import Any

_MODULES = {"numpy": "numpy", "scipy": "scipy", "numba": "numba", "py-pde": "pde",
            "matplotlib": "matplotlib"}


def new_run_id(now: datetime | None = None) -> str:
    """``YYYYmmddTHHMMSSZ-xxxxxx``: sortable by time, unique across concurrent runs."""
    now = now or datetime.now(UTC)
    return f"{now:%Y%m%dT%H%M%SZ}-{secrets.token_hex(3)}"


def vifpk_version() -> str:
    try:
        return metadata.version("vifpk")
    except metadata.PackageNotFoundError:
        return "unknown"


@lru_cache(maxsize=1)
def git_state() -> dict[str, Any] | None:
    """Commit and dirty flag of the checkout the code runs from, or None outside one."""
    here = Path(__file__).resolve().parent.parent
    if not (here / ".git").exists():
        return None
    env = {**os.environ, "GIT_OPTIONAL_LOCKS": "0"}
    try:
        sha = subprocess.run(["git", "-C", str(here), "rev-parse", "HEAD"], capture_output=True,
                             text=True, timeout=5, env=env, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(here), "status", "--porcelain",
                                "--untracked-files=no"], capture_output=True, text=True,
                               timeout=5, env=env, check=True).stdout.strip() != ""
    except (OSError, subprocess.SubprocessError):
        return None
    return {"commit": sha, "dirty": dirty}


def versions() -> dict[str, str]:
    """Versions of python and of the numerical libraries that are installed: the imported
    module's ``__version__`` when it is loaded, else the installed distribution's metadata
    (no import: a solve that needs no numba should not pay for loading it)."""
    out = {"python": platform.python_version()}
    for name, module in _MODULES.items():
        mod = sys.modules.get(module)
        if mod is not None:
            out[name] = str(getattr(mod, "__version__", "unknown"))
            continue
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return out


def file_sha256(path: str | Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def collect(*, argv: Sequence[str] | None = None, scene_path: str | Path | None = None,
            overrides: Mapping[str, Any] | Sequence[str] = (), run_id: str | None = None,
            now: datetime | None = None) -> dict[str, Any]:
    """The provenance block of one run (see the module docstring for its keys)."""
    now = now or datetime.now(UTC)
    argv = list(sys.argv if argv is None else argv)
    if argv and argv[0].endswith(("__main__.py", "vifpk")):
        argv[0] = "vifpk"
    if isinstance(overrides, Mapping):
        overrides = [f"{k}={v}" for k, v in overrides.items()]
    scene = None
    if scene_path is not None and Path(scene_path).is_file():
        scene = {"path": str(scene_path), "sha256": file_sha256(scene_path)}
    return {
        "run_id": run_id or new_run_id(now),
        "created": now.isoformat(timespec="seconds").replace("+00:00", "Z"),
        "vifpk": vifpk_version(),
        "git": git_state(),
        "versions": versions(),
        "command": shlex.join(argv),
        "scene": scene,
        "overrides": list(overrides),
    }


def scene_file(path: str | Path) -> Path | None:
    """The scene file a path or shipped-scene name resolves to, found where ``load_scene``
    reads it (``vifpk.core.scene.find_scene``: a shipped scene is package data ``vifpk.scenes``,
    in a wheel under site-packages/vifpk/scenes); None when there is none on disk."""
    from vifpk.core import scene

    found = scene.find_scene(path)
    if found is None:
        return None
    p = Path(str(found))  # importlib.resources gives filesystem paths for installed packages
    return p if p.is_file() else None


def overridden_name(name: str, overrides: Sequence[str]) -> str:
    """The name of a scene run with ``--set`` overrides: the base name plus each override as
    given, ``paper-base+system.mu=0.5+noise.D=0.02``, so its title and default output folder
    are never the base scene's."""
    return "+".join([name, *("".join(o.split()) for o in overrides)])


def folder_name(name: str) -> str:
    """A scene name made safe as one folder name (path separators, spaces, quotes -> ``_``)."""
    safe = "".join(c if c.isalnum() or c in "._=+,-" else "_" for c in name).lstrip(".")
    return safe or "scene"


def rows(prov: Mapping[str, Any]) -> list[tuple[str, str]]:
    """The provenance block as (field, value) text rows for a report table."""
    git = prov.get("git")
    out = [("run id", prov["run_id"]), ("created (UTC)", prov["created"]),
           ("vifpk version", prov["vifpk"]),
           ("git commit", (git["commit"] + (" (with uncommitted changes)" if git["dirty"] else ""))
            if git else "not run from a git checkout"),
           ("command", prov["command"])]
    sc = prov.get("scene")
    out.append(("scene file", f"{sc['path']} (sha256 {sc['sha256']})" if sc else "none"))
    out.append(("overrides", ", ".join(prov.get("overrides") or []) or "none"))
    out.append(("versions", ", ".join(f"{k} {v}" for k, v in prov["versions"].items())))
    return out


def summary(prov: Mapping[str, Any]) -> str:
    """One line naming the run: ``run 2026...-3fa9c1, 2026-11-23T11:35:12Z, vifpk 0.1.0``."""
    git = prov.get("git")
    tail = f" (git {git['commit'][:10]}{'+dirty' if git['dirty'] else ''})" if git else ""
    return f"run {prov['run_id']}, {prov['created']}, vifpk {prov['vifpk']}{tail}"


def stamped(res: Any, prov: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
    """(the result carrying ``prov``, prov): a report writer's provenance, ``prov`` when given,
    else :func:`collect` for this process with the result's scene file (``res.scene.source``).
    ``res`` is a dataclass with a ``provenance`` field (the check, passage, transient and
    splitting results)."""
    if prov is None:
        prov = collect(scene_path=scene_file(res.scene.source) if res.scene.source else None)
    return dataclasses.replace(res, provenance=prov), prov


def process_clock() -> dict[str, float]:
    """{"wall": seconds since this process started, "cpu": its CPU seconds so far (every
    thread)}: at a command's start, what the interpreter and the imports cost (the run's
    timing record, "startup"). The start from /proc (Linux, to the clock tick; nan elsewhere),
    read at the first call; later calls add time.perf_counter's seconds since, so the
    differences of two calls are exact."""
    import time

    now = time.perf_counter()
    if not _ANCHOR:
        try:
            with open("/proc/self/stat") as f:
                ticks = int(f.read().rsplit(")", 1)[1].split()[19])  # field 22: starttime
            with open("/proc/uptime") as f:
                up = float(f.read().split()[0])
            wall = up - ticks / os.sysconf("SC_CLK_TCK")
        except (OSError, ValueError, IndexError):
            wall = float("nan")
        _ANCHOR.append((now, wall))
    t0, w0 = _ANCHOR[0]
    return {"wall": w0 + (now - t0), "cpu": time.process_time()}


_ANCHOR: list[tuple[float, float]] = []  # (perf_counter, wall since the start) at the first call
