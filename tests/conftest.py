"""Shared fixtures: the paper's base scene and helpers to vary it."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from harness.scene import Scene, load_scene

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def base() -> Scene:
    return load_scene(ROOT / "scenes" / "paper-base.toml")


def vary(scene: Scene, **kw: float | str | bool) -> Scene:
    """A copy of ``scene`` with system/noise/averaging fields replaced by name."""
    parts = {}
    for sec in ("system", "noise", "averaging"):
        obj = getattr(scene, sec)
        mine = {k: v for k, v in kw.items() if hasattr(obj, k)}
        parts[sec] = replace(obj, **mine)
    unknown = set(kw) - {k for p in parts.values() for k in p.__dict__}
    assert not unknown, unknown
    return replace(scene, **parts)


pytest_plugins = ["pytester"]
