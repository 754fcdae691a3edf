"""The Monte Carlo's own timing record (montecarlo/timing.py, issue 44): the stages of a run,
wall and CPU, that add up to its total; and what a stationary run imports."""

from __future__ import annotations

import subprocess
import sys

import pytest
from vifpk.montecarlo.timing import Laps


def test_laps_add_up_to_the_total():
    laps = Laps()
    sum(i * i for i in range(200_000))
    laps.lap("a")
    laps.lap("b")
    sum(i * i for i in range(100_000))
    laps.lap("a")  # a stage run twice adds up
    rec = laps.record()
    assert list(rec["stages"]) == ["a", "b"]
    for clock in ("wall", "cpu"):
        parts = sum(v[clock] for v in rec["stages"].values())
        assert 0 <= parts <= rec["total"][clock]
        assert rec["stages"]["a"][clock] >= rec["stages"]["b"][clock]


@pytest.mark.slow
def test_a_stationary_run_imports_no_scipy_stats_and_no_other_driver():
    """The command line's solve path (the parser with every workflow, the door, the
    stationary Monte Carlo) loads neither scipy.stats nor scipy.optimize (0.8 s and 0.5 s of
    imports, issue 44), nor the first-passage, transient or averaged-SDE drivers."""
    code = ("import sys\n"
            "from vifpk.harness.cli import app\n"
            "app.build_parser()\n"
            "from vifpk import montecarlo\n"
            "montecarlo.simulate\n"
            "import vifpk.harness.door.solvers\n"
            "print(' '.join(sorted(sys.modules)))\n")
    mods = set(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              check=True).stdout.split())
    for heavy in ("scipy.stats", "scipy.optimize", "scipy.interpolate", "matplotlib",
                  "xarray", "dask", "pde", "vifpk.montecarlo.passage",
                  "vifpk.montecarlo.transient", "vifpk.montecarlo.sde_time",
                  "vifpk.montecarlo.averaged_sde"):
        assert heavy not in mods, heavy
