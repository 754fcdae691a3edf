"""How a researcher pins the accuracy of their own averaged model (run by vifpk's own tests).

A user's model (docs/examples/plugin/vifpk_white_envelope.py: the standard energy-envelope
averaging of the vibro-impact Duffing oscillator with the sgn(y) factor dropped, "additive"
noise, the paper's assumption, in a few lines of numpy) checked against the Monte Carlo of the
original system. The same file is the example plugin (docs/plugins.md); here it is imported
from its folder, installed or not.

    pytest docs/examples/test_my_model.py --vifpk-cache .vifpk-cache

The first run pays for the Monte Carlo reference; later runs load it from the cache.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from vifpk.harness.testing import assert_averaging_error

sys.path.insert(0, str(Path(__file__).resolve().parent / "plugin"))
from vifpk_white_envelope import WhiteNoiseEnvelope  # noqa: E402

# a small, fast reference for the example (the default scene settings are bigger)
MC = {"paths": 256, "time": 1000.0}


def test_my_model_is_accurate_under_white_noise(vifpk_scene):
    """Under white noise the sgn(y) factor does not matter: the model is good (L1 0.021)."""
    scene = vifpk_scene("paper-base", **{"noise.kind": "white"})
    assert_averaging_error(scene, WhiteNoiseEnvelope(scene), below=0.08, **MC)


def test_the_same_model_fails_under_real_noise(vifpk_scene):
    """Under OU noise the white-noise model is wrong (L1 1.165); what the failure looks like."""
    scene = vifpk_scene("paper-base")
    with pytest.raises(AssertionError) as failure:
        assert_averaging_error(scene, WhiteNoiseEnvelope(scene), below=0.08, **MC)
    message = str(failure.value)
    print(message)
    assert "averaging error of WhiteNoiseEnvelope on p(A): L1 =" in message
    assert "reproduce: vifpk solve" in message
