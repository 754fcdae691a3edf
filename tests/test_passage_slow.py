"""The time-domain workflows end to end with the real solvers (slow tier, tens of seconds each):
`vifpk passage` and `vifpk transient` on paper-base, `vifpk passage` on a user-defined system
(a scene file of the user's).

Tolerances come from the runs' own error bars (the averaged SDE's Monte Carlo against its
model's quadrature: 3 standard errors, harness.workflows.passage.SAMPLING_Z) or from check's
sampling rule (2.5 x the noise floor, harness.workflows.verdict.SAMPLING_FACTOR), never from a
stored number."""

from __future__ import annotations

import json
import math

import pytest
from vifpk.harness.cli.app import main
from vifpk.harness.workflows.passage import CENSORED_WARN
from vifpk.harness.workflows.verdict import SAMPLING_FACTOR

pytestmark = pytest.mark.slow
# xdist_group "passage-paper-base": the tests that run paper-base's passage kernel shape go to
# one worker (CI's --dist loadgroup), so it is compiled once (tests/test_passage_mc.py too)


def _run(args, capsys):
    code = main(args)
    cap = capsys.readouterr()
    assert code == 0, cap.err
    return cap


@pytest.mark.xdist_group("passage-paper-base")
def test_passage_paper_base(tmp_path, capsys):
    """Ac = 0.5 from the stationary law: MFPT ~ 1e2 time units (docs/passage.md). The two
    routes of each model agree within the quadrature's error plus the FPK's grid error
    (int R dt on 400 cells: second order, 1e-3 is ~100x what docs/passage.md measures); each
    averaged SDE's MFPT lies within 3 standard errors of its model's quadrature; the horizon
    rule leaves fewer than 1% of the original system's paths censored."""
    out = tmp_path / "p"
    cap = _run(["passage", "paper-base", "--threshold", "0.5", "--model", "exact",
                "--model", "corrected", "--paths", "256", "--out", str(out), "--quiet"], capsys)
    assert "recommended model for first passage" in cap.out
    doc = json.loads((out / "metrics.json").read_text())
    orig = doc["mfpt"]["original_system"]
    assert orig["paths"] == 256 and orig["stderr"] > 0
    assert orig["censored"] / orig["paths"] < CENSORED_WARN
    for m in ("exact", "corrected"):
        mf, e = doc["mfpt"][m], doc["models"][m]
        assert abs(mf["routes_rel_diff"]) < 1e-3, mf
        assert e["sde"]["sampling_ok"], e["sde"]
        assert math.isfinite(e["mfpt_error"]["value"]) and e["mfpt_error"]["err"] > 0
        assert e["R_sup"]["floor"] > 0
    assert (out / "report.html").stat().st_size > 10_000


def test_transient_paper_base(tmp_path, capsys):
    """From A0 = 1.0 (above the bulk): every model's averaged-SDE snapshots agree with its FPK
    snapshots within check's sampling rule (2.5 x the noise floor), and a relaxation time is
    measured on the original system."""
    out = tmp_path / "t"
    _run(["transient", "paper-base", "--start", "1.0", "--times", "5,10,20,40,80",
          "--model", "exact", "--paths", "256", "--out", str(out), "--quiet"], capsys)
    doc = json.loads((out / "metrics.json").read_text())
    meas = doc["relaxation"]["original_system"]
    assert meas is not None and meas["value"] > 0 and meas["err"] > 0
    assert doc["relaxation"]["exact"]["predicted"] > 0
    for row in doc["models"]["exact"]["snapshots"]:
        s = row["sampling"]
        assert s["L1"] <= SAMPLING_FACTOR * s["L1_floor"], row


#: a user's own scene file: a pure cubic spring (k1 = 0: outside the paper's family, which needs
#: omega0 > 0), OU noise, the paper's friction and one Newton wall at 0. Its Monte Carlo record
#: has paper-base's shape (a cubic spring, one damping term, friction on), so its kernels are
#: the ones the paper-base tests compile (a quintic spring compiled two more, ~16 s cold).
USER_SCENE = """name = "user-cubic"
description = "a user's system outside the paper's family: x'' + 0.01 x' + x^3 + mu sgn(x')"
[system]
restoring = [0.0, 1.0]
damping = [0.01]
mu = 0.001
r = 0.98
f = 1.0
[noise]
kind = "ou"
D = 0.05
alpha1 = 2.0
"""


@pytest.mark.xdist_group("passage-paper-base")
def test_passage_user_defined_system(tmp_path, capsys):
    """A scene file of the user's (USER_SCENE, outside the paper's family): exact and corrected
    only, the paper model named absent with the reason, and the original system's MFPT (64
    paths: no number is compared, the workflow's precision is test_passage_paper_base's)."""
    scene = tmp_path / "user.toml"
    scene.write_text(USER_SCENE)
    out = tmp_path / "q"
    cap = _run(["passage", str(scene), "--threshold", "0.9", "--paths", "64", "--out",
                str(out), "--quiet"], capsys)
    assert "paper model: not checked, the paper's model needs omega0 > 0" in cap.out
    doc = json.loads((out / "metrics.json").read_text())
    assert set(doc["models"]) == {"exact", "corrected"} and "paper" in doc["models_absent"]
    assert doc["mfpt"]["original_system"]["value"] > 0
