"""The public Python API, ``import vifpk`` (docs/api.md): every documented name resolves, and
the workflows do what their commands do (the check on the canned tiny result)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import vifpk


def test_every_public_name_resolves_and_is_documented():
    doc = (Path(__file__).resolve().parent.parent / "docs" / "api.md").read_text()
    for name in vifpk.__all__:
        assert getattr(vifpk, name) is not None
        assert f"vifpk.{name}" in doc, f"docs/api.md does not document vifpk.{name}"
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        vifpk.nope  # noqa: B018


def test_scene_solve_and_models():
    sc = vifpk.scene("paper-base", **{"noise.D": 0.02})
    assert isinstance(sc, vifpk.Scene) and sc.noise.D == 0.02
    with pytest.raises(vifpk.SceneError, match="noise.D"):
        vifpk.scene("paper-base", **{"noise.D": -1.0})
    res = vifpk.solve(sc, "averaging", model="exact")
    assert isinstance(res, vifpk.Result) and res.info["status"] == vifpk.Status.DENSITY.record()
    x, p = res.data["A"]["x"], res.data["A"]["p"]
    assert abs(np.trapezoid(p, x) - 1) < 1e-9
    assert {"paper", "exact", "corrected"} <= set(vifpk.model_names())
    assert callable(vifpk.build_model(sc, "paper").drift)


@pytest.mark.slow
def test_check_writes_the_report_like_the_command(canned_check, tmp_path):
    res = vifpk.check("paper-base", out=tmp_path / "rep")
    assert res.verdicts and (tmp_path / "rep" / "report.html").is_file()
    assert (tmp_path / "rep" / "metrics.json").is_file()
