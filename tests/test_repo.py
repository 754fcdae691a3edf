"""The repository keeps its promises: CI (.ci/run) runs every test, the slow tier included."""

from __future__ import annotations

import shlex
import subprocess
import sys

from .conftest import ROOT


def collected(*args: str) -> set[str]:
    res = subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q",
                          "-p", "no:cacheprovider", *args], cwd=ROOT, capture_output=True,
                         text=True, timeout=600)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    return {line for line in res.stdout.splitlines() if "::" in line}


def test_ci_runs_every_test():
    """The pytest command of .ci/run selects the same tests as pytest with no marker filter
    (addopts emptied), and so includes the slow tier (e.g. the wheel test), and spreads them
    over the cores."""
    lines = [ln for ln in (ROOT / ".ci" / "run").read_text().splitlines()
             if ln.strip().startswith("python -m pytest")]
    assert len(lines) == 1, lines
    ci_args = shlex.split(lines[0])[3:]
    # xdist's options (-n N, --dist MODE) choose where tests run, not which
    for opt in ("-n", "--dist"):
        if opt in ci_args:
            i = ci_args.index(opt)
            del ci_args[i:i + 2]
    everything = collected("-o", "addopts=")
    assert collected(*ci_args) == everything
    assert any(t.startswith("tests/test_wheel.py::") for t in everything)
    assert "-n" in shlex.split(lines[0]) and "loadgroup" in lines[0]
