"""corrected's MFPT far in the tail (issue 45, item 5): its impact loss -ln(e^2) K is first
order in lambda = -ln e^2; with a speed-dependent (Johnson) law lambda grows with the impact
speed, and `vifpk passage` warns where the compounded loss exceeds the impact's own by more
than COMPOUNDED_MAX. Closed forms of the restitution laws, no solver."""

from __future__ import annotations

import math

from vifpk.harness.workflows.assumptions import COMPOUNDED_MAX, compounded_tail

from vifpk.core.scene import load_scene, scene_from_dict

K1, K3 = 1.0, 0.5
WALL, R, VY = -0.2, 0.9, 0.3


def _johnson():
    return scene_from_dict({
        "system": {"restoring": [K1, K3], "damping": [0.02], "mu": 0.0, "f": 1.0,
                   "lower_wall": {"at": WALL, "r": R, "law": "johnson", "v_yield": VY}},
        "noise": {"kind": "white", "D": 0.01}})


def _ratio(Ac: float) -> float:
    """-ln(e^2) / (1 - e^2) at the impact speed of the orbit of amplitude Ac, Johnson's
    e(v) = r min(1, (v_yield / v)^(1/4)), written here from its definition."""
    U = lambda x: K1 * x * x / 2 + K3 * x ** 4 / 4  # noqa: E731
    v = math.sqrt(2 * (U(Ac) - U(WALL)))
    e = R * min(1.0, (VY / v) ** 0.25)
    return -math.log(e * e) / (1 - e * e)


def test_the_johnson_wall_leaves_the_derivation_as_the_threshold_rises():
    sc = _johnson()
    ratios = [_ratio(a) for a in (0.3, 0.5, 0.8, 1.2)]
    assert ratios == sorted(ratios) and ratios[0] < COMPOUNDED_MAX < ratios[-1]
    for a, q in zip((0.3, 0.5, 0.8, 1.2), ratios, strict=True):
        w = compounded_tail(sc, a)
        assert (w is not None) == (q > COMPOUNDED_MAX)
        if w:
            assert f"{q:.2f} x the energy the impact takes" in w and "johnson" in w


def test_the_papers_wall_at_r_096_stays_inside_at_any_threshold():
    """lambda = -ln 0.96^2 = 0.082 whatever the speed: ratio 1.04."""
    sc = load_scene("paper-base")
    assert all(compounded_tail(sc, a) is None for a in (0.5, 1.0, 3.0, 10.0))

