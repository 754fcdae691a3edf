"""Issue 45 item 1: a step too coarse for the scene is refused before any work, in one line
naming --dt and the allowed range, exit 2 (docs/edges.md, round 8b). Fast: the request reads
the step rule's bias model (montecarlo/tuning.py ``predicted_bias``, through the door); no
simulation runs.

At aa1e12c `vifpk passage systems/bilateral-duffing --threshold 0.5 --dt 0.5` was accepted and
reported the original system's step bias as the model's error ("exact model: LARGE +124%"; at
dt 0.01 the same case is -7% +- 10%); the transient and check took --dt 0.5 alike.
"""

from __future__ import annotations

import pytest
from vifpk.harness.cli.app import main
from vifpk.harness.door.reach import step_bias, step_limit

import vifpk
from vifpk.core.defaults import SMALL_L1
from vifpk.core.result import BadInput

COARSE = [
    ["passage", "systems/bilateral-duffing", "--threshold", "0.5", "--dt", "0.5",
     "--paths", "64"],
    ["transient", "systems/bilateral-duffing", "--start", "0.2", "--times", "1,2,3",
     "--dt", "0.5"],
    ["check", "systems/offset-parametric", "--dt", "0.5", "--paths", "64", "--quiet"],
    ["solve", "paper-base", "--solver", "montecarlo", "--dt", "0.5", "--paths", "64"],
]


@pytest.mark.parametrize("args", COARSE, ids=lambda a: a[0])
def test_a_step_too_coarse_is_refused_before_work(capsys, tmp_path, monkeypatch, args):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("vifpk: error: --dt (montecarlo.dt) = 0.5 is "
                                               "too coarse for this scene")
    assert "allowed: dt < 0.29" in err[0]
    assert not any(tmp_path.iterdir())  # nothing written


def test_the_python_api_refuses_it_alike():
    with pytest.raises(BadInput, match="too coarse"):
        vifpk.passage("systems/bilateral-duffing", threshold=0.5, dt=0.5, paths=64)
    with pytest.raises(BadInput, match="too coarse"):
        vifpk.check("systems/offset-parametric", dt=0.5)


def test_the_bound_is_the_rule_s_model_read_through_the_door():
    """The allowed step is where the model reaches SMALL_L1: C (rate dt)^p with the base
    family's envelope C = 0.64, p = 1.5 before the pilot (rate max(sqrt(k1), 1) = 1 on
    bilateral-duffing, white noise: no held-noise term), so dt = (0.1 / 0.64)^(2/3) = 0.2902;
    the default step 0.01 is 30x below it."""
    s = vifpk.scene("systems/bilateral-duffing")
    top = step_limit(s, SMALL_L1, 0.5)
    assert top == pytest.approx((0.1 / 0.64) ** (2 / 3), rel=1e-3)
    assert step_bias(s, top) <= SMALL_L1 < step_bias(s, 0.3)
    assert step_bias(s, 0.01) < SMALL_L1 / 100


def test_a_spring_with_no_linear_term_under_held_noise_is_priced():
    """A pure cubic spring (restoring = [0, 1]) under OU noise: its orbit frequency at A = 0 is
    0, and the held-noise term of the rule (tuning.hold_bias) took the max over no frequency,
    a ValueError inside validation (the slow tier's passage of a user's cubic system, CI of
    0b2359e). Its step bias is the envelope's alone there: finite, and the default step 0.01
    far below SMALL_L1."""
    s = vifpk.scene("paper-base", **{"system.restoring": [0.0, 1.0],
                                     "system.damping": [0.01], "noise.D": 0.05})
    assert 0.0 < step_bias(s, 0.01) < SMALL_L1 / 100
