"""The scene keys of issue 37: walls anywhere, their impact laws, parametric noise (data and
validation only: vifpk.core.walls, vifpk.core.scene). Fast: no solver runs."""

from __future__ import annotations

import pytest

from vifpk.core.scene import SceneError, energy_balance, load_scene, scene_from_dict
from vifpk.core.walls import Wall

TWO = {"system": {"lower_wall": {"at": -0.3, "r": 0.9},
                  "upper_wall": {"at": 0.8, "r": 0.85, "law": "johnson", "v_yield": 0.5}},
       "parametric": {"stiffness": 0.004}}


def test_wall_tables_parse_and_round_trip():
    s = scene_from_dict(TWO)
    lo, up = s.system.walls
    assert lo == Wall.of("lower", -0.3, r=0.9)
    assert up == Wall.of("upper", 0.8, "johnson", r=0.85, v_yield=0.5)
    assert s.system.r is None and s.system.barrier is None  # the old spelling is off
    assert s.parametric.stiffness == 0.004 and s.parametric.on
    again = scene_from_dict(s.to_dict())
    assert again.system == s.system and again.parametric == s.parametric


def test_the_paper_wall_has_one_meaning_in_both_spellings():
    base = load_scene("paper-base")
    table = base.with_values({"system.lower_wall.at": 0.0})
    assert table.system == base.system  # normalised to r, barrier
    assert base.system.walls == (Wall.of("lower", 0.0, r=0.96),)
    assert base.system.walls_problem() is None
    assert "parametric" not in base.to_dict()  # off: the scene's dictionary is unchanged
    assert scene_from_dict({"system": {"barrier": False}}).system.walls == ()


def test_set_a_wall_key_on_the_paper_scene_converts_its_wall():
    s = load_scene("paper-base").with_values({"system.lower_wall.at": -0.1})
    assert s.system.walls == (Wall.of("lower", -0.1, r=0.96),)
    assert "wall at x = 0" in s.system.paper_family_problem()


@pytest.mark.parametrize("system, words", [
    ({"r": 0.9, "lower_wall": {"at": -0.1}}, "both set the walls"),
    ({"barrier": False, "upper_wall": {"at": 0.5}}, "both set the walls"),
    ({"lower_wall": {"at": 0.2}}, "allowed: <= 0"),
    ({"upper_wall": {"at": -0.2}}, "allowed: >= 0"),
    ({"lower_wall": {"at": -0.1, "r": 0.0}}, "0 < r <= 1"),
    ({"lower_wall": {"at": -0.1, "r": 1.5}}, "0 < r <= 1"),
    ({"lower_wall": {"at": -0.1, "law": "hertz"}}, "impact law must be one of"),
    ({"lower_wall": {"at": -0.1, "law": "johnson"}},
     "v_yield is missing: the johnson law needs it"),
    ({"lower_wall": {"at": -0.1, "law": "johnson", "v_yield": -1}},
     "v_yield = -1 is out of range; allowed: a finite number > 0"),
    ({"lower_wall": {"at": -0.1, "v_yield": 1}},
     "v_yield applies to law = 'johnson' only, not 'newton'"),
    ({"lower_wall": {"r": 0.9}}, "at is missing"),
    ({"lower_wall": {"at": -0.1, "rr": 0.9}}, "unknown key"),
    ({"lower_wall": {"at": float("nan")}}, "finite number"),
    ({"lower_wall": {"at": 0.0}, "upper_wall": {"at": 0.0}}, "leave no room"),
    ({"lower_wall": 3}, "must be a table"),
])
def test_bad_walls_are_refused_in_one_line(system, words):
    with pytest.raises(SceneError) as e:
        scene_from_dict({"system": system}, source="s.toml")
    msg = str(e.value)
    assert words in msg and "\n" not in msg and msg.startswith("s.toml: system")


@pytest.mark.parametrize("value", [-0.1, float("inf"), "x", True])
def test_bad_parametric_intensity_is_refused(value):
    with pytest.raises(SceneError, match="parametric.stiffness"):
        scene_from_dict({"parametric": {"stiffness": value}})


def test_energy_balance_with_two_walls_counts_their_losses():
    """Two walls hold x in [a, b]: the impacts (~ A^{3n+3}) outgrow the bounded damping; a
    johnson wall loses energy at high speed even with r = 1; elastic Newton walls lose none."""
    s = scene_from_dict({"system": {"c1": -0.01, "c2": 0.0, "mu": 0.0,
                                    "lower_wall": {"at": -0.3, "r": 1.0},
                                    "upper_wall": {"at": 0.5, "r": 1.0, "law": "johnson",
                                                   "v_yield": 1.0}}})
    bal = energy_balance(s.system)
    assert not bal.grows and "system.upper_wall" in bal.losses and bal.degree == 6
    elastic = s.with_values({"system.upper_wall.law": "newton",
                             "system.upper_wall.v_yield": None})
    assert energy_balance(elastic.system).losses == ("system.c1",)


def test_parametric_noise_at_the_top_degree():
    """A parametric gain of the top loss's degree is decided by the tail's constants
    (vifpk.core.energy; tests/test_parametric_tail.py): held while kappa > 1, else no stationary
    law; one of a degree above every loss stays a tie (the law is E^-kappa beyond a crossover
    energy only)."""
    s = scene_from_dict({"system": {"restoring": [1.0], "damping": [0.05], "mu": 0.0,
                                    "barrier": False},
                         "parametric": {"stiffness": 0.01}})
    bal = energy_balance(s.system, s.parametric)
    assert not bal.tie and not bal.grows and bal.gains == ("parametric.stiffness",)
    assert energy_balance(s.system, s.with_values({"parametric.stiffness": 0.2}).parametric).grows
    cubic = s.with_values({"system.restoring": [1.0, 0.3]})
    bal = energy_balance(cubic.system, cubic.parametric)
    assert bal.tie and not bal.grows and bal.tail.crossover > 0
