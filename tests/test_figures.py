"""`vifpk figures` end to end on one figure with a small Monte Carlo."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from vifpk.harness.cli.app import main


@pytest.mark.slow
def test_figures_command(tmp_path: Path):
    out = tmp_path / "figs"
    assert main(["figures", "--out", str(out), "--figure", "6", "--paths", "64", "--time", "50",
                 "--quiet"]) == 0
    assert (out / "paper-fig6.png").stat().st_size > 10_000
    table = json.loads((out / "figures.json").read_text())
    assert table["figure6"]["values"] == [0.96, 0.968, 0.975]
    assert table["provenance"]["command"].startswith("vifpk figures")  # issue 13.2
    assert "| 6 | r = 0.968 |" in (out / "figures.md").read_text()
