"""Issue 20: the edges. Every reproducer of the issue as a case: sweep output folders (lock,
refusal, whole-folder rules shared with check, a sweep folder and a report folder told apart,
names kept inside out/), wrong scene paths, signals on every executor, tracebacks and ignored
input, the cost guard, the verdict over every observable.

The catalogue runs in-process with every entry point of real work replaced by one that fails
the test (the input must be refused first). The signal tests are subprocesses on tiny sweeps
(a point of tests/data/sweep-averaging.toml is a few seconds of closed forms).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.conftest import ROOT

DATA = ROOT / "tests" / "data"
BASE = "paper-base"
MC = ("--solver", "montecarlo")
LONG = "x" * 300
ENV = {**os.environ, "NUMBA_NUM_THREADS": "1", "PYTHONPATH": os.pathsep.join(
    [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}

NO_LOSS = ("--set", "system.c1=0", "--set", "system.c2=0", "--set", "system.mu=0")
SWEEP = ('scene = "tiny"\nworkflow = "averaging"\n[vary]\n"system.r" = [0.95, 0.97]\n')


def _sweep_file(folder: Path, text: str = SWEEP, name: str = "s.toml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "tiny.toml").write_text((DATA / "tiny.toml").read_text())
    p = folder / name
    p.write_text(text)
    return p


def _home(folder: Path) -> Path:
    home = folder / "home"
    home.mkdir()
    (home / ".bashrc").write_text("# mine\n")
    (home / "thesis").mkdir()
    return home


def _fifo(folder: Path) -> str:
    os.mkfifo(folder / "fifo.toml")
    return str(folder / "fifo.toml")


def _loop(folder: Path) -> str:
    (folder / "loop.toml").symlink_to(folder / "loop.toml")
    return str(folder / "loop.toml")


_ENV: dict[str, str] = {}


def _with_env(folder: Path, key: str, value: str, args: list[str]) -> list[str]:
    _ENV[key] = value
    return args


def _scene(folder: Path, body: str | bytes) -> str:
    p = folder / "scene.toml"
    p.write_bytes(body if isinstance(body, bytes) else body.encode())
    return str(p)


def _check_report(folder: Path) -> Path:
    folder.mkdir(parents=True)
    for n in ("report.html", "report.md", "metrics.json", "arrays.npz"):
        (folder / n).write_text("a check report\n")
    return folder


def _sweep_folder(folder: Path) -> Path:
    (folder / "points").mkdir(parents=True)
    (folder / "points" / "0123456789abcdef.json").write_text("{}\n")
    (folder / "sweep.nc").write_text("netcdf\n")
    (folder / "report.html").write_text("sweep maps\n")
    return folder


# (id, setup(tmp) -> args, needle): each must exit 2 with one line holding the needle, before
# any computation, leaving the folder as it was
def _setup_cases():
    def sweep_out(make):
        def setup(tmp):
            s = _sweep_file(tmp / "in")
            return ["sweep", str(s), "--out", str(make(tmp))]
        return setup

    def file_(tmp):
        (tmp / "f.txt").write_text("keep\n")
        return tmp / "f.txt"

    def points_file(tmp):
        (tmp / "o").mkdir()
        (tmp / "o" / "points").write_text("not a folder\n")
        return tmp / "o"

    def nc_folder(tmp):
        (tmp / "o" / "sweep.nc").mkdir(parents=True)
        return tmp / "o"

    def html_folder(tmp):
        (tmp / "o" / "points").mkdir(parents=True)
        (tmp / "o" / "report.html").mkdir()
        return tmp / "o"

    def foreign(tmp):
        (tmp / "o").mkdir()
        (tmp / "o" / "thesis.tex").write_text("mine\n")
        return tmp / "o"

    def lone_html(tmp):
        (tmp / "o").mkdir()
        (tmp / "o" / "report.html").write_text("whose?\n")
        return tmp / "o"

    def check_into_sweep(tmp):
        return ["check", BASE, "--out", str(_sweep_folder(tmp / "o"))]

    def wp_into_sweep(tmp):
        return ["workprecision", BASE, "--out", str(_sweep_folder(tmp / "o"))]

    def check_into_wp(tmp):
        (tmp / "o").mkdir()
        (tmp / "o" / "workprecision.json").write_text("{}\n")
        return ["check", BASE, "--out", str(tmp / "o")]

    def path_like_name(body):
        def setup(tmp):
            return ["sweep", str(_sweep_file(tmp, SWEEP.replace('"tiny"', body)))]
        return setup

    def check_cwd(tmp):
        os.chdir(tmp)
        return ["check", BASE, "--out", "."]

    def check_parent(tmp):
        (tmp / "sub").mkdir()
        os.chdir(tmp / "sub")
        return ["check", BASE, "--out", ".."]

    def json_symlink(tmp):
        (tmp / "real.json").write_text("{}")
        (tmp / "link.json").symlink_to(tmp / "real.json")
        return ["solve", BASE, "--json", str(tmp / "link.json")]

    def sweep_bom_path(tmp):
        return ["sweep", "/no/such/dir/r-mu.toml"]

    def deep(tmp):
        s = _sweep_file(tmp, SWEEP + '[set]\n"system.mu" = ' + "[" * 100000 + "]" * 100000)
        return ["sweep", str(s)]

    def deep_scene(tmp):
        (tmp / "d.toml").write_text("[system]\nr = " + "[" * 100000 + "]" * 100000 + "\n")
        return ["solve", str(tmp / "d.toml")]

    return [
        # A: sweep --out
        ("sweep-out-file", sweep_out(file_), "exists and is not a folder"),
        ("sweep-out-proc", sweep_out(lambda t: Path("/proc/vifpk-sweep")), "cannot write in"),
        ("sweep-out-300", sweep_out(lambda t: t / LONG), "bytes long; allowed: up to 200"),
        ("sweep-points-file", sweep_out(points_file), "points exists and is not a folder"),
        ("sweep-nc-folder", sweep_out(nc_folder), "sweep.nc exists and is not a file"),
        ("sweep-html-folder", sweep_out(html_folder), "report.html exists and is not a file"),
        ("sweep-into-check", sweep_out(lambda t: _check_report(t / "o")),
         "is a check report folder"),
        ("sweep-foreign", sweep_out(foreign), "does not hold an earlier sweep"),
        ("sweep-lone-html", sweep_out(lone_html), "does not hold an earlier sweep"),
        ("check-into-sweep", check_into_sweep, "is a sweep folder"),
        ("wp-into-sweep", wp_into_sweep, "is a sweep folder"),
        ("check-into-wp", check_into_wp, "is a work-precision run folder"),
        ("check-out-300", lambda t: ["check", BASE, "--out", str(t / LONG)], "bytes long"),
        ("solve-json-300", lambda t: ["solve", BASE, "--json", str(t / LONG)], "bytes long"),
        ("bif-json-300", lambda t: ["bifurcation", BASE, "--vary", "mu", "--json",
                                    str(t / LONG)], "bytes long"),
        ("wp-out-300", lambda t: ["workprecision", BASE, "--out", str(t / LONG)], "bytes long"),
        ("figures-out-300", lambda t: ["figures", "--out", str(t / LONG)], "bytes long"),
        ("check-out-dot", check_cwd, "is the current folder"),
        ("check-out-dotdot", check_parent, "is the current folder (or holds it)"),
        ("json-symlink", json_symlink, "is a symbolic link"),
        ("json-dev-stdout", lambda t: ["solve", BASE, "--json", "/dev/stdout"],
         "is a symbolic link"),
        ("json-dev-null", lambda t: ["solve", BASE, "--json", "/dev/null"],
         "is not a regular file"),
        # C: a path is a path
        ("scene-wrong-path", lambda t: ["solve", "experiments/paper-base.toml"],
         "experiments/paper-base.toml: no such scene file"),
        ("scene-abs-wrong", lambda t: ["solve", "/no/such/dir/paper-fig5.toml"],
         "no such scene file"),
        ("scene-no-suffix-path", lambda t: ["check", "./paper-base"], "no such scene file"),
        ("scene-typo-name", lambda t: ["solve", "paper-bse"], "did you mean 'paper-base'"),
        ("scene-300", lambda t: ["solve", LONG], "cannot read (File name too long)"),
        ("sweep-wrong-path", sweep_bom_path, "no such sweep file"),
        ("sweep-scene-wrong-path", path_like_name('"sub/paper-base.toml"'),
         "no such scene file"),
        ("sweep-scene-abs", path_like_name('"/no/such/paper-base.toml"'), "no such scene"),
        # E: deep nesting
        ("sweep-deep", deep, "nested too deeply"),
        ("scene-deep", deep_scene, "nested too deeply"),
        # E: values numba, math or the grids would fail on
        ("threads-100", lambda t: ["solve", BASE, *MC, "--set", "montecarlo.threads=100"],
         "montecarlo.threads = 100 is out of range; allowed: 0 (all) to"),
        ("tail-1e300", lambda t: ["solve", BASE, "--set", "averaging.tail=1e300"],
         "allowed: 0 < tail <= 0.001"),
        ("tail-0.5", lambda t: ["solve", BASE, "--set", "averaging.tail=0.5"],
         "averaging.tail = 0.5 is out of range"),
        ("dt-5e-324", lambda t: ["solve", BASE, *MC, "--dt", "5e-324"],
         "is too small; allowed: dt >= montecarlo.sample_every / 1e+09"),
        ("paths-32-rhat", lambda t: ["solve", BASE, *MC, "--paths", "32"],
         "paths >= 2 x blocks = 64"),
        ("scene-top-sweep", lambda t: ["solve", _scene(t, "sweep = 1\n[system]\nr = 0.9\n")],
         "unknown key 'sweep'"),
        ("bif-range-inf", lambda t: ["sweep", str(_sweep_file(t, (
            'scene = "tiny"\nworkflow = "bifurcation"\n[bifurcation]\nfind = "mu"\n'
            'range = [0.0, inf]\n[vary]\n"system.r" = [0.95]\n')))], "finite numbers"),
        ("sweep-point-magnitude", lambda t: ["sweep", str(_sweep_file(t, SWEEP.replace(
            "[0.95, 0.97]", "[0.95]\n\"noise.D\" = [0.01, 1e-200]")))],
         "at the point system.r = 0.95, noise.D = 1e-200: noise.D = 1e-200 is out of range"),
        ("sweep-point-mc", lambda t: ["sweep", str(_sweep_file(t, (
            'scene = "tiny"\n[vary]\n"montecarlo.dt" = [0.01, 0.03]\n')))],
         "montecarlo.dt = 0.03 must divide"),
        # E: no stationary density (vifpk.core.scene.energy_balance), refused up front
        ("no-damping", lambda t: ["solve", BASE, *MC, *NO_LOSS, "--set", "system.r=1"],
         "system: no stationary density: nothing removes energy at large amplitude (no "
         "damping law, no velocity_damping, system.mu = 0, system.r = 1)"),
        ("no-damping-check", lambda t: ["check", BASE, *NO_LOSS, "--set", "system.r=1"],
         "system: no stationary density: nothing removes energy"),
        ("no-damping-no-barrier", lambda t: ["solve", BASE, *NO_LOSS, "--set",
                                             "system.barrier=false"], "mu = 0, no barrier)"),
        ("c1-gain-elastic", lambda t: ["solve", BASE, *MC, "--set", "system.c1=0.5", "--set",
                                       "system.c2=0", "--set", "system.mu=0", "--set",
                                       "system.r=1"],
         "the energy gain of system.c1 (power ~ A^4 with the spring's top term system.alpha"),
        ("velocity-damping-negative", lambda t: ["solve", BASE, *MC, "--set",
                                                 "system.velocity_damping=[-1]"],
         "gain of system.velocity_damping[0] (power ~ A^8 with the spring's top term "
         "system.alpha, degree 3) outgrows every loss (system.c2 ~ A^6, system.mu ~ A^2, "
         "system.r ~ A^5)"),
        ("sweep-point-no-density", lambda t: ["sweep", str(_sweep_file(t, SWEEP.replace(
            '"system.r" = [0.95, 0.97]', '"system.c2" = [0.05, 0.0]') + (
            '[set]\n"system.c1" = 0.5\n"system.mu" = 0.0\n"system.r" = 1.0\n')))],
         "at the point system.c2 = 0: system: no stationary density"),
        ("allow-unequilibrated-averaging", lambda t: ["solve", BASE, "--allow-unequilibrated"],
         "--allow-unequilibrated: does not apply to --solver averaging"),
        # F: ignored input is refused
        ("budget-no-floor", lambda t: ["solve", BASE, *MC, "--budget", "10"],
         "--budget 10: does not apply without a target floor"),
        ("model-twice", lambda t: ["solve", BASE, "--model", "exact", "--model", "paper"],
         "--model given twice (exact and paper)"),
        ("paths-twice", lambda t: ["solve", BASE, *MC, "--paths", "64", "--paths", "128"],
         "--paths given twice"),
        ("solver-twice", lambda t: ["solve", BASE, "--solver", "fpk", "--solver=averaging"],
         "--solver given twice"),
        ("bif-set-varied", lambda t: ["bifurcation", BASE, "--vary", "mu", "--set",
                                      "system.mu=0.01"], "is the parameter --vary mu searches"),
        ("no-observables", lambda t: ["solve", _scene(t, "[observables]\nA = false\n"
                                                      "x1 = false\nx2 = false\nmoments = false"
                                                      "\nevents = false\n"), *MC],
         "every observable is off"),
        # my own: hostile inputs beyond the (docs/edges.md lists them all)
        ("json-trailing-slash", lambda t: ["solve", BASE, "--json", str(t / "new") + "/"],
         "ends with a folder separator"),
        ("json-empty", lambda t: ["solve", BASE, "--json", ""], "is a folder"),
        ("out-slash", lambda t: ["check", BASE, "--out", "/"], "is the current folder (or"),
        ("out-home", lambda t: ["check", BASE, "--out", str(_home(t))],
         "does not hold an earlier check report"),
        ("scene-fifo", lambda t: ["solve", _fifo(t)], "no such scene file"),
        ("scene-symlink-loop", lambda t: ["solve", _loop(t)], "no such scene file"),
        ("scene-latin1", lambda t: ["solve", _scene(t, b"name = \"caf\xe9\"\n")],
         "cannot read"),
        ("scene-duplicate-key", lambda t: ["solve", _scene(t, "[system]\nr = 0.9\nr = 0.8\n")],
         "not valid TOML"),
        ("scene-two-lists", lambda t: ["solve", _scene(t, "[system]\nr = [0.9, 0.95]\n"
                                                       "mu = [0.0, 0.001]\n")],
         "only one parameter may vary"),
        ("scene-is-a-sweep", lambda t: ["solve", str(_sweep_file(t))], "unknown key 'scene'"),
        ("sweep-is-a-scene", lambda t: ["sweep", str(DATA / "tiny.toml")],
         "unknown key 'averaging'"),
        ("set-no-value", lambda t: ["solve", BASE, "--set", "noise.D"], "expected section.key"),
        ("set-empty-value", lambda t: ["solve", BASE, "--set", "noise.D="], "noise.D = ''"),
        ("set-table", lambda t: ["solve", BASE, "--set", "noise.D={a=1}"], "must be a finite"),
        ("set-unicode-section", lambda t: ["solve", BASE, "--set", "système.r=1"],
         "unknown field"),
        ("dt-underflow", lambda t: ["solve", BASE, *MC, "--dt", "1e-400"], "--dt = 0.0"),
        ("range-equal", lambda t: ["bifurcation", BASE, "--vary", "mu", "--range", "0.01",
                                   "0.01", "--no-mc"], "LO must be below HI"),
        ("executor-space", lambda t: ["sweep", str(_sweep_file(t)), "--executor", " serial"],
         "unknown executor"),
        ("executor-processes-empty", lambda t: ["sweep", str(_sweep_file(t)), "--executor",
                                                "processes:"], "N must be a whole number"),
        ("sweep-vary-bool", lambda t: ["sweep", str(_sweep_file(t, SWEEP.replace(
            "[0.95, 0.97]", "[true, false]")))], "True is not a finite number"),
        ("sweep-name-empty", lambda t: ["sweep", str(_sweep_file(t, 'name = ""\n' + SWEEP))],
         "name and description must be strings"),
        ("sweep-name-300", lambda t: ["sweep", str(_sweep_file(t, f'name = "{"n" * 300}"\n'
                                                                + SWEEP))], "bytes long"),
        ("sweep-scene-is-a-sweep", lambda t: ["sweep", str(_sweep_file(t, SWEEP.replace(
            '"tiny"', '"inner.toml"'), name="outer.toml"))] if _sweep_file(
            t, SWEEP, name="inner.toml") else [], "unknown key 'scene'"),
        ("numba-threads-text", lambda t: _with_env(t, "NUMBA_NUM_THREADS", "abc",
                                                   ["solve", BASE]), "NUMBA_NUM_THREADS=abc"),
        ("check-paths-32", lambda t: ["check", BASE, "--set", "montecarlo.paths=32"],
         "paths >= 2 x blocks"),
        # D: the cost guard
        ("floor-5", lambda t: ["solve", BASE, *MC, "--floor", "5"], "0 <= floor < 2"),
        ("floor-no-budget", lambda t: ["solve", BASE, *MC, "--floor", "1e-5", "--budget", "0"],
         "this solve: estimated at least"),
        ("floor-unreachable", lambda t: ["solve", BASE, *MC, "--dt", "auto", "--floor", "1e-9"],
         "needs at least"),
        ("paths-memory", lambda t: ["solve", BASE, *MC, "--paths", "1e12", "--yes"],
         "GiB of memory"),
        ("check-floor-no-budget", lambda t: ["check", BASE, "--floor", "1e-5", "--budget", "0"],
         "this check: estimated at least"),
        ("sweep-1000x1000", lambda t: ["sweep", str(_sweep_file(t, (
            'scene = "paper-base"\nworkflow = "averaging"\n[vary]\n"system.r" = {start = 0.9,'
            ' stop = 1.0, num = 1000}\n"system.mu" = {start = 0.0, stop = 0.01, num = 1000}\n'
        )))], "1000 x 1000 = 1000000 points; allowed: up to 20000"),
        ("sweep-num-huge", lambda t: ["sweep", str(_sweep_file(t, (
            'scene = "tiny"\n[vary]\n"system.r" = {start = 0.9, stop = 1.0, num = 1000000000}'
            '\n')))], "num = 1000000000: out of range; allowed: 1 to 20000"),
        # 100 points of ~23 s each at the test's speed: over the hour only summed, and only at
        # the measured speed (the fastest rate says 30 minutes); at the fixed step 0.01 (the
        # default "auto" step, 0.038 here since issue 44, is ~4x cheaper)
        ("sweep-10x10", lambda t: ["sweep", str(_sweep_file(t, (
            'scene = "paper-base"\nworkflow = "check"\n[vary]\n"system.r" = {start = 0.9, '
            'stop = 1.0, num = 10}\n"system.mu" = {start = 0.0, stop = 0.01, num = 10}\n'
            '[set]\n"montecarlo.time" = 40000.0\n"montecarlo.dt" = 0.01\n'
        ))), "--out", str(t / "o")], "this sweep (100 points): estimated at least"),
        # issue 28: an adaptive budget of 100000 points was refused as "this sweep (81 points)"
        # though it was priced for the whole budget; the message now says what was priced
        ("sweep-adaptive-100000", lambda t: ["sweep", str(_sweep_file(t, (
            'scene = "paper-base"\nworkflow = "check"\nmode = "adaptive"\n[vary]\n'
            '"system.r" = {start = 0.95, stop = 0.99}\n"system.mu" = {start = 0.0, stop = 0.004}'
            '\n[adaptive]\npoints = 100000\nmodel = "exact"\n'
        ))), "--out", str(t / "o")],
         "this sweep (100000 points: 81 initial, the rest adaptive): estimated at least"),
    ]


CASES = _setup_cases()


@pytest.fixture(autouse=True)
def _known_speed(monkeypatch):
    """The cost guard at a fixed machine speed: no calibration run inside a test."""
    monkeypatch.setenv("VIFPK_STEPS_PER_SECOND", "2e7")


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else b"<dir>"
            for p in sorted(folder.rglob("*"))}


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_refused_before_any_work(case, no_computation, tmp_path, monkeypatch, capsys):
    from vifpk.harness.cli.app import main

    monkeypatch.chdir(tmp_path)
    _ENV.clear()
    args = case[1](tmp_path)
    for key, value in _ENV.items():
        monkeypatch.setenv(key, value)
    before = _snapshot(tmp_path)
    try:
        code = main(args)
    except SystemExit as exc:  # argparse's own errors (one line, exit 2)
        code = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1 and case[2] in err[0], err
    assert _snapshot(tmp_path) == before
    assert not list(tmp_path.rglob(".*.lock"))


# --------------------------------------------------------------------------------------------
# A: the lock, and the name of the default folder
def _canned(monkeypatch):
    """The averaging workflow replaced by a canned result: plumbing only, no physics."""
    import vifpk.harness.sweeps.points

    def canned(job):
        r = dict(job.params)["system.r"]
        return {"models": {m: {"mean_A": 1.0 + r} for m in ("paper", "exact", "corrected")},
                "flags": {"warn_narrow_band": False, "warn_strong_damping": False,
                          "warn_strong_noise": False}, "warnings": [], "L1_paper_exact_A": 0.1}

    functions = vifpk.harness.sweeps.points.sweep_functions()  # the registered ones, loaded
    monkeypatch.setitem(functions, "averaging", canned)


def test_second_sweep_into_a_held_folder_is_refused(tmp_path, monkeypatch, capsys):
    """Another live run holds the folder (its lock taken by a second process): refused."""
    from vifpk.harness.cli.app import main

    _canned(monkeypatch)
    out = tmp_path / "o"
    holder = subprocess.Popen([sys.executable, "-c", (
        "import fcntl, os, sys, time; fd = os.open(sys.argv[1], os.O_RDWR | os.O_CREAT); "
        "fcntl.flock(fd, fcntl.LOCK_EX); os.write(fd, b'{\"pid\": 1, \"run_id\": \"other\"}');"
        " print('held', flush=True); time.sleep(60)"), str(tmp_path / ".o.lock")],
        stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        assert main(["sweep", str(_sweep_file(tmp_path / "in")), "--out", str(out)]) == 2
    finally:
        holder.kill()
        holder.wait()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "another vifpk run is writing this folder" in err[0]
    assert not out.exists()


def test_sweep_then_check_then_sweep_neither_overwrites(tmp_path, monkeypatch, capsys):
    """A finished sweep folder: the check refuses it; the sweep again skips its points."""
    from vifpk.harness.cli.app import main

    _canned(monkeypatch)
    out = tmp_path / "o"
    sweep = _sweep_file(tmp_path / "in")
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet"]) == 0
    assert sorted(os.listdir(out)) == ["points", "report.html", "sweep.nc"]
    before = _snapshot(out)
    assert main(["check", BASE, "--out", str(out)]) == 2
    assert "is a sweep folder" in capsys.readouterr().err
    assert _snapshot(out) == before
    assert main(["sweep", str(sweep), "--out", str(out), "--quiet"]) == 0
    assert "0 computed, 2 done before" in capsys.readouterr().out
    assert not list(tmp_path.glob(".*.lock"))


def test_sweep_name_cannot_escape_out(tmp_path, monkeypatch, capsys):
    """name = "../../escaped": the default folder is out/<the name made one folder name>."""
    from vifpk.harness.cli.app import main

    _canned(monkeypatch)
    monkeypatch.chdir(tmp_path)
    sweep = _sweep_file(tmp_path / "a" / "b", 'name = "../../escaped"\n' + SWEEP)
    assert main(["sweep", str(sweep), "--quiet"]) == 0
    made = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.iterdir())
    assert made == ["a", "out"]
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["_.._escaped"]


def test_sweep_file_with_bom_is_read(tmp_path, monkeypatch, capsys):
    from vifpk.harness.sweeps.spec import load_sweep

    p = _sweep_file(tmp_path)
    p.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    assert [pt.params for pt in load_sweep(p).points] == [(("system.r", 0.95),),
                                                          (("system.r", 0.97),)]


def test_shipped_names_still_resolve():
    """A bare name finds a shipped scene or sweep; hard/NAME too."""
    from vifpk.harness.sweeps.spec import load_sweep

    from vifpk.core.scene import load_scene

    assert load_scene("paper-base").system.r == 0.96
    assert load_scene("hard/r-low").source == "r-low.toml"
    assert load_sweep("r-mu").workflow == "check"


# --------------------------------------------------------------------------------------------
# B: signals (subprocesses on a tiny sweep; a few seconds each)
def _start_sweep(tmp_path: Path, executor: str) -> tuple[subprocess.Popen, Path]:
    out = tmp_path / "o"
    proc = subprocess.Popen(
        [sys.executable, "-m", "vifpk", "sweep", str(DATA / "sweep-averaging.toml"), "--out",
         str(out), "--executor", executor, "--quiet"], env=ENV, cwd=tmp_path,
        stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True, start_new_session=True,
        # a test run started in the background inherits SIGINT ignored
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    t0 = time.monotonic()
    while not _records(out) and time.monotonic() - t0 < 120:
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.05)
    return proc, out


def _records(out: Path) -> list[Path]:
    """The finished point records (not the hidden temporary files of a write under way)."""
    return [p for p in (out / "points").glob("*.json") if not p.name.startswith(".")]


def _group(pid: int) -> list[int]:
    res = subprocess.run(["ps", "-eo", "pid=,pgid=,stat="], capture_output=True, text=True)
    return [int(p) for p, g, st in (ln.split() for ln in res.stdout.splitlines())
            if int(g) == pid and not st.startswith("Z")]


@pytest.mark.slow  # subprocesses that spawn workers: ~10 s each on 2 cores
@pytest.mark.parametrize("how", ["SIGINT-group", "SIGTERM-pid", "SIGKILL-pid"])
def test_signal_stops_the_workers_and_keeps_finished_points(tmp_path, how):
    """processes:2: Ctrl-C on the process group, SIGTERM or SIGKILL on the sweep: no process
    of the sweep is left running; the finished points stay; the message says so (130, 143);
    no lock file is left (SIGKILL leaves one, which the next run takes over)."""
    name, target = how.split("-")
    proc, out = _start_sweep(tmp_path, "processes:2")
    assert len(_group(proc.pid)) >= 3  # the sweep and its two workers
    (os.killpg if target == "group" else os.kill)(proc.pid, getattr(signal, name))
    _, err = proc.communicate(timeout=60)
    deadline = time.monotonic() + 10
    while _group(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _group(proc.pid) == []  # no orphan: workers and resource tracker gone
    kept = len(_records(out))
    assert kept >= 1 and not (out / "sweep.nc").exists()
    if name == "SIGKILL":
        return
    assert proc.returncode == {"SIGINT": 130, "SIGTERM": 143}[name]
    last = err.strip().splitlines()[-1]
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert f"{kept} finished point" in last and "run the same command again" in last, last
    assert ("terminated (SIGTERM)" in last) == (name == "SIGTERM")
    assert not (tmp_path / ".o.lock").exists()


@pytest.mark.slow
def test_ctrl_c_on_a_dask_sweep_leaves_no_worker(tmp_path):
    proc, out = _start_sweep(tmp_path, "dask:2")
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    deadline = time.monotonic() + 10
    while _group(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert _group(proc.pid) == [] and proc.returncode == 130
    assert "Traceback" not in err and "finished point" in err


@pytest.mark.slow  # a subprocess check: ~5 s
def test_sigterm_on_check_is_like_ctrl_c(tmp_path):
    """check on SIGTERM: exit 143 with the one message, no .lock, nothing written."""
    proc = subprocess.Popen([sys.executable, "-m", "vifpk", "check", str(DATA / "tiny.toml"),
                             "--out", str(tmp_path / "c"), "--quiet"], env=ENV, cwd=tmp_path,
                            stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not (tmp_path / ".c.lock").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    assert err.strip().splitlines() == ["vifpk: terminated (SIGTERM); nothing was written"]
    assert sorted(os.listdir(tmp_path)) == []


# --------------------------------------------------------------------------------------------
# E: failures that are found only while computing exit 3 with one line
def test_numba_threads_zero_in_the_environment(monkeypatch, capsys, no_computation):
    from vifpk.harness.cli.app import main

    monkeypatch.setenv("NUMBA_NUM_THREADS", "0")
    assert main(["solve", BASE]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["vifpk: error: NUMBA_NUM_THREADS=0: out of range; allowed: a whole number "
                   ">= 1 (or unset: every core)"]


def test_bifurcation_without_noise_exits_3(tmp_path, capsys, no_computation):
    from vifpk.harness.cli.app import main

    assert main(["bifurcation", _scene(tmp_path, "[system]\nf = 0.0\n"), "--vary", "mu",
                 "--no-mc"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "f = 0: there is no noise" in err[0]


def test_full_disk_on_stdout_exits_3_one_line(tmp_path):
    """`vifpk solve S > /dev/full`: one line, exit 3, no traceback."""
    with open("/dev/full", "w") as full:
        res = subprocess.run([sys.executable, "-m", "vifpk", "solve", str(DATA / "tiny.toml")],
                             stdout=full, stderr=subprocess.PIPE, text=True, env=ENV,
                             cwd=tmp_path, timeout=120)
    assert res.returncode == 3, res.stderr
    assert res.stderr.strip().splitlines() == [
        "vifpk: cannot write the standard output (No space left on device); the run's output "
        "is incomplete"]


@pytest.mark.numpy_errors_ok
@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_averaging_sweep_point_with_nonsense_numbers_fails():
    """D = 1e-90 (inside the magnitude box) overflows the closed forms: `solve` exits 3 on it,
    and the sweep records the point as failed (numerical), never "ok" with nonsense."""
    from vifpk.harness.sweeps.points import Job, run_point

    from vifpk.core.scene import load_scene

    scene = load_scene(DATA / "tiny.toml").with_values({"noise.D": 1e-90})
    rec = run_point(Job(key="k", fingerprint="f", params=(("noise.D", 1e-90),), seed=1,
                        workflow="averaging", scene=scene, bifurcation={}))
    assert rec["status"] == "failed" and rec["failure"] == "numerical", rec
    assert "noise.D = 1e-90" in rec["message"]


def test_workprecision_prints_no_nan_fit():
    """A bias fit the ladder cannot determine is said in words, not printed as nan."""
    import math

    from vifpk.harness.workflows.workprecision import table_markdown

    data = {"seconds_to_reach": {"closed form (paper)": {"1e-2": 0.1, "1e-3": math.nan}},
            "mc_bias_variance": {"paths": 64, "time": 10.0, "ladder": [
                {"dt": 0.02, "seconds": 1.0, "L1": 0.1, "floor": 0.1, "reference_floor": 0.01,
                 "error": 0.1, "bias_L1": 0.0, "mean_A_bias": 0.0, "mean_A_bias_err": 0.01}],
                "variance_constant_K": 0.02, "bias_fit": {"C": math.nan, "order": math.nan},
                "best_dt_for_budget": {"1 s": {"dt": math.nan, "predicted_L1": math.nan}}}}
    text = table_markdown(data)
    assert "nan" not in text and "Bias fit: not determined" in text
    assert "not reached" in text


# --------------------------------------------------------------------------------------------
# D: the measured speed of this machine
def test_machine_speed_is_measured_once_and_cached(tmp_path, monkeypatch):
    from vifpk.harness.request import cost

    monkeypatch.delenv("VIFPK_STEPS_PER_SECOND")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    calls = []
    monkeypatch.setattr(cost, "_calibrate", lambda: calls.append(1) or 1.5e7)
    assert cost.machine_speed() == 1.5e7 and cost.machine_speed() == 1.5e7
    assert calls == [1]
    cached = json.loads((tmp_path / "vifpk" / "speed.json").read_text())
    assert cached["steps_per_second_per_core"] == 1.5e7 and cached["cores"] == os.cpu_count()


def test_cost_between_the_bounds_uses_the_measured_speed(monkeypatch):
    """At the fastest rate a run looks like 20 minutes; at this machine's measured speed
    (3x slower) it is an hour: refused; the estimate above an hour at the fastest rate needs
    no measurement; far below it neither."""
    from vifpk.harness.request import cost, validate

    speeds = []

    def estimate(sp):
        speeds.append(sp)
        return 1200.0 * cost.MC_STEPS_PER_CORE / (sp or cost.MC_STEPS_PER_CORE)

    monkeypatch.setenv("VIFPK_STEPS_PER_SECOND", str(cost.MC_STEPS_PER_CORE / 3.5))
    with pytest.raises(validate.InputError, match="estimated at least 70 minutes"):
        cost.refuse_costly(estimate, "this run", False)
    assert speeds == [None, cost.MC_STEPS_PER_CORE / 3.5]
    cost.refuse_costly(lambda sp: 60.0, "this run", False)
    cost.refuse_costly(lambda sp: 1e9, "this run", True)  # --yes
    monkeypatch.setenv("VIFPK_STEPS_PER_SECOND", "fast")
    with pytest.raises(validate.InputError, match="VIFPK_STEPS_PER_SECOND=fast"):
        cost.refuse_costly(estimate, "this run", False)


# --------------------------------------------------------------------------------------------
# G: the verdict looks at every observable; a colour per class; help texts
def _entry(**l1):
    hist = {o: {"L1": v, "L1_err": 0.002, "L1_floor": 0.018, "ks": v / 2, "mean_diff": 0.0}
            for o, v in l1.items()}
    return {"averaging_error": hist, "sampling_ok": True,
            "sampling_error": {o: {"L1": 0.01, "L1_floor": 0.018} for o in l1}}


def test_headline_verdict_is_the_worst_observable():
    """The issue's case: p(A) within the noise but p(x2) 2.8 x its floor: not called
    indistinguishable; the line names each observable's class."""
    from vifpk.harness.workflows.verdict import verdict, verdict_class

    e = _entry(A=0.02, x1=0.03, x2=2.8 * 0.018)
    cls, cause = verdict_class(e, [])
    assert cls == "small" and "p(x2)" in cause
    line = verdict("corrected", e, [])
    assert line.startswith("corrected model: SMALL --")
    assert "p(A) indistinguishable" in line and "p(x2) small (L1 0.050, 2.8 x floor)" in line
    assert verdict_class(_entry(A=0.02, x1=0.02, x2=0.02), [])[0] == "indistinguishable"
    assert verdict_class(_entry(A=0.05, x1=0.4, x2=0.02), [])[0] == "large"


def test_the_cause_never_reports_an_fpk_error_nobody_measured():
    """Issue 28 (day-one path): a plugin's check showed "FPK numerics 0.0e+00" where no FPK was
    compared (no closed form: the FPK solve is the reference). Unmeasured: "not computed";
    measured: its number."""
    from vifpk.harness.workflows.verdict import verdict_class

    e = _entry(A=0.4, x1=0.4, x2=0.4)  # no discretisation_error: nothing measured
    cause = verdict_class(e, [])[1]
    assert "FPK numerics not computed" in cause and "0.0e+00" not in cause
    e["discretisation_error"] = {o: {"L1": 1e-4} for o in ("A", "x1", "x2")}
    assert "FPK numerics 1.0e-04" in verdict_class(e, [])[1]


def test_each_class_has_its_own_colour():
    from vifpk.harness.outputs.report import CLASS_COLOURS, _class_css
    from vifpk.harness.workflows.verdict import RANK

    CLASSES = [*RANK, "not an estimate"]  # every class verdict_class returns

    assert set(CLASS_COLOURS) == set(CLASSES)
    assert len(set(CLASS_COLOURS.values())) == len(CLASSES)
    css = _class_css()
    assert all(f".{c.replace(' ', '-')}{{background:" in css for c in CLASSES)


def test_help_texts_count_the_models():
    from vifpk.harness.cli.app import build_parser

    sub = next(a for a in build_parser()._actions if hasattr(a, "choices") and a.choices)
    helps = {a.dest: a.help for a in sub._choices_actions}
    assert "both averaged models" not in helps["check"]  # there are three
    assert all(m in helps["check"] for m in ("paper", "exact", "corrected"))
    assert "two averaged models" in helps["figures"]  # it draws two


def test_bifurcation_prints_words_not_python_reprs(monkeypatch, capsys):
    import vifpk.harness.workflows.bifurcation
    from vifpk.harness.cli.app import main

    def canned(scene, vary, **kw):
        return {"fixed": {"r": 0.96}, "critical": {"paper": None, "exact": 0.0123},
                "range": [0.0, 0.05], "paper_claim": "mu near 0.038",
                "mc_check": [{"value": 0.01, "predicted": {"paper": "crater", "exact": "peak"},
                              "monte_carlo": {"shape": "peak", "max_rise_in_se": 1.5},
                              "words": "agrees"}]}

    monkeypatch.setattr(vifpk.harness.workflows.bifurcation, "bifurcation", canned)
    assert main(["bifurcation", BASE, "--vary", "mu", "--no-mc", "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "{" not in out and "[" not in out and "'paper'" not in out, out
    assert "paper model: critical mu = none in 0 to 0.05" in out
    assert "models predict paper a crater, exact a peak" in out


def test_leftover_temporaries_are_cleared_not_refused(tmp_path, monkeypatch, capsys):
    """A killed write leaves `.sweep.nc.<hex>.tmp.nc` or `.KEY.json.<hex>.tmp.json`: the next
    run into the folder clears them (with the lock held) instead of calling them foreign."""
    from vifpk.harness.cli.app import main

    _canned(monkeypatch)
    out = _sweep_folder(tmp_path / "o")
    (out / "points" / "0123456789abcdef.json").unlink()
    (out / ".sweep.nc.0a1b2c3d.tmp.nc").write_text("half\n")
    (out / "points" / ".0123456789abcdef.json.0a1b2c3d.tmp.json").write_text("{")
    assert main(["sweep", str(_sweep_file(tmp_path / "in")), "--out", str(out), "--quiet"]) == 0
    assert not [p for p in out.rglob(".*") if ".tmp" in p.name]


def _unequilibrated(out: Path, *extra: str) -> list[str]:
    """tiny, 32 paths x 20 time units after a burn-in of 0: the start still shows (R-hat)."""
    return ["solve", str(DATA / "tiny.toml"), *MC, "--paths", "32", "--time", "20",
            "--set", "montecarlo.blocks=16", "--set", "montecarlo.burn_in=0",
            "--json", str(out), *extra]


def test_not_equilibrated_exits_3_and_keeps_the_output(tmp_path, capsys):
    """R-hat fails (the paths remember their start): exit 3, one line naming the diagnostic
    and the remedy; the JSON is written, its certificate inside (nothing lost)."""
    from vifpk.harness.cli.app import main

    out = tmp_path / "mc.json"
    assert main(_unequilibrated(out)) == 3
    err = capsys.readouterr().err
    err = err[err.find("vifpk: "):].strip().splitlines()  # after a progress bar, if shown
    conv = json.loads(out.read_text())["info"]["convergence"]
    assert conv["equilibrated"] is False and "rhat" in conv["failed"], conv
    assert len(err) == 1, err
    assert err[0].startswith("vifpk: the simulation is NOT equilibrated: R-hat across "
                             "starting amplitudes")
    assert "give a longer burn-in" in err[0] and f"{out} was written" in err[0]
    assert "--allow-unequilibrated" in err[0]


def test_allow_unequilibrated_exits_0_with_the_warning(tmp_path, capsys):
    """--allow-unequilibrated: exit 0; --json hides the summary, so the warning is said on
    stderr."""
    from vifpk.harness.cli.app import main

    out = tmp_path / "mc.json"
    assert main(_unequilibrated(out, "--allow-unequilibrated")) == 0
    err = capsys.readouterr().err
    assert json.loads(out.read_text())["info"]["convergence"]["equilibrated"] is False
    assert "vifpk: warning: the simulation is NOT equilibrated" in err


def test_too_few_samples_alone_is_a_warning_not_a_failure():
    """An effective sample size below 400 alone (a short exploratory run, e.g. 64 paths x 50:
    ESS 68-86 in 6 seeds, R-hat and drift passing) keeps exit 0: its error bars say it."""
    from vifpk.harness.cli.commands import _not_equilibrated

    conv = {"equilibrated": False, "failed": ["ess"], "rhat": 1.0, "rhat_limit": 1.1,
            "drift_z": 0.3, "drift_limit": 4.0, "burn_in": 20.0}
    assert _not_equilibrated(conv) == ""
    said = _not_equilibrated(dict(conv, failed=["drift", "ess"], drift_z=-5.2))
    assert said.startswith("the mean amplitude drifts by -5.2 standard errors (limit 4)")


# --------------------------------------------------------------------------------------------
# E: no stationary density: the large-amplitude energy balance against the averaged model
@pytest.mark.parametrize("values", [
    {"system.c1": 0.0, "system.c2": 0.0, "system.mu": 0.0, "system.r": 1.0},
    {"system.c1": 0.5, "system.c2": 0.0, "system.mu": 0.05, "system.r": 1.0},
    {"system.velocity_damping": [-1.0]},
    {"system.c1": 0.5, "system.c2": 0.0},  # impacts ~ A^5 outgrow the gain ~ A^4
    {"system.c1": 0.0, "system.c2": 0.0, "system.mu": 0.05, "system.r": 1.0},  # friction
    {"system.restoring": [1.0, 0.0, 1.0], "system.damping": [-0.5], "system.r": 0.9},
    {"system.restoring": [1.0, 0.0, 1.0], "system.damping": [-0.5], "system.r": 0.9,
     "system.velocity_damping": [-0.01]},
])
@pytest.mark.numpy_errors_ok
@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_energy_balance_agrees_with_the_averaged_model(values):
    """energy_balance's verdict from the exponents alone (no constants) against an independent
    truth: the exact averaged model's stationary density by orbit quadrature (averaging/),
    which exists exactly when the averaged energy drift turns negative at large amplitude."""
    from vifpk.harness.door.solvers import SolverFailure, run_solver

    from vifpk.core.scene import energy_balance, load_scene

    scene = load_scene(DATA / "tiny.toml").with_values(values)
    bal = energy_balance(scene.system)
    assert not bal.tie
    try:
        run_solver(scene, "averaging", model="exact")
        exists = True
    except SolverFailure as exc:
        assert "no stationary density" in str(exc)
        exists = False
    assert exists == (not bal.grows), bal.text


def test_a_tie_is_left_to_the_solvers():
    """A linear spring with c1 > 0, c2 = 0 and impacts: gain and loss both ~ A^2, so the
    constants decide: not refused up front (c1 = 0.5, c2 = 0 with the cubic spring is not a
    tie: the impacts win, and the averaged model has a density there)."""
    from vifpk.harness.request import validate

    from vifpk.core.scene import energy_balance, load_scene

    base = load_scene(BASE)
    tie = base.with_values({"system.c1": 0.5, "system.c2": 0.0, "system.alpha": 0.0})
    bal = energy_balance(tie.system)
    assert bal.tie and bal.degree == 2 and bal.gains == ("system.c1",)
    assert bal.losses == ("system.r",)
    validate.stationary_density(tie)
    validate.stationary_density(base.with_values({"system.c1": 0.5, "system.c2": 0.0}))


def test_a_blow_up_leads_with_energy_growth(capsys):
    """The tie above blows up at run time (the gain wins): the one line says the energy grows
    without bound before any time-step advice."""
    from vifpk.harness.cli.app import main

    assert main(["solve", str(DATA / "tiny.toml"), *MC, "--set", "system.alpha=0", "--set",
                 "system.c2=0", "--set", "system.c1=0.5"]) == 3
    err = capsys.readouterr().err
    err = err[err.find("vifpk: "):].strip().splitlines()
    assert len(err) == 1, err
    line = err[0]
    assert line.startswith("vifpk: the Monte Carlo blew up")
    assert "most likely the energy grows without bound" in line
    assert line.index("energy grows without bound") < line.index("smaller --dt")


# --------------------------------------------------------------------------------------------
# D: the automatic burn-in priced again after the relaxation pilot
@pytest.mark.slow
@pytest.mark.parametrize("command", ["solve", "check"])
def test_auto_burn_in_is_priced_after_the_relaxation_pilot(command, tmp_path, monkeypatch,
                                                           capsys):
    """The relaxation time is measured, not known up front: once the pilot has measured it,
    the run is priced again with the same guard (here a machine of 1e-3 path-steps per second,
    so any burn-in is above the hour): exit 2 before the burn-in, one line naming the measured
    relaxation time, the price and the ways out; nothing written. The up-front estimate is
    far below an hour/8 at the fastest rate, so it passes without the measured speed."""
    from vifpk.harness.cli.app import main

    monkeypatch.setenv("VIFPK_STEPS_PER_SECOND", "1e-3")
    out = tmp_path / ("mc.json" if command == "solve" else "report")
    code = main([command, str(DATA / "tiny.toml"), "--set", "montecarlo.burn_in='auto'",
                 *((*MC, "--json") if command == "solve" else ("--quiet", "--out")),
                 str(out)])
    err = capsys.readouterr().err
    err = err[err.find("vifpk: "):].strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith("vifpk: error: the relaxation pilot measured a relaxation time "
                             "of ")
    assert "estimated at least" in err[0] and "allowed without --yes: up to 1 hour" in err[0]
    assert "give --yes, a fixed burn-in (--set montecarlo.burn_in=T)" in err[0]
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_yes_lifts_the_price_of_the_measured_burn_in(monkeypatch):
    from vifpk.harness.request import cost

    from vifpk.core.scene import load_scene

    monkeypatch.setenv("VIFPK_STEPS_PER_SECOND", "2e7")
    scene = load_scene(BASE).with_values({"montecarlo.threads": 1})
    assert cost.run_cost_limit(scene, True) is None
    assert cost.run_cost_limit(scene, False) == (cost.HOUR, 2e7)


# --------------------------------------------------------------------------------------------
# A: a folder the system refuses (immutable, read-only): the write probe's OS error, simulated
# (root ignores permissions here, so a real immutable folder cannot be made in a test)
@pytest.mark.parametrize("err", [(13, "Permission denied"), (30, "Read-only file system")])
@pytest.mark.parametrize("command", ["sweep", "check"])
def test_unwritable_folder_is_refused_before_any_work(err, command, tmp_path, monkeypatch,
                                                      capsys, no_computation):
    import tempfile

    import vifpk.harness.request.outpaths

    def refuse(*a, **k):
        raise OSError(err[0], err[1])

    args = (["sweep", str(_sweep_file(tmp_path / "in"))] if command == "sweep"
            else ["check", BASE])
    from vifpk.harness.cli.app import main

    before = _snapshot(tmp_path)
    monkeypatch.setattr(vifpk.harness.request.outpaths.tempfile, "mkstemp", refuse)
    try:
        code = main([*args, "--out", str(tmp_path / "o")])
    finally:
        monkeypatch.setattr(vifpk.harness.request.outpaths.tempfile, "mkstemp", tempfile.mkstemp)
    out = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(out) == 1, out
    assert f"--out {tmp_path / 'o'}: cannot write in {tmp_path} ({err[1]})" in out[0]
    assert _snapshot(tmp_path) == before
