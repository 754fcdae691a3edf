"""Issue 45 item 1 (docs/edges.md round 8): the time domain's reproducers. Fast tier on
tests/time_doubles.py's known answers (the doors replaced, the workflow's, request's and
command's own code run); the real runs are marked slow."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests import time_doubles as td
from tests.test_edges7_timeapi import far_tail, split_doubles  # noqa: F401 (fixtures)
from tests.test_time_request import tiny  # noqa: F401 (a fixture)

OP = "systems/offset-parametric"
BD = "systems/bilateral-duffing"


def test_splitting_has_a_cycle_start_for_every_particle(split_doubles, tmp_path, capsys):  # noqa: F811
    """``vifpk passage systems/offset-parametric --threshold 30 --start 0.3``: --method auto
    turned to splitting, whose first run died out at 200 particles; the retry at 400 died as
    "internal error: ValueError: paths x cycles = 200 < particles = 400 ... please report it"
    (exit 1, 31 s): the direct paths that give the AMS runs their starts stayed 8 x 25. Now
    the door gives as many paths as the particles need (paths x cycles >= particles)."""
    import vifpk.montecarlo.splitting as splitting
    from vifpk.harness.cli.app import main
    from vifpk.montecarlo.cycles import groups_direct

    seen = []
    double = splitting.passage_splitting

    def split(system, noise, s, **kw):  # the settings meet groups_direct's own check
        seen.append((s.particles, s.paths, s.cycles))
        if s.paths * s.cycles < s.particles:
            groups_direct(None, None, 0.0, 0.0, 0.0, s, 0, 1)  # raises the ValueError
        return double(system, noise, s, **kw)

    splitting.passage_splitting = split
    try:
        split_doubles["need"] = 800
        out = tmp_path / "s"
        code = main(["passage", "paper-base", "--threshold", "1.2", "--start", "0.1",
                     "--method", "splitting", "--model", "exact", "--quiet", "--out",
                     str(out)])
    finally:
        splitting.passage_splitting = double
    assert code == 0, capsys.readouterr().err
    assert [p for p, _, _ in seen] == [200, 400, 800]
    assert all(paths * cycles >= particles for particles, paths, cycles in seen), seen
    assert seen[0][1] == 8  # the default run keeps its 8 direct paths


def test_api_passage_takes_method_auto_as_the_command_does(split_doubles, far_tail):  # noqa: F811
    """``vifpk.passage(..., method="auto")`` was refused ("allowed: direct, splitting")
    although ``--method auto`` is the command's default. Now it chooses as the command does:
    out of direct reach (the quadratures of threshold 2.0 put the MFPT at 1e118), splitting,
    with the reason; no direct run is started (far_tail records any)."""
    import vifpk

    split_doubles["need"] = 0
    res = vifpk.passage("paper-base", threshold=2.0, start=0.1, method="auto",
                        models=("exact",))
    assert type(res).__name__ == "SplittingResult"
    assert far_tail == []
    assert res.metrics["method_reason"].startswith("chosen automatically: threshold 2: "
                                                      "the averaged models put the MFPT")


def test_api_passage_auto_within_reach_runs_direct(monkeypatch, tiny):  # noqa: F811
    """Within the hour, method="auto" is the direct run (a PassageResult)."""
    import vifpk

    td.install(monkeypatch)
    res = vifpk.passage(tiny, threshold=2.0, start=0.5, method="auto", models=("exact",),
                        sde=False)
    assert type(res).__name__ == "PassageResult"


def test_a_threshold_whose_mfpt_overflows_is_refused_before_any_run(monkeypatch, tmp_path,
                                                                   capsys):
    """``vifpk passage w2.toml --threshold 1e6`` (a two-wall scene): exit 3 after the closed
    forms ("the MFPT overflows"); every model's quadrature overflowing means no method
    reaches it: exit 2, one line, before any R(t) stepping or Monte Carlo, nothing written.
    (The real command on systems/bilateral-duffing: exit 2, the same line, in the closed
    forms' seconds: docs/edges.md round 8.)"""
    import vifpk.harness.door.timedomain as door
    from vifpk.harness.cli.app import main
    from vifpk.harness.door.solvers import SolverFailure

    td.install(monkeypatch)

    def overflow(scene, model, *, threshold, start):
        raise SolverFailure(f"the MFPT overflows (> 1e308 time units) at threshold "
                            f"{threshold:g}: far beyond reach")

    def forbidden(*a, **k):
        raise AssertionError("a run was started")

    monkeypatch.setattr(door, "mfpt_averaged", overflow)
    for name in ("passage_averaged", "passage_montecarlo", "passage_sde", "passage_splitting"):
        monkeypatch.setattr(door, name, forbidden)
    out = tmp_path / "o"
    assert main(["passage", "paper-base", "--threshold", "1e6", "--quiet", "--out",
                 str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and ("--threshold 1e+06: the averaged models (paper, exact, "
                                     "corrected) put the MFPT beyond 1e308 time units") in err
    assert not out.exists()
    import vifpk
    from vifpk.core.result import BadInput

    with pytest.raises(BadInput, match="beyond 1e308 time units"):
        vifpk.passage("paper-base", threshold=1e6, method="auto")


def test_every_path_of_the_averaged_sde_censored_is_not_a_nan(monkeypatch, tiny):  # noqa: F811
    """A horizon that censors every path on a two-wall scene (``--horizon 0.5``) ended "not
    finite: models.exact.sde.z; no report written" (exit 3): the averaged SDE's sampling
    check divided by a zero standard error. Now the check is skipped (z is None, "no sampling
    check"), the metrics are finite and the verdict is NOT AN ESTIMATE (docs/passage.md)."""
    from vifpk.harness.cli.timedomain import _finite
    from vifpk.harness.workflows.passage import passage

    td.install(monkeypatch)
    monkeypatch.setattr(td, "T_ORIGINAL", 1e12)
    monkeypatch.setitem(td.T_MODEL, "exact", 1e12)
    res = passage(tiny, threshold=2.0, start=0.5, models=("exact",), horizon=5.0, sde=True)
    e = res.metrics["models"]["exact"]
    assert e["sde"]["z"] is None and e["sde"]["sampling_ok"]
    assert "no sampling check" in e["sde"]["not_an_estimate"]
    _finite(res.metrics)
    json.dumps(res.metrics)
    assert e["verdict_class"] == "not an estimate"
    assert np.isfinite(e["sde"]["mfpt"]["stderr"]) or e["sde"]["mfpt"]["stderr"] == 0


def test_a_relaxation_time_whose_interval_reaches_zero_is_not_a_measurement(monkeypatch,
                                                                           tiny):  # noqa: F811
    """"measured on the original system 3.232e+04 +/- 9.3e+08 (within the error bar: -99.9% +/-
    1617.8%)": a fit whose two-error-bar interval reaches tau <= 0 pins no time scale. Now it
    is not reported (NOT AN ESTIMATE, a warning saying what would pin it); the models' own
    fitted relaxation times stay."""
    import vifpk.harness.workflows.transient as tr

    td.install(monkeypatch)
    fit = tr.fit_relaxation

    def loose(times, means, start):
        f = fit(times, means, start)
        if any(e > 0 for _, e in means):  # the original system's means (the models' have 0)
            return {**f, "value": 3.232e4, "err": 9.3e8}
        return f

    monkeypatch.setattr(tr, "fit_relaxation", loose)
    res = tr.transient(tiny, start=0.5, times=(5.0, 10.0, 20.0, 40.0), models=("exact",),
                       sde=False)
    assert res.metrics["relaxation"]["original_system"] is None
    line = res.verdicts[0]
    assert "9.3e+08" not in line and "not measured on the original system" in line
    assert any("relaxation time is not measured: its fit gives 3.232e+04 +/- 9.3e+08" in w
               for w in res.warnings), res.warnings
    assert not any("needs at least" in w for w in res.warnings)
    assert res.metrics["models"]["exact"]["relaxation"]["fitted"] is not None
