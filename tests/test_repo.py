"""The repository keeps its promises: CI (.ci/run) runs every test, the slow tier included."""

from __future__ import annotations

import contextlib
import io
import shlex

import pytest

from tests.conftest import ROOT


class _Selected:
    """A plugin that records the node ids pytest selects (after -m deselection)."""

    def __init__(self) -> None:
        self.ids: set[str] = set()

    def pytest_collection_finish(self, session: pytest.Session) -> None:
        self.ids = {item.nodeid for item in session.items}


def collected(*args: str) -> set[str]:
    """The tests pytest selects with these arguments, collected in this process (the test
    modules are imported already; a subprocess would import everything again)."""
    rec = _Selected()
    with contextlib.redirect_stdout(io.StringIO()) as out:
        code = pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider",
                            "--rootdir", str(ROOT), "-c", str(ROOT / "pyproject.toml"),
                            *args, str(ROOT / "tests")], plugins=[rec])
    assert code == 0, out.getvalue()[-2000:]
    return rec.ids


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
