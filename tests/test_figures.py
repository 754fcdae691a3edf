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


def test_a_concrete_wall_scene_is_a_sweep_of_one_value_that_loads():
    """`vifpk figures --scene systems/bilateral-duffing` was refused ("system.r and
    system.lower_wall both set the walls"): a concrete scene became a 'sweep' of system.r,
    which a scene with wall tables cannot set. It is now one value of system.mu, a key of
    every scene; each row's scene loads with its walls as they are (round 8)."""
    from vifpk.harness.workflows.figures import as_sweep

    from vifpk.core.scene import load_scene

    for name in ("systems/bilateral-duffing", "systems/bilateral-duffing-bounded", "paper-base"):
        base = load_scene(name)
        sw = as_sweep(base).sweep
        rows = [base.with_values({sw.path: v}) for v in sw.values]
        assert [r.system.walls for r in rows] == [base.system.walls]
