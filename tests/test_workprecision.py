"""Work-precision: a small ladder end to end; the error falls as the cost rises."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from vifpk.harness.cli.app import main
from vifpk.harness.workflows.workprecision import (
    DT_LADDER,
    TARGETS,
    reference_floor,
    run_error,
    seconds_to_reach,
    timed,
)


def test_timed_records_nan_on_failure():
    """A solver's failure is a NaN point with its reason; anything else is a bug and
    propagates (issue 27: no exception returned as a result, none swallowed)."""
    from vifpk.harness.door.solvers import SolverFailure
    from vifpk.harness.workflows.workprecision import Failed

    def boom():
        raise SolverFailure("x")

    out, first, best = timed(boom, repeats=2)
    assert out == Failed("x") and math.isnan(first) and math.isnan(best)

    def bug():
        raise KeyError("y")

    with pytest.raises(KeyError):
        timed(bug, repeats=0)
    out, first, best = timed(lambda: 3, repeats=2)
    assert out == 3 and best <= first + 1e-3


def test_seconds_to_reach_takes_the_cheapest_run():
    pts = [{"seconds": 1.0, "error": 1e-2}, {"seconds": 2.0, "error": 1e-3},
           {"seconds": 0.5, "error": 5e-3}, {"seconds": math.nan, "error": math.nan}]
    row = seconds_to_reach({"s": pts})["s"]
    assert row["0.01"] == 0.5 and row["0.001"] == 2.0 and math.isnan(row["0.0001"])


@pytest.mark.slow
def test_small_ladder_end_to_end(tmp_path: Path, capsys):
    out = tmp_path / "wp"
    assert main(["workprecision", "paper-base", "--quick", "--repeats", "1", "--out", str(out),
                 "--quiet"]) == 0
    d = json.loads((out / "workprecision.json").read_text())
    assert (out / "workprecision.png").stat().st_size > 10_000
    assert d["provenance"]["scene"]["path"].endswith("paper-base.toml")  # issue 13.2
    for name, pts in d["solvers"].items():
        for p in pts:
            assert {"setting", "seconds", "error"} <= set(p), name
    # deterministic solvers: the error falls as the resolution (and the cost) rises; the
    # ladder steps are 2x apart, far above the timing noise (tolerance: 1e-12 for ties)
    for name in ("closed form (paper)", "FPK direct (paper)"):
        errs = [p["error"] for p in d["solvers"][name]]
        assert np.all(np.diff(errs) < 1e-12), (name, errs)
    # Monte Carlo: the error falls with the samples within its noise floor
    for name in ("MC averaged SDE (paper)", "MC original system"):
        pts = d["solvers"][name]
        a, b = pts[0], pts[-1]
        assert b["error"] <= a["error"] + 2 * a["error_floor"], (name, pts)
    assert "best_dt_for_budget" in d["mc_bias_variance"]
    # the seconds-to-reach table and the split table count the same runs the same way
    reach = d["seconds_to_reach"][DT_LADDER]
    for r in d["mc_bias_variance"]["ladder"]:
        for t in TARGETS:
            if r["error"] <= t:
                assert reach[f"{t:g}"] <= r["seconds"], (r, reach)
    printed = capsys.readouterr()
    table = (out / "workprecision.md").read_text()
    assert (printed.out + printed.err).count(table.splitlines()[0]) == 1  # printed once


def test_run_error_removes_the_reference_noise_only():
    # sum sqrt(2/pi) se w over 4 bins of width 0.5 with se = 0.01: 0.02 sqrt(2/pi)
    ref = {"edges": np.linspace(0, 2, 5), "err": np.full(4, 0.01), "p": np.ones(4), "x": 0}
    assert reference_floor(ref) == pytest.approx(0.02 * math.sqrt(2 / math.pi), rel=1e-12)
    assert reference_floor({"x": np.zeros(3), "p": np.zeros(3)}) == 0.0
    assert run_error(0.005, 0.003) == pytest.approx(0.004, rel=1e-12)
    assert run_error(0.002, 0.003) == 0.0
