"""Issue 45 item 1 (docs/edges.md round 8): the wall tables' messages and magnitudes. Each case
failed at bd11bcf; all are refusals before any work, run in-process (``main([...])``), fast."""

from __future__ import annotations

import pytest
from vifpk.harness.cli.app import main

BD = "systems/bilateral-duffing"
HEAD = """name = "w"
[system]
restoring = [1.0, 0.5]
damping = [0.01]
f = 1.0
{walls}
[noise]
kind = "white"
D = 0.005
"""


@pytest.mark.parametrize("walls, words", [
    # no did-you-mean inside a wall table ("unknown key; allowed: at, law, r"),
    # while [parametric] had one; the case of a key is ignored (AT is at)
    ("[system.lower_wall]\nat = -0.6\nrr = 0.9\n", "system.lower_wall.rr: unknown key; did "
                                                    "you mean 'r'?"),
    ("[system.lower_wall]\nAT = -0.6\n", "system.lower_wall.AT: unknown key; did you mean "
                                         "'at'?"),
    ("[system.lower_wall]\nat = -0.6\nzz = 1\n", "allowed: at, law, r"),
    # %g rounded 1.0000001 to "1", which then read as "r = 1 is out of range"
    ("[system.lower_wall]\nat = -0.6\nr = 1.0000001\n", "system.lower_wall.r = 1.0000001 is "
                                                         "out of range; allowed: 0 < r <= 1"),
    # "-0" printed for a wall at -0.0
    ("[system.lower_wall]\nat = -0.0\n[system.upper_wall]\nat = 0.0\n",
     "system.lower_wall.at = 0 and upper_wall.at = 0 leave no room"),
    # the 1e-100 magnitude rule of every physical length applied to [parametric] but not to a
    # wall's position: at = -1e-300 or a subnormal -1e-320 went to the solvers
    ("[system.lower_wall]\nat = -1e-300\n", "system.lower_wall.at = -1e-300 is out of range; "
                                            "allowed: 0 or 1e-100 <= |at| <= 1e+100"),
    ("[system.lower_wall]\nat = -1e-320\n", "system.lower_wall.at = -1e-320 is out of range"),
    ("[system.lower_wall]\nat = -0.6\n[system.upper_wall]\nat = 5e-324\n",
     "system.upper_wall.at = 5e-324 is out of range"),
])
def test_wall_table_messages(tmp_path, capsys, walls, words):
    s = tmp_path / "w.toml"
    s.write_text(HEAD.format(walls=walls))
    assert main(["solve", str(s), "--model", "exact"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert words in err, err


@pytest.mark.parametrize("args, words", [
    # answered "system.r and system.lower_wall both set the walls" (paper-base has r)
    (["solve", "paper-base", "--model", "exact", "--set", "system.lower_wall=-0.2"],
     "system.lower_wall is a table (keys at, r, law, v_yield), not a value; set one of its "
     "keys, e.g. system.lower_wall.at=-0.2"),
    (["solve", BD, "--model", "exact", "--set", "system.upper_wall=0.5"],
     "system.upper_wall is a table"),
    (["solve", BD, "--model", "exact", "--set", "system.lower_wall.rr=0.5"],
     "did you mean 'r'?"),
    (["solve", BD, "--model", "exact", "--set", "system.lower_wall.at=-1e-200"],
     "system.lower_wall.at = -1e-200 is out of range"),
])
def test_wall_messages_from_set(capsys, args, words):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert words in err, err


def test_a_wall_at_minus_zero_is_the_wall_at_zero():
    """at = -0.0 is stored as 0.0 (it printed as "-0" in messages and reports)."""
    import math

    import vifpk

    s = vifpk.scene(BD, **{"system.lower_wall.at": -0.0})
    assert s.system.walls[0].at == 0.0 and math.copysign(1.0, s.system.walls[0].at) == 1.0


def test_varying_a_wall_table_says_it_is_a_table(tmp_path):
    """A sweep varying "system.lower_wall" was refused as "only numeric parameters can
    vary", which sends the user looking for a number; it names the table's keys."""
    from vifpk.harness.sweeps.errors import SweepError
    from vifpk.harness.sweeps.spec import load_sweep

    p = tmp_path / "s.toml"
    p.write_text(f'scene = "{BD}"\nworkflow = "check"\n[vary]\n"system.lower_wall" = '
                 '[-0.2, -0.3]\n')
    with pytest.raises(SweepError, match=r"'system.lower_wall': is a table \(keys at, r, "
                                         r"law, v_yield\), not a value; vary or set one of its "
                                         r"keys, e.g. system.lower_wall.at"):
        load_sweep(p)
