"""Issue 39 (edges, round 7): signals in the first second (X11). ``vifpk`` answers Ctrl-C and
SIGTERM during its imports in one line, with the commands' exit codes (harness/cli/entry.py)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest


@pytest.mark.parametrize("signum, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_x11_a_signal_during_the_imports_is_one_line(tmp_path, signum, code):
    """The signal arrives once numpy's extension is mapped (read in /proc: the command is
    importing numpy, scipy and the workflows, about 0.9 s warm on this machine): before
    harness/cli/entry.py, Ctrl-C there printed a KeyboardInterrupt traceback and SIGTERM
    nothing."""
    out = tmp_path / "out"
    p = subprocess.Popen([sys.executable, "-m", "vifpk", "check", "paper-base", "--out",
                          str(out)], stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                         # a test run started in the background inherits SIGINT ignored
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    maps = f"/proc/{p.pid}/maps"
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:  # numpy's extension mapped: the imports are under way
        try:
            if "_multiarray_umath" in open(maps).read():
                break
        except OSError:
            break
        time.sleep(0.005)
    p.send_signal(signum)
    _, err = p.communicate(timeout=60)
    assert p.returncode == code, err
    assert err == "vifpk: interrupted; nothing was written\n"
    assert not out.exists()


def test_the_command_recorded_is_the_argv_given_and_the_guard_is_released(monkeypatch):
    """app.main records ``vifpk`` + the arguments it was given (provenance's ``command``), not
    the process's sys.argv (the ``argv is None`` branch there could not be reached: argv is a
    list by then, issue 38 item 4); the import-time guard is released through the function
    entry.py hands in (app and entry no longer import each other: the cycle test)."""
    import argparse

    from vifpk.harness.cli import app
    from vifpk.harness.cli.options import _Parser
    from vifpk.harness.outputs import signals

    seen: dict[str, object] = {}

    def command(args):
        seen["argv"] = args.argv
        return 0

    monkeypatch.setattr(_Parser, "parse_args", lambda self, argv=None, namespace=None:
                        argparse.Namespace(func=command, debug=False))
    monkeypatch.setattr(sys, "argv", ["vifpk", "something", "else"])
    assert app.main(["models", "--x"]) == 0
    assert seen["argv"] == ["vifpk", "models", "--x"]
    released = []
    monkeypatch.setattr(signals, "install", lambda: None)  # no handlers in the test process
    assert app.main(None, release_guard=lambda: released.append(1)) == 0
    assert seen["argv"] == ["vifpk", "something", "else"] and released == [1]
