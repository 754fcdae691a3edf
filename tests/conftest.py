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

from vifpk.core.scene import Scene, load_scene

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


def phase_mass_gap(scene: Scene, result, model: str) -> float:
    """Largest relative gap between the phase-space masses an averaged solution had BEFORE its
    normalisation and their exact value.

    The phase densities are p(y, y') = p_A / (g T_model) (paper eq. 15-16). The orbit of
    amplitude A fills dy dy' = dE dt = g dA dt over its true period T, so their mass is
    int p_A T / T_model dA, computed here with the independent period quadrature of
    averaging.geometry (1 for the exact model; for the paper model T_model = 2 pi / b0). A
    wrong fold, Jacobian or period in the mapping shows up here; after normalisation it would
    not.
    """
    from averaging import build_model
    from averaging.geometry import period

    s = scene.system
    A, p = np.asarray(result.data["A"]["x"]), np.asarray(result.data["A"]["p"])
    Ai = np.maximum(A, 1e-12)  # T and T_model are regular at A = 0
    ratio = period(Ai, s.omega0, s.alpha) / build_model(scene, model).period(Ai)
    expect = float(np.trapezoid(p * ratio, A))
    raw = result.info["diagnostics"]["phase_mass_before_normalisation"]
    return max(abs(raw[k] / expect - 1.0) for k in ("x1", "x2", "joint"))


pytest_plugins = ["pytester"]
