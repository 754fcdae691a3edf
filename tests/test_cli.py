"""The command line: contracts of `vifpk solve`, and bad input (exit 2, one line, no file)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from vifpk.harness.cli.app import main

from tests.conftest import ROOT

BASE = str(ROOT / "scenes" / "paper-base.toml")


@pytest.mark.parametrize("model", ["paper", "exact", "corrected"])
def test_solve_json_contract(tmp_path: Path, model: str):
    out = tmp_path / "sol.json"
    assert main(["solve", BASE, "--solver", "averaging", "--model", model, "--json",
                 str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["solver"] == "averaging" and d["model"] == model
    assert d["scene"]["system"]["r"] == 0.96
    # the JSON round trip is exact (json writes floats with repr): the densities in the file
    # are bit for bit the solver's (their normalisation is the solver's own doing)
    from vifpk.harness.door.solvers import closed_form

    from vifpk.core.scene import load_scene

    ref = closed_form(load_scene(BASE), model=model).data
    for key in ("A", "x1", "x2"):
        x, p = np.array(d["pdf"][key]["x"]), np.array(d["pdf"][key]["p"])
        assert np.array_equal(x, ref[key]["x"]) and np.array_equal(p, ref[key]["p"])
    assert d["info"]["status"]["ok"] is True
    assert not list(tmp_path.glob(".*tmp"))  # no temporary file left behind


def test_solve_prints_summary(capsys):
    assert main(["solve", BASE]) == 0
    out = capsys.readouterr().out
    assert "mean" in out and "mode" in out and "mass check: 1.0000000000" in out


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "vifpk", *args], capture_output=True,
                          text=True, timeout=120, cwd=ROOT)


@pytest.mark.parametrize(
    ("body", "needle"),
    [
        ("[system]\nr = 1.2\n", "system.r = 1.2 is out of range; allowed: 0 < r <= 1"),
        ("[noise]\nD = -1\n", "noise.D = -1 is out of range"),
        ("[noise]\nD = nan\n", "noise.D = nan"),
        ("[system]\nmuu = 0.1\n", "did you mean 'mu'?"),
        ("[noise]\nkind = 'pink'\n", "noise.kind = 'pink'"),
        ("[system\n", "not valid TOML"),
    ],
)
def test_bad_input_one_line_exit_2_no_file(tmp_path: Path, capsys, body: str, needle: str):
    """In process (an uncaught exception fails the test); the TOML error also in a fresh
    interpreter, for the console path (exit code, no traceback): one case says it for all, as
    in tests/test_cli_validation.py (each interpreter costs ~1 s)."""
    scene = tmp_path / "bad.toml"
    scene.write_text(body)
    out = tmp_path / "out.json"
    assert main(["solve", str(scene), "--json", str(out)]) == 2
    err = capsys.readouterr().err
    assert needle in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists() and list(tmp_path.iterdir()) == [scene]
    if "TOML" in needle:
        res = run_cli("solve", str(scene), "--json", str(out))
        assert res.returncode == 2
        assert needle in res.stderr
        assert len(res.stderr.strip().splitlines()) == 1 and "Traceback" not in res.stderr
        assert not out.exists() and list(tmp_path.iterdir()) == [scene]


def test_sweep_scene_needs_a_value(tmp_path: Path):
    res = run_cli("solve", str(ROOT / "scenes" / "paper-fig2.toml"))
    assert res.returncode == 2 and "--set noise.D=VALUE" in res.stderr


def test_no_stationary_density_is_one_line_exit_3(tmp_path: Path):
    out = tmp_path / "o.json"
    res = run_cli("solve", BASE, "--set", "system.f=0", "--json", str(out))
    assert res.returncode == 3 and "no stationary density" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and not out.exists()


def test_unknown_option_exit_2():
    res = run_cli("solve", BASE, "--model", "nonsense")
    assert res.returncode == 2 and "Traceback" not in res.stderr


def test_montecarlo_json_has_edges_and_errors(tmp_path: Path):
    out = tmp_path / "mc.json"
    assert main(["solve", BASE, "--solver", "montecarlo", "--paths", "64", "--time", "50",
                 "--dt", "0.02", "--seed", "3", "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["solver"] == "montecarlo" and d["info"]["settings"]["paths"] == 64
    assert d["info"]["seed"]["root"] == 3 and d["info"]["settings"]["dt"] == 0.02
    for key in ("A", "x1", "x2"):
        rec = d["pdf"][key]
        assert len(rec["edges"]) == len(rec["p"]) + 1 == len(rec["err"]) + 1
    assert d["info"]["L1_floor"]["A"] > 0
    # the run's timing record (montecarlo/timing.py): its stages, then the process's own
    t = d["info"]["timing"]
    assert list(t["stages"]) == ["plan", "kernel", "scale_pilot", "relaxation_pilot",
                                 "burn_in", "sampling", "densities", "certificate", "result"]
    assert {"startup", "request", "door", "record", "process", "total"} <= set(t)
    assert all(v["cpu"] >= 0 and v["wall"] >= 0 for v in t["stages"].values())
    # the process's stages around the run's: the run's own total lies within the door call
    # (one clock for both: the door's residual is not negative), the record after it
    for clock in ("wall", "cpu"):
        assert t["door"][clock] >= 0 and t["record"][clock] >= 0, clock
        assert t["process"][clock] >= t["startup"][clock] + t["total"][clock], clock


def test_fpk_json(tmp_path: Path):
    out = tmp_path / "f.json"
    assert main(["solve", BASE, "--solver", "fpk", "--grid", "200", "--json", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["solver"] == "fpk" and d["info"]["grid"]["cells"] == 200
    x, p = np.array(d["pdf"]["A"]["x"]), np.array(d["pdf"]["A"]["p"])
    # the summary's mean was computed from the same arrays before writing: the round trip
    # keeps it to rounding (json floats are exact; 1e-12 covers the re-summation)
    assert np.trapezoid(x * p, x) == pytest.approx(d["info"]["summary"]["mean"], rel=1e-12)


def test_budget_too_small_for_the_pilots_is_refused_up_front(capsys):
    """Issue 19 bug 1: the pilots and the first sampling windows cannot fit in 0.01 s (their
    path-steps at the cost estimate's rate, a lower bound of the wall time): exit 2 naming
    --budget, before any computation (it used to run the pilots and die with a ValueError)."""
    code = main(["solve", BASE, "--solver", "montecarlo", "--floor", "1e-4", "--budget",
                 "0.01"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "--budget (montecarlo.budget) = 0.01" in err and "or 0 for no limit" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_budget_spent_before_the_first_window_exits_3_with_one_line(monkeypatch, capsys):
    """A budget above the up-front lower bound that still runs out in the pilots (here the
    bound is disabled by an infinite assumed speed): exit 3, one line, no file written."""
    from vifpk.harness.request import cost

    monkeypatch.setattr(cost, "MC_STEPS_PER_CORE", math.inf)
    code = main(["solve", BASE, "--solver", "montecarlo", "--paths", "64", "--floor", "1e-4",
                 "--budget", "1e-6", "--set", "montecarlo.burn_in=20"])
    err = capsys.readouterr().err
    assert code == 3, err
    err = err[err.find("vifpk: "):]  # after the progress bar, when it showed (a slow pilot)
    assert err.startswith("vifpk: the budget of 1e-06 s ran out before the first sampling "
                          "window")
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def _raising_in(module: str, exc: BaseException):
    """A function whose code runs as part of ``module`` (its globals' __name__), raising
    ``exc`` there: the boundary tells a solver's own frame from the harness's by that name."""
    namespace = {"__name__": module, "exc": exc}
    exec("def failing(*a, **k):\n    raise exc\n", namespace)  # noqa: S102 - test double
    return namespace["failing"]


@pytest.mark.parametrize("exc, line", [
    (FloatingPointError("overflow encountered in exp"),
     "vifpk: numerical failure: overflow encountered in exp; the scene's magnitudes or the "
     "step are most likely too extreme"),
    (ValueError("drift or diffusion is not finite on the table"),
     "vifpk: drift or diffusion is not finite on the table")])
def test_a_solver_failure_is_mapped_at_the_door_one_line_exit_3(monkeypatch, capsys, exc, line):
    """A solver's numerical failure (an ArithmeticError, or a non-finite value a solver reports
    from its own code) leaves the door as SolverFailure: one line, exit 3 (issue 27: mapped at
    the solver boundary only; issue 38: only numerical failures)."""
    import vifpk.averaging

    monkeypatch.setattr(vifpk.averaging, "solve", _raising_in("vifpk.averaging.solve", exc))
    code = main(["solve", BASE, "--solver", "averaging"])
    err = capsys.readouterr().err
    assert code == 3, err
    assert err.strip() == line


@pytest.mark.parametrize("module, exc", [
    # a numpy shape error made inside a solver's code by arguments it should not have had
    ("vifpk.averaging.solve", ValueError("operands could not be broadcast together with "
                                         "shapes (3,) (4,)")),
    # a solver's argument check reached: the request layer should have refused it first
    ("vifpk.averaging.solve", ValueError("no sample was taken: time must be at least "
                                         "sample_every")),
    # a non-finite wording raised by harness code, not a solver's: still a bug
    ("vifpk.harness.workflows.check", ValueError("drift or diffusion is not finite"))])
def test_a_callers_mistake_through_a_door_call_is_an_internal_error(monkeypatch, capsys,
                                                                     module, exc):
    """Issue 38: door/boundary.py turned every ValueError inside a door call into "the solver
    could not produce a result" (exit 3). A caller's mistake through a door call is an internal
    error: in process the ValueError itself (not SolverFailure), on the command line exit 1
    with the traceback under --debug."""
    import vifpk.averaging
    from vifpk.harness.door.solvers import SolverFailure, run_solver

    from vifpk.core.scene import load_scene

    monkeypatch.setattr(vifpk.averaging, "solve", _raising_in(module, exc))
    with pytest.raises(ValueError) as raised:
        run_solver(load_scene(BASE), "averaging")
    assert not isinstance(raised.value, SolverFailure) and raised.value is exc
    code = main(["--debug", "solve", BASE, "--solver", "averaging"])
    err = capsys.readouterr().err
    assert code == 1, err
    assert "Traceback" in err
    assert err.strip().splitlines()[-1].startswith(f"vifpk: internal error: ValueError: {exc}")


def test_a_value_error_outside_the_solvers_is_an_internal_error(monkeypatch, capsys):
    """A ValueError raised by harness code (not a solver's) is a bug, not exit 3 (issue 27: the
    old broad mapping hid bugs as 'the solver could not'): in process it propagates; under
    --debug it is one line with the traceback before it, exit 1."""
    from vifpk.harness.cli import app

    def boom(args):
        raise ValueError("a bug in the harness")

    parser = app.build_parser
    monkeypatch.setattr(app, "build_parser", lambda: _with_func(parser(), boom))
    with pytest.raises(ValueError, match="a bug in the harness"):
        main(["solve", BASE])
    code = main(["--debug", "solve", BASE])
    err = capsys.readouterr().err
    assert code == 1, err
    assert err.startswith("Traceback"), err
    assert err.strip().splitlines()[-1].startswith(
        "vifpk: internal error: ValueError: a bug in the harness"), err


def _with_func(parser, func):
    for action in parser._subparsers._group_actions:
        for sub in action.choices.values():
            sub.set_defaults(func=func)
    return parser
