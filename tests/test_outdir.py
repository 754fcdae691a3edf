"""Output folders written as a unit (harness/outputs/outdir.py): the swap, the lock, stale
leftovers,
file modes under a umask. Fast: the folders hold a few small files, no numerics."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from vifpk.harness.outputs import outdir

from vifpk.core.io import write_json

ROOT = Path(__file__).resolve().parent.parent
NAMES = ("a.txt", "b.txt", "sub")


def _fill(run_id: str):
    def fill(tmp: Path) -> None:
        (tmp / "a.txt").write_text(run_id)
        (tmp / "sub").mkdir()
        (tmp / "sub" / "c.txt").write_text(run_id)
        (tmp / "b.txt").write_text(run_id)
    return fill


def _ids(folder: Path) -> set[str]:
    return {(folder / n).read_text() for n in ("a.txt", "b.txt", "sub/c.txt")}


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.parent.iterdir() if p.name.startswith(f".{folder.name}."))


def test_new_set_replaces_old_set_whole(tmp_path: Path):
    out = tmp_path / "rep"
    outdir.write_folder(out, _fill("one"), run_id="one", allowed=NAMES)
    assert _ids(out) == {"one"}
    outdir.write_folder(out, _fill("two"), run_id="two", allowed=NAMES)
    assert _ids(out) == {"two"} and _leftovers(out) == []


def test_failed_fill_keeps_old_set_and_leaves_nothing(tmp_path: Path):
    out = tmp_path / "rep"
    outdir.write_folder(out, _fill("one"), run_id="one", allowed=NAMES)

    def bad(tmp: Path) -> None:
        (tmp / "a.txt").write_text("two")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        outdir.write_folder(out, bad, run_id="two", allowed=NAMES)
    assert _ids(out) == {"one"} and _leftovers(out) == []


def test_nothing_written_leaves_no_parent_and_no_lock(tmp_path: Path):
    out = tmp_path / "new" / "rep"
    with pytest.raises(KeyboardInterrupt), outdir.hold(out, run_id="x"):
        raise KeyboardInterrupt
    assert not (tmp_path / "new").exists()


def test_refuses_a_file_and_a_foreign_folder(tmp_path: Path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(outdir.FolderRefused, match="not a folder"):
        outdir.write_folder(tmp_path / "f", _fill("one"), run_id="one", allowed=NAMES)
    home = tmp_path / "home"
    home.mkdir()
    (home / "thesis.tex").write_text("precious")
    with pytest.raises(outdir.FolderRefused, match="thesis.tex"):
        outdir.write_folder(home, _fill("one"), run_id="one", allowed=NAMES)
    assert (home / "thesis.tex").read_text() == "precious"


def test_exchange_unavailable_falls_back_and_recovers(tmp_path: Path, monkeypatch):
    out = tmp_path / "rep"
    outdir.write_folder(out, _fill("one"), run_id="one", allowed=NAMES)
    monkeypatch.setattr(outdir, "_exchange", lambda a, b: False)
    outdir.write_folder(out, _fill("two"), run_id="two", allowed=NAMES)
    assert _ids(out) == {"two"} and _leftovers(out) == []
    # a run cut between the fallback's two renames: DIR absent, the old set at .DIR.old-*
    os.rename(out, tmp_path / ".rep.old-two")
    (tmp_path / ".rep.partial-three").mkdir()
    with outdir.hold(out, run_id="four"):
        pass
    assert _ids(out) == {"two"} and _leftovers(out) == []


# ---------------------------------------------------------------- kill tests and the lock
_WRITER = textwrap.dedent("""
    import sys
    from pathlib import Path
    from vifpk.harness.outputs import outdir
    if sys.argv[3] == "no-exchange":
        outdir._exchange = lambda a, b: False
    run_id = sys.argv[2]
    def fill(tmp):
        (tmp / "a.txt").write_text(run_id)
        (tmp / "sub").mkdir()
        (tmp / "sub" / "c.txt").write_text(run_id)
        outdir._hook("fill")
        (tmp / "b.txt").write_text(run_id)
    outdir.write_folder(sys.argv[1], fill, run_id=run_id, allowed=("a.txt", "b.txt", "sub"))
""")


def _start_paused(out: Path, run_id: str, moment: str, flag: Path,
                  mode: str = "exchange") -> subprocess.Popen:
    env = dict(os.environ, VIFPK_TEST_PAUSE=moment, VIFPK_TEST_PAUSE_FILE=str(flag),
               PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", _WRITER, str(out), run_id, mode], env=env)
    reached = Path(str(flag) + ".reached")
    for _ in range(3000):  # up to 30 s for the interpreter to start and reach the moment
        if reached.exists() or proc.poll() is not None:
            break
        time.sleep(0.01)
    assert reached.exists(), f"the writer never reached {moment} (exit {proc.poll()})"
    return proc


@pytest.mark.parametrize(("moment", "mode"), [("fill", "exchange"), ("before-swap", "exchange"),
                                              ("after-swap", "exchange"),
                                              ("between-renames", "no-exchange")])
def test_sigkill_leaves_old_or_new_set_and_next_run_cleans(tmp_path: Path, moment, mode):
    out = tmp_path / "rep"
    outdir.write_folder(out, _fill("one"), run_id="one", allowed=NAMES)
    proc = _start_paused(out, "two", moment, tmp_path / "go", mode)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    if moment == "between-renames":
        assert not out.exists()  # the fallback's gap: no folder, never a mix
    else:
        assert _ids(out) == ({"two"} if moment == "after-swap" else {"one"})
    assert outdir.lock_path(out).exists()  # the killed run's lock, now stale
    outdir.write_folder(out, _fill("three"), run_id="three", allowed=NAMES)
    assert _ids(out) == {"three"} and _leftovers(out) == []


def test_second_run_into_a_held_folder_is_refused(tmp_path: Path):
    out = tmp_path / "rep"
    outdir.write_folder(out, _fill("one"), run_id="one", allowed=NAMES)
    flag = tmp_path / "go"
    proc = _start_paused(out, "two", "fill", flag)
    try:
        holder = json.loads(outdir.lock_path(out).read_text())
        assert holder["pid"] == proc.pid and holder["run_id"] == "two"
        with pytest.raises(outdir.FolderBusy, match=f"pid {proc.pid}, run two"):
            outdir.write_folder(out, _fill("three"), run_id="three", allowed=NAMES)
        assert _ids(out) == {"one"}
    finally:
        flag.write_text("")
        assert proc.wait(timeout=60) == 0
    assert _ids(out) == {"two"} and not outdir.lock_path(out).exists()
    assert _leftovers(out) == []


def test_cli_refuses_a_held_folder_before_any_work(tmp_path: Path, capsys):
    from vifpk.harness.cli.app import main

    out = tmp_path / "rep"
    flag = tmp_path / "go"
    proc = _start_paused(out, "two", "fill", flag)
    try:
        assert main(["check", str(ROOT / "tests" / "data" / "tiny.toml"), "--out", str(out),
                     "--quiet"]) == 2
    finally:
        flag.write_text("")
        proc.wait(timeout=60)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "another vifpk run is writing this folder" in err[0]
    assert f"pid {proc.pid}" in err[0]


# ---------------------------------------------------------------- modes follow the umask
@pytest.mark.parametrize("umask", [0o022, 0o027, 0o077])
def test_modes_follow_the_umask(tmp_path: Path, umask: int):
    old = os.umask(umask)
    try:
        out = tmp_path / "rep"
        outdir.write_folder(out, _fill("one"), run_id="one", allowed=NAMES)
        write_json(tmp_path / "x.json", {"a": 1})
    finally:
        os.umask(old)
    assert (out / "a.txt").stat().st_mode & 0o777 == 0o666 & ~umask
    assert (out / "sub").stat().st_mode & 0o777 == 0o777 & ~umask
    assert out.stat().st_mode & 0o777 == 0o777 & ~umask
    assert (tmp_path / "x.json").stat().st_mode & 0o777 == 0o666 & ~umask



def test_replaceability_is_checked_on_what_recovery_restores(tmp_path: Path):
    """A run killed between the fallback's two renames leaves DIR absent and its old set at
    .DIR.old-<id>; the next run restores it under the lock. Checked only before the lock, a
    check report into DIR saw no folder and replaced the restored sweep (issue 38 item 4:
    the replaceability was checked before the lock, not after)."""
    out = tmp_path / "rep"

    def killed_sweep() -> None:
        old = tmp_path / ".rep.old-killed"
        (old / "points").mkdir(parents=True)
        (old / "sweep.nc").write_text("the sweep")

    killed_sweep()
    with pytest.raises(outdir.FolderRefused, match="holds files this command does not write"):
        outdir.write_folder(out, _fill("one"), run_id="one", allowed=NAMES)
    assert (out / "sweep.nc").read_text() == "the sweep" and _leftovers(out) == []
    os.rename(out, tmp_path / ".rep.old-killed")  # killed again, between the renames
    with pytest.raises(outdir.FolderRefused, match="is a sweep folder"), \
            outdir.hold(out, run_id="two", allowed=(*NAMES, "points", "sweep.nc"),
                        kind="check report"):
        pass
    assert (out / "sweep.nc").read_text() == "the sweep" and _leftovers(out) == []


@pytest.mark.parametrize("where", ["after-create", "after-lock"])
def test_a_signal_while_the_lock_is_taken_leaves_no_lock_file(tmp_path: Path, monkeypatch,
                                                              where: str):
    """A SIGHUP that landed between the lock file's creation and its recording left an empty
    ``.DIR.lock`` (seen 3 times in 40 under load, tests/test_edges5.py's SIGHUP test once in
    CI-like runs). The signal handler of signals.install() is called here by hand at the two
    moments: inside the critical section it is held until the section ends, then raised, and
    the cleanup finds the file."""
    from vifpk.harness.outputs import signals

    real_open, real_write = os.open, os.write

    def fire() -> None:
        signals._term_handler(signal.SIGHUP, None)

    def opening(*a, **k):
        fd = real_open(*a, **k)
        if where == "after-create" and str(a[0]).endswith(".lock"):
            fire()
        return fd

    def writing(fd, data):
        n = real_write(fd, data)
        if where == "after-lock" and b'"pid"' in data:
            fire()
        return n

    monkeypatch.setattr(outdir.os, "open", opening)
    monkeypatch.setattr(outdir.os, "write", writing)
    entered = []
    with pytest.raises(signals.Terminated):
        with outdir.hold(tmp_path / "out", run_id="r"):
            entered.append(True)
    assert entered == [] and os.listdir(tmp_path) == []
