"""Issue 20: the edges. Every reproducer of the issue as a case: sweep output folders (lock,
refusal, whole-folder rules shared with check, a sweep folder and a report folder told apart,
names kept inside out/), wrong scene paths, signals on every executor, tracebacks and ignored
input, the cost guard, the verdict over every observable.

The catalogue runs in-process with every entry point of real work replaced by one that fails
the test (the input must be refused first). The signal tests are subprocesses on tiny sweeps
(a point of tests/data/sweep-averaging.toml is a few seconds of closed forms).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from .conftest import ROOT

DATA = ROOT / "tests" / "data"
BASE = "paper-base"
MC = ("--solver", "montecarlo")
LONG = "x" * 300
ENV = {**os.environ, "NUMBA_NUM_THREADS": "1", "PYTHONPATH": os.pathsep.join(
    [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}

SWEEP = ('scene = "tiny"\nworkflow = "averaging"\n[vary]\n"system.r" = [0.95, 0.97]\n')


def _sweep_file(folder: Path, text: str = SWEEP, name: str = "s.toml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "tiny.toml").write_text((DATA / "tiny.toml").read_text())
    p = folder / name
    p.write_text(text)
    return p


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
    ]


CASES = _setup_cases()


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() if p.is_file() else b"<dir>"
            for p in sorted(folder.rglob("*"))}


@pytest.fixture
def no_computation(monkeypatch):
    """Replace every entry point of real work by one that fails the test."""
    import harness.bifurcation
    import harness.check
    import harness.cli
    import harness.figures
    import harness.run
    import harness.sweep
    import harness.workprecision

    def forbidden(*a, **k):
        raise AssertionError("computation started before the input was checked")

    for mod, name in ((harness.cli, "run_solver"), (harness.run, "run_solver"),
                      (harness.run, "montecarlo_solution"), (harness.run, "fpk_solution"),
                      (harness.check, "cross_check"), (harness.bifurcation, "bifurcation"),
                      (harness.figures, "draw_figures"), (harness.sweep, "run_point"),
                      (harness.workprecision, "run_workprecision")):
        monkeypatch.setattr(mod, name, forbidden)


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_refused_before_any_work(case, no_computation, tmp_path, monkeypatch, capsys):
    from harness.cli import main

    monkeypatch.chdir(tmp_path)
    args = case[1](tmp_path)
    before = _snapshot(tmp_path)
    code = main(args)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1 and case[2] in err[0], err
    assert _snapshot(tmp_path) == before
    assert not list(tmp_path.rglob(".*.lock"))


# --------------------------------------------------------------------------------------------
# A: the lock, and the name of the default folder
def _canned(monkeypatch):
    """The averaging workflow replaced by a canned result: plumbing only, no physics."""
    import harness.sweep

    def canned(job):
        r = dict(job.params)["system.r"]
        return {"models": {m: {"mean_A": 1.0 + r} for m in ("paper", "exact", "corrected")},
                "flags": {"warn_narrow_band": False, "warn_strong_damping": False,
                          "warn_strong_noise": False}, "warnings": [], "L1_paper_exact_A": 0.1}

    monkeypatch.setitem(harness.sweep.WORKFLOW_FUNCTIONS, "averaging", canned)


def test_second_sweep_into_a_held_folder_is_refused(tmp_path, monkeypatch, capsys):
    """Another live run holds the folder (its lock taken by a second process): refused."""
    from harness.cli import main

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
    from harness.cli import main

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
    from harness.cli import main

    _canned(monkeypatch)
    monkeypatch.chdir(tmp_path)
    sweep = _sweep_file(tmp_path / "a" / "b", 'name = "../../escaped"\n' + SWEEP)
    assert main(["sweep", str(sweep), "--quiet"]) == 0
    made = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.iterdir())
    assert made == ["a", "out"]
    assert [p.name for p in (tmp_path / "out").iterdir()] == ["_.._escaped"]


def test_sweep_file_with_bom_is_read(tmp_path, monkeypatch, capsys):
    from harness.sweep import load_sweep

    p = _sweep_file(tmp_path)
    p.write_bytes(b"\xef\xbb\xbf" + p.read_bytes())
    assert [pt.params for pt in load_sweep(p).points] == [(("system.r", 0.95),),
                                                          (("system.r", 0.97),)]


def test_shipped_names_still_resolve():
    """A bare name finds a shipped scene or sweep; hard/NAME too."""
    from harness.sweep import load_sweep
    from vifpk.core.scene import load_scene

    assert load_scene("paper-base").system.r == 0.96
    assert load_scene("hard/r-low").source == "r-low.toml"
    assert load_sweep("r-mu").workflow == "check"


# --------------------------------------------------------------------------------------------
# B: signals (subprocesses on a tiny sweep; a few seconds each)
def _start_sweep(tmp_path: Path, executor: str) -> tuple[subprocess.Popen, Path]:
    out = tmp_path / "o"
    proc = subprocess.Popen(
        [sys.executable, "-m", "harness", "sweep", str(DATA / "sweep-averaging.toml"), "--out",
         str(out), "--executor", executor, "--quiet"], env=ENV, cwd=tmp_path,
        stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True, start_new_session=True,
        # a test run started in the background inherits SIGINT ignored
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    t0 = time.monotonic()
    while not list((out / "points").glob("*.json")) and time.monotonic() - t0 < 120:
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.05)
    return proc, out


def _group(pid: int) -> list[int]:
    res = subprocess.run(["ps", "-eo", "pid=,pgid=,stat="], capture_output=True, text=True)
    return [int(p) for p, g, st in (ln.split() for ln in res.stdout.splitlines())
            if int(g) == pid and not st.startswith("Z")]


@pytest.mark.parametrize("how", ["SIGINT-group",
                                 pytest.param("SIGTERM-pid", marks=pytest.mark.slow),
                                 pytest.param("SIGKILL-pid", marks=pytest.mark.slow)])
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
    kept = len(list((out / "points").glob("*.json")))
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


def test_sigterm_on_check_is_like_ctrl_c(tmp_path):
    """check on SIGTERM: exit 143 with the one message, no .lock, nothing written."""
    proc = subprocess.Popen([sys.executable, "-m", "harness", "check", str(DATA / "tiny.toml"),
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
