"""Issue 45 item 1 (docs/edges.md round 8): sweep files' faults named where they were written,
and Ctrl-C before the first point leaves nothing. Fast: the files are refused before any work;
the interrupted run's runner is a double."""

from __future__ import annotations

from pathlib import Path

import pytest
from vifpk.harness.sweeps.errors import SweepError
from vifpk.harness.sweeps.spec import load_sweep

ROOT = Path(__file__).resolve().parents[1]
BD = "systems/bilateral-duffing"
HEAD = ('scene = "' + BD + '"\nworkflow = "{wf}"\nmodels = ["exact"]\n{extra}\n[vary]\n'
        '"system.mu" = [0.0, 0.01]\n[set]\n"montecarlo.paths" = 64\n{set}')


@pytest.mark.parametrize("wf, extra, set_, expected", [
    # a [set] fault read "at the point system.mu = 0: system.lower_wall.r = 2 ..." (the
    # point's varied value is not the fault)
    ("check", "", '"system.lower_wall.r" = 2.0\n',
     "s.toml: [set]: system.lower_wall.r = 2 is out of range; allowed: 0 < r <= 1"),
    # a [transient] start fault read "at the point system.mu = 0: --start -1: ..."
    ("transient", "[transient]\nstart = -1\ntimes = [1, 2, 3]\n", "",
     "s.toml: [transient] start -1: out of range; allowed: a finite amplitude > 0"),
    ("passage", "[passage]\nthreshold = 0.5\nstart = 0.1\nhorizon = 1e-300\n",
     '"parametric.stiffness" = 0\n',
     "s.toml: [passage] horizon 1e-300: shorter than one time step"),
])
def test_a_sweep_fault_is_named_where_it_was_written(tmp_path, wf, extra, set_, expected):
    p = tmp_path / "s.toml"
    p.write_text(HEAD.format(set=set_, wf=wf, extra=extra))
    with pytest.raises(SweepError) as exc:
        load_sweep(p)
    assert str(exc.value).startswith(expected), str(exc.value)
    assert "at the point" not in str(exc.value) and "\n" not in str(exc.value)


def test_a_varied_value_s_fault_still_names_the_point(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text(HEAD.format(set="", wf="check", extra="").replace(
        '"system.mu" = [0.0, 0.01]', '"system.lower_wall.r" = [0.9, 1.5]'))
    with pytest.raises(SweepError, match=r"at the point system.lower_wall.r = 1.5: "
                                         r"system.lower_wall.r = 1.5 is out of range"):
        load_sweep(p)


def test_ctrl_c_before_the_first_point_leaves_no_empty_folders(tmp_path, monkeypatch):
    """Ctrl-C before the first point said "no point had finished, nothing was kept" and left
    an empty out/ and out/points/; now neither is left (a folder the user made stays)."""
    import vifpk.harness.sweeps.runs as runs

    class Interrupted:
        def __init__(self, spec):
            pass

        def completed(self, jobs):
            raise KeyboardInterrupt
            yield  # a generator, as the real runner's

        def stop(self):
            pass

        def close(self):
            pass

    monkeypatch.setattr(runs, "Runner", Interrupted)
    sweep = load_sweep(ROOT / "tests" / "data" / "sweep-averaging-fast.toml")
    out = tmp_path / "o"
    with pytest.raises(KeyboardInterrupt):
        runs.run_sweep(sweep, out, quiet=True, report=False)
    assert not out.exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    with pytest.raises(KeyboardInterrupt):
        runs.run_sweep(sweep, mine, quiet=True, report=False)
    assert mine.is_dir() and list(mine.iterdir()) == []


def test_a_bifurcation_sweep_finding_r_on_wall_tables_is_refused_before_work(tmp_path):
    """`workflow = "bifurcation"` with `find = "r"` on a scene whose walls are tables: every
    point failed at run time (exit 3, "2 of 2 points failed"); the workflow's own refusal now
    comes when the file is read."""
    p = tmp_path / "s.toml"
    p.write_text(HEAD.format(set="", wf="bifurcation",
                             extra='[bifurcation]\nfind = "r"\n').replace(
        'models = ["exact"]\n', ""))
    with pytest.raises(SweepError, match=r"\[bifurcation\] find = 'r': r is the restitution "
                                         r"of the paper's wall .* allowed here: find = 'mu'"):
        load_sweep(p)
