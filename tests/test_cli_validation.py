"""Issue 11: every input checked before any work (exit 2, one line naming the option or field,
no traceback, nothing written, no computation), numerical failures exit 3, Ctrl-C exits 130,
a closed pipe is quiet, numpy warnings never reach the terminal.

Every case of the catalogue runs in-process with every solver entry point replaced by one that
fails the test ("no computation started"; an uncaught exception would fail it too); one case of
each kind (option range, combination, rounding, output path, scene, cost, search range, each
command) also runs as a real `python -m vifpk` subprocess, two at a time, for the exit code
and the terminal. Each subprocess costs ~1 s of interpreter start-up, hence the subset.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from tests.conftest import ROOT

BASE = "paper-base"
MC = ("--solver", "montecarlo")

# (id, args, needle); "{tmp}" is the case's own folder, "{file}" an existing file in it,
# "{scene:BODY}" a scene file with BODY in it
CATALOGUE = [
    ("paths-3", ["solve", BASE, *MC, "--paths", "3"], "nearest valid: 64"),
    ("paths-16", ["solve", BASE, *MC, "--paths", "16"], "--paths (montecarlo.paths) = 16"),
    ("paths-31", ["solve", BASE, *MC, "--paths", "31"], "whole multiple of montecarlo.blocks"),
    ("paths-33", ["solve", BASE, *MC, "--paths", "33"], "nearest valid: 64"),
    ("paths-65", ["solve", BASE, *MC, "--paths", "65"], "nearest valid: 64 or 96"),
    ("paths-32", ["solve", BASE, *MC, "--paths", "32"], "allowed: paths >= 2 x blocks = 64"),
    ("paths-minus-64", ["solve", BASE, *MC, "--paths", "-64"], "--paths = -64 is out of range"),
    ("dt-0-figures", ["figures", "--dt", "0", "--out", "{tmp}/f"], "--dt = 0.0 is out of range"),
    ("repeats-huge", ["workprecision", BASE, "--repeats", "1000000000", "--out", "{tmp}/w"],
     "--repeats 1000000000: out of range; allowed: a whole number from 1 to 100"),
    ("phase-points-huge", ["solve", BASE, "--set", "averaging.phase_points=100000000"],
     "allowed: a whole number from 17 to 4001"),
    ("bins-huge", ["solve", BASE, *MC, "--set", "montecarlo.bins=1000000000"],
     "allowed: a whole number from 4 to 100000"),
    ("paths-8-in-file", ["solve", "{scene:[montecarlo]\npaths = 8\n}", *MC],
     "montecarlo.paths = 8 must be"),
    ("dt-10", ["solve", BASE, *MC, "--dt", "10"], "dt < 2 / omega0 = 2"),
    ("dt-2", ["solve", BASE, *MC, "--dt", "2"], "dt < 2 / omega0"),
    ("dt-1", ["solve", BASE, *MC, "--dt", "1"], "--dt (montecarlo.dt) = 1 must divide"),
    ("dt-0.03", ["solve", BASE, *MC, "--dt", "0.03"], "nearest valid: 0.02941176471 or 0.03125"),
    ("dt-omega0", ["solve", BASE, *MC, "--dt", "0.5", "--set", "system.omega0=5"],
     "dt < 2 / omega0 = 0.4"),
    ("time-0.001", ["solve", BASE, *MC, "--time", "0.001"], "allowed: time >= 0.5"),
    ("time-prime", ["solve", BASE, *MC, "--time", "1001.5"],
     "would sample 1000 (whole windows of whole samples every 0.5); nearest valid: 1001 or 1003"),
    ("time-off-grid", ["solve", BASE, *MC, "--time", "100.3"], "nearest valid: 100 or 101.5"),
    ("burn-in", ["solve", BASE, *MC, "--set", "montecarlo.burn_in=10.005"],
     "montecarlo.burn_in = 10.005 is not a whole number of steps"),
    ("grid-2", ["solve", BASE, "--solver", "fpk", "--grid", "2"], "--grid 2: out of range"),
    ("grid-minus-3", ["solve", BASE, "--solver", "fpk", "--grid", "-3"], "allowed: a whole"),
    ("grid-0", ["solve", BASE, "--solver", "fpk", "--grid", "0"], "--grid 0"),
    ("grid-averaging", ["solve", BASE, "--grid", "50"], "--grid: does not apply to --solver "
     "averaging"),
    ("grid-montecarlo", ["solve", BASE, *MC, "--grid", "50"], "--grid: does not apply"),
    ("model-montecarlo", ["solve", BASE, *MC, "--model", "exact"], "--model: does not apply"),
    ("paths-fpk", ["solve", BASE, "--solver", "fpk", "--paths", "64"], "--paths: does not"),
    ("joint-no-json", ["solve", BASE, "--joint"], "--joint: does not apply without --json"),
    ("set-twice", ["solve", BASE, "--set", "system.r=0.9", "--set", "system.r=0.95"],
     "--set system.r: given twice"),
    # two spellings of one coefficient (a scene file refuses them too; the last used to win)
    ("set-alias-and-law", ["solve", BASE, "--set", "system.restoring=[1, 0.3]", "--set",
                           "system.alpha=0.2"], "--set system.alpha: sets the restoring law"),
    ("set-alias-and-index", ["solve", BASE, "--set", "system.c1=0.1", "--set",
                             "system.damping[0]=-0.1"], "--set system.damping[0]: sets the "),
    ("json-folder", ["solve", BASE, "--json", "{tmp}"], "--json {tmp}: is a folder"),
    ("json-proc", ["solve", BASE, "--json", "/proc/vifpk.json"], "cannot write in /proc"),
    ("scene-folder", ["solve", "{tmp}"], "is a folder; give a scene file"),
    ("alpha-1e308", ["solve", "{scene:[system]\nalpha = 1e308\n}"], "system.alpha = 1e+308"),
    ("D-1e308", ["solve", "{scene:[noise]\nD = 1e308\n}"], "noise.D = 1e+308 is out of range"),
    ("D-1e-320", ["solve", "{scene:[noise]\nD = 1e-320\n}"], "noise.D = 9.99989e-321"),
    ("cost-dt", ["solve", BASE, *MC, "--dt", "1e-9"], "or add --yes"),
    ("cost-paths", ["solve", BASE, *MC, "--paths", "1e12"], "estimated at least"),
    ("cost-grid", ["solve", BASE, "--solver", "fpk", "--grid", "10000000"], "--yes"),
    ("check-out-file", ["check", BASE, "--out", "{file}"], "exists and is not a folder"),
    ("check-out-proc", ["check", BASE, "--out", "/proc/vifpk"], "cannot write in /proc"),
    ("check-paths", ["check", BASE, "--paths", "33"], "nearest valid: 64"),
    ("check-cost", ["check", BASE, "--paths", "1e9"], "this check: estimated"),
    ("range-nan", ["bifurcation", BASE, "--vary", "mu", "--range", "nan", "1"],
     "LO = nan is outside the valid values of system.mu"),
    ("range-reversed", ["bifurcation", BASE, "--vary", "mu", "--range", "0.05", "0"],
     "LO must be below HI"),
    ("range-outside", ["bifurcation", BASE, "--vary", "r", "--range", "0.9", "1.2"],
     "HI = 1.2 is outside the valid values of system.r; allowed: 0 < r <= 1"),
    ("range-negative", ["bifurcation", BASE, "--vary", "mu", "--range", "-0.01", "0.05"],
     "LO = -0.01"),
    ("no-mc-paths", ["bifurcation", BASE, "--vary", "mu", "--no-mc", "--paths", "64"],
     "--paths: does not apply with --no-mc"),
    ("bifurcation-json-folder", ["bifurcation", BASE, "--vary", "mu", "--json", "{tmp}"],
     "is a folder"),
    ("figures-out-file", ["figures", "--out", "{file}"], "--out {file}: exists and is not"),
    ("figures-time", ["figures", "--figure", "6", "--time", "1001.5"], "would sample 1000"),
    ("wp-out-file", ["workprecision", BASE, "--out", "{file}"], "exists and is not a folder"),
    ("wp-repeats-0", ["workprecision", BASE, "--repeats", "0"], "--repeats 0: out of range"),
    ("wp-paths", ["workprecision", BASE, "--paths", "64"], "--paths: does not apply to "
     "workprecision"),
    ("wp-dt-auto", ["workprecision", BASE, "--dt", "auto"], "--dt auto: does not apply"),
    # issue 30: the time-domain workflows
    ("passage-threshold-below-start", ["passage", BASE, "--threshold", "1", "--start", "1.5"],
     "--start 1.5: at or above the threshold Ac = 1"),
    ("passage-threshold-equals-start", ["passage", BASE, "--threshold", "1", "--start", "1"],
     "--start 1: at or above the threshold"),
    ("passage-threshold-0", ["passage", BASE, "--threshold", "0"], "--threshold 0: out of "
     "range; allowed: a finite amplitude > 0"),
    ("passage-threshold-nan", ["passage", BASE, "--threshold", "nan"], "--threshold nan"),
    ("passage-threshold-inf", ["passage", BASE, "--threshold", "inf"], "--threshold inf"),
    ("passage-threshold-huge", ["passage", BASE, "--threshold", "1e90"],
     "--threshold 1e+90: beyond the domain: its energy U(A) overflows"),
    ("passage-start-negative", ["passage", BASE, "--threshold", "2", "--start=-0.5"],
     "--start -0.5: out of range"),
    ("passage-start-nan", ["passage", BASE, "--threshold", "2", "--start", "nan"],
     "--start nan: out of range"),
    ("passage-horizon-0", ["passage", BASE, "--threshold", "2", "--horizon", "0"],
     "--horizon 0: out of range"),
    ("passage-horizon-negative", ["passage", BASE, "--threshold", "2", "--horizon=-5"],
     "--horizon -5: out of range"),
    ("passage-dt-auto", ["passage", BASE, "--threshold", "2", "--dt", "auto"],
     "--dt auto: does not apply to passage"),
    ("passage-paths", ["passage", BASE, "--threshold", "2", "--paths", "33"],
     "nearest valid: 64"),
    ("passage-out-file", ["passage", BASE, "--threshold", "2", "--out", "{file}"],
     "exists and is not a folder"),
    ("passage-paper-quintic", ["passage", "systems/quintic", "--threshold", "2", "--model",
                               "paper"], "--model paper:"),
    ("transient-times-0", ["transient", BASE, "--start", "1", "--times", "0,5"],
     "--times: 0 is not > 0"),
    ("transient-times-negative", ["transient", BASE, "--start", "1", "--times=-1,5"],
     "--times: -1 is not > 0"),
    ("transient-times-unsorted", ["transient", BASE, "--start", "1", "--times", "5,2,10"],
     "--times 5,2,10: not increasing"),
    ("transient-times-repeated", ["transient", BASE, "--start", "1", "--times", "2,2"],
     "not increasing"),
    ("transient-times-nan", ["transient", BASE, "--start", "1", "--times", "2,nan"],
     "--times 2,nan: not finite"),
    ("transient-start-0", ["transient", BASE, "--start", "0", "--times", "1"],
     "--start 0: out of range; allowed: a finite amplitude > 0"),
    ("transient-start-nan", ["transient", BASE, "--start", "nan", "--times", "1"],
     "--start nan: out of range"),
    ("transient-cost", ["transient", BASE, "--start", "1", "--times",
                        "1e7,1e8,1e9"],
     "this transient (4 Monte Carlo runs to t = 1e+09): estimated at least"),
    ("transient-out-proc", ["transient", BASE, "--start", "1", "--times", "1", "--out",
                            "/proc/vifpk"], "cannot write in /proc"),
]
IDS = [c[0] for c in CATALOGUE]
# refused by the argument parser itself (SystemExit 2 in-process; one line all the same)
PARSER_CATALOGUE = [
    ("passage-no-threshold", ["passage", BASE], "the following arguments are required: "
     "--threshold"),
    ("passage-threshold-word", ["passage", BASE, "--threshold", "high"], "'high' is not a "
     "number"),
    ("passage-start-word", ["passage", BASE, "--threshold", "2", "--start", "equilibrium"],
     "is not an amplitude or 'stationary'"),
    ("passage-time", ["passage", BASE, "--threshold", "2", "--time", "100"],
     "unrecognized arguments: --time 100"),
    ("transient-no-times", ["transient", BASE, "--start", "1"], "required: --times"),
    ("transient-no-start", ["transient", BASE, "--times", "1,2"], "required: --start"),
    ("transient-times-word", ["transient", BASE, "--start", "1", "--times", "2,soon"],
     "is not a comma-separated list of times"),
]
# The console path (a fresh interpreter: exit code, one line on stderr, nothing on stdout, no
# traceback) for one case of each command and of each kind of output path; every case of the
# catalogue runs in process below (test_bad_input_is_refused_before_any_computation). 17
# interpreters here cost a fifth of the fast tier; six say the same of the console path.
SUBPROCESS = ["paths-33", "json-proc", "check-out-file", "figures-out-file",
              "passage-threshold-below-start", "transient-times-unsorted"]


def _materialise(case: tuple, folder: Path) -> tuple[list[str], str]:
    """The case's arguments and needle with {tmp}, {file} and {scene:...} filled in."""
    _, args, needle = case
    folder.mkdir(parents=True, exist_ok=True)
    existing = folder / "existing.txt"
    existing.write_text("keep me\n")
    out = []
    for a in args:
        if a.startswith("{scene:"):
            scene = folder / "scene.toml"
            scene.write_text(a[len("{scene:"):-1])
            a = str(scene)
        out.append(a.replace("{tmp}", str(folder)).replace("{file}", str(existing)))
    return out, needle.replace("{tmp}", str(folder)).replace("{file}", str(existing))


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else b"<dir>"
            for p in sorted(folder.rglob("*"))}


# the subprocesses run in their own folders: put this checkout first on their path (an
# editable install may point elsewhere)
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(
    [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}


def run_cli(*args: str, **kw) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "vifpk", *args], capture_output=True,
                          text=True, timeout=120, env=ENV, **kw)


@pytest.fixture(scope="module")
def subprocess_results(tmp_path_factory):
    """Every catalogue case in its own subprocess and folder, four at a time."""
    root = tmp_path_factory.mktemp("catalogue")

    def one(case):
        folder = root / case[0]
        args, needle = _materialise(case, folder)
        before = _snapshot(folder)
        res = run_cli(*args, cwd=folder)
        return res, needle, before, _snapshot(folder)

    cases = [c for c in CATALOGUE if c[0] in SUBPROCESS]
    with ThreadPoolExecutor(max_workers=2) as pool:
        return dict(zip([c[0] for c in cases], pool.map(one, cases), strict=True))


# one worker runs the catalogue's subprocesses (a module fixture is made once per xdist worker:
# on two workers the 17 interpreters ran twice, ~25 s each, a fifth of the fast tier)
@pytest.mark.xdist_group("cli-catalogue")
@pytest.mark.parametrize("case_id", SUBPROCESS)
def test_bad_input_exit_2_one_line_nothing_written(subprocess_results, case_id):
    res, needle, before, after = subprocess_results[case_id]
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2, res.stderr
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    assert needle in lines[0], lines[0]
    assert res.stdout == ""
    assert after == before  # nothing written (the probe file is gone too)


@pytest.mark.parametrize("case", CATALOGUE, ids=IDS)
def test_bad_input_is_refused_before_any_computation(no_computation, tmp_path, capsys,
                                                     monkeypatch, case):
    from vifpk.harness.cli.app import main

    monkeypatch.chdir(tmp_path)
    args, needle = _materialise(case, tmp_path / "case")
    before = _snapshot(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0]
    assert _snapshot(tmp_path) == before


def test_values_on_the_grid_are_accepted_exactly(tmp_path):
    """The nearest valid values named by the messages are accepted, and run exactly (a burn-in
    of 20 is too short for the certificate's R-hat here: accepted with
    --allow-unequilibrated, the settings being the subject)."""
    import json

    from vifpk.harness.cli.app import main

    out = tmp_path / "mc.json"
    assert main(["solve", BASE, *MC, "--paths", "64", "--time", "48", "--dt", "0.03125",
                 "--set", "montecarlo.burn_in=20", "--json", str(out),
                 "--allow-unequilibrated"]) == 0
    st = json.loads(out.read_text())["info"]["settings"]
    assert st["paths"] == 64 and st["time"] == 48.0 and st["dt"] == 0.03125
    assert st["sample_every"] == 0.5 and st["burn_in"] == 20.0


def test_utf8_bom_scene_is_accepted(tmp_path, capsys):
    from vifpk.harness.cli.app import main

    scene = tmp_path / "bom.toml"
    scene.write_bytes(b"\xef\xbb\xbf[system]\nr = 0.9\n")
    out = tmp_path / "bom.json"
    assert main(["solve", str(scene), "--json", str(out)]) == 0
    assert json.loads(out.read_text())["scene"]["system"]["r"] == 0.9  # the file was read


def test_numerical_failure_exits_3_naming_the_field(tmp_path):
    """An extreme but representable scene (D = 1e-90): numpy overflows inside the phase map;
    the run exits 3 with one line naming the field, and no RuntimeWarning is printed."""
    out = tmp_path / "o.json"
    res = run_cli("solve", BASE, "--set", "noise.D=1e-90", "--json", str(out), cwd=tmp_path)
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 3 and len(lines) == 1, res.stderr
    assert "noise.D = 1e-90" in lines[0] and "RuntimeWarning" not in res.stderr
    assert not out.exists()


def test_closed_pipe_is_quiet(tmp_path):
    """`vifpk solve ... | head -2`: the reader is gone before the summary is printed."""
    r, w = os.pipe()
    os.close(r)  # the reader has left: every write raises EPIPE
    proc = subprocess.Popen([sys.executable, "-m", "vifpk", "solve", BASE], stdout=w,
                            stderr=subprocess.PIPE, text=True, cwd=tmp_path, env=ENV)
    os.close(w)
    _, err = proc.communicate(timeout=120)
    assert "Traceback" not in err and "BrokenPipe" not in err and err == ""
    assert proc.returncode == 141


def test_ctrl_c_stops_a_monte_carlo_within_seconds(tmp_path):
    """SIGINT inside the Monte Carlo: exit 130 with the one message, nothing written. The
    wait is bounded generously (10 s) against a shared machine; the kernel calls are ~0.4 s
    and the watchdog exits 1.5 s after the signal at the latest."""
    out = tmp_path / "mc.json"
    proc = subprocess.Popen([sys.executable, "-m", "vifpk", "solve", BASE, *MC, "--paths",
                             "4096", "--time", "4000", "--json", str(out)], cwd=tmp_path,
                            stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            env={**ENV, "NUMBA_NUM_THREADS": "1"},
                            # a test run started in the background inherits SIGINT ignored
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # past start-up, inside the Monte Carlo: its progress line has begun (a fixed sleep of 4 s
    # was sometimes still inside the interpreter's start on a loaded machine: killed by the
    # signal, return code -2, before Python had a handler)
    seen, t_start = b"", time.monotonic()
    while b"monte carlo" not in seen and time.monotonic() - t_start < 120:
        chunk = os.read(proc.stderr.fileno(), 4096)
        if not chunk:
            break
        seen += chunk
    assert proc.poll() is None and b"monte carlo" in seen, seen
    proc.send_signal(signal.SIGINT)
    t0 = time.monotonic()
    _, rest = proc.communicate(timeout=30)
    err = seen.decode() + rest
    waited = time.monotonic() - t0
    assert proc.returncode == 130 and waited < 10.0
    assert err.strip().splitlines()[-1] == "vifpk: interrupted; nothing was written"
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_yes_lets_a_costly_run_past_the_estimate(no_computation, tmp_path, capsys):
    """--yes skips only the cost refusal: the (forbidden) computation is then reached."""
    from vifpk.harness.cli.app import main

    with pytest.raises(AssertionError, match="computation started"):
        main(["solve", BASE, *MC, "--dt", "1e-9", "--yes"])


@pytest.mark.parametrize("case", PARSER_CATALOGUE, ids=[c[0] for c in PARSER_CATALOGUE])
def test_bad_arguments_are_refused_by_the_parser(no_computation, tmp_path, capsys, case):
    from vifpk.harness.cli.app import main

    args, needle = _materialise(case, tmp_path / "case")
    with pytest.raises(SystemExit) as exc:
        main(args)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0], err


def test_transient_times_off_the_step_grid_are_refused_not_moved(no_computation, capsys):
    """Review of issue 30: --times 0.001,0.002 with dt = 0.01 ran, both Monte Carlo snapshots
    taken at t = 0 while metrics.json said 0.001 and 0.002; now exit 2 with the nearest valid
    times, before any work."""
    from vifpk.harness.cli.app import main

    assert main(["transient", BASE, "--start", "1.0", "--times", "0.001,0.002,0.003"]) == 2
    err = capsys.readouterr().err
    assert "not a whole number of steps of dt = 0.01" in err and "nearest valid: 0.01" in err
