"""Shared fixtures: the paper's base scene and helpers to vary it.

In the style of py-pde's conftest: every test runs with numpy floating-point errors raised
(``divide``, ``over``, ``invalid``; underflow ignored), so a NaN or inf that nobody expects
fails the test where it is made instead of travelling into a density. A test that expects them
says so with ``@pytest.mark.numpy_errors_ok`` (with the reason in its docstring). Matplotlib
figures left open by a test are closed after it.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from harness.scene import Scene, load_scene

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True)
def _numpy_errors_raise_and_figures_close(request: pytest.FixtureRequest):
    if request.node.get_closest_marker("numpy_errors_ok") is not None:
        yield
    else:
        with np.errstate(all="raise", under="ignore"):
            yield
    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")


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
