"""Scene loading and validation: every bad value gets one line naming the field."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from tests.conftest import ROOT
from vifpk.core.scene import SceneError, load_scene, scene_from_dict


def test_shipped_scenes_load():
    files = sorted((ROOT / "scenes").glob("*.toml"))
    names = {f.stem for f in files}
    assert {"paper-base", "paper-fig2", "paper-fig3", "paper-fig4", "paper-fig5",
            "paper-fig6"} <= names
    for f in files:
        s = load_scene(f)
        assert all(v.sweep is None for v in s.variants())


def test_base_values_are_the_papers(base):
    s, n = base.system, base.noise
    assert (s.c1, s.c2, s.alpha, s.omega0, s.r, s.mu, s.f) == (0.025, 0.05, 0.6, 1.0, 0.96,
                                                               0.001, 1.0)
    assert (n.kind, n.D, n.alpha1) == ("ou", 0.01, 2.0)


def test_sweep_expands():
    s = load_scene(ROOT / "scenes" / "paper-fig6.toml")
    assert s.sweep is not None and s.sweep.path == "system.r"
    assert [v.system.r for v in s.variants()] == [0.96, 0.968, 0.975]


@pytest.mark.parametrize(
    ("doc", "needle"),
    [
        ({"system": {"r": 1.2}}, "s.toml: system.r = 1.2 is out of range; allowed: 0 < r <= 1"),
        ({"system": {"r": 0.0}}, "0 < r <= 1"),
        ({"noise": {"D": -1.0}}, "noise.D = -1 is out of range; allowed: a finite number > 0"),
        ({"noise": {"D": math.nan}}, "noise.D = nan"),
        ({"noise": {"alpha1": 0.0}}, "alpha1"),
        ({"system": {"mu": -0.1}}, "mu = -0.1"),
        ({"system": {"omega0": 0.0}}, "omega0"),
        ({"system": {"alpha": -1.0}}, "alpha = -1.0"),
        ({"system": {"c2": -1.0}}, "c2 = -1.0"),
        ({"system": {"c1": math.inf}}, "c1 = inf"),
        ({"system": {"f": "one"}}, "f = 'one' must be a finite number"),
        ({"noise": {"kind": "pink"}}, "noise.kind = 'pink': noise kind must be one of ('ou', "),
        ({"system": {"bounce_law": 0.9}}, "unknown key; allowed"),
        ({"system": {"mu_": 0.1}}, "did you mean 'mu'?"),
        ({"noize": {}}, "unknown key 'noize'; did you mean 'noise'?"),
        ({"system": {"mu": [0.1], "r": [0.9]}}, "only one parameter may vary"),
        ({"system": {"r": [0.9, 1.5]}}, "r[1] = 1.5 is out of range"),
        ({"averaging": {"points": 3}}, "points = 3 is out of range"),
    ],
)
def test_bad_values_name_the_field(doc, needle):
    with pytest.raises(SceneError) as exc:
        scene_from_dict(doc, source="s.toml")
    msg = str(exc.value)
    assert needle in msg
    assert "\n" not in msg


def test_c1_may_be_negative():
    s = scene_from_dict({"system": {"c1": -0.3}})
    assert s.system.c1 == -0.3


def test_bad_toml_and_missing_file(tmp_path: Path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[system\nr = 1")
    with pytest.raises(SceneError, match="not valid TOML"):
        load_scene(bad)
    with pytest.raises(SceneError, match="no such scene file"):
        load_scene(tmp_path / "nope.toml")


def test_overrides_are_validated(base):
    assert base.with_values({"noise.D": 0.02}).noise.D == 0.02
    with pytest.raises(SceneError, match="r = 2"):
        base.with_values({"system.r": 2})
    with pytest.raises(SceneError, match="unknown field"):
        base.with_values({"bogus.x": 1})


def test_round_trip(base):
    again = scene_from_dict(base.to_dict())
    assert again.system == base.system and again.noise == base.noise
