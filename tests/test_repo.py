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


@pytest.mark.slow
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


@pytest.mark.slow
def test_xdist_groups_keep_their_tests_on_one_worker(tmp_path):
    """`--dist loadgroup` (the fast tier's and CI's) keeps an xdist_group on one worker, so a
    group's shared fixture (the wheel, the adaptive sweep, the CLI catalogue) is built once.
    pytest 9.2 broke this silently (pytest-dev/pytest-xdist#1386): CI then built the adaptive
    sweep twice (80 s each) and took 897 s; pyproject.toml pins pytest < 9.2 for it.
    pytest and xdist alone (no plugin autoloading): the grouping is theirs, and each of the
    three processes imported every installed plugin (vifpk's, hypothesis, ...) for 8 s of CPU
    in all, against 1.4 s without."""
    import os
    import re
    import subprocess
    import sys

    (tmp_path / "test_g.py").write_text(
        "import pytest\n"
        + "".join(f"@pytest.mark.xdist_group('g')\ndef test_g{i}(): pass\n" for i in range(6))
        + "".join(f"def test_free{i}(): pass\n" for i in range(6)))
    env = {**os.environ, "PYTEST_DISABLE_PLUGIN_AUTOLOAD": "1"}
    res = subprocess.run([sys.executable, "-m", "pytest", "-p", "no:cacheprovider",
                          "-p", "xdist.plugin", "-n", "2", "--dist", "loadgroup", "-v",
                          "test_g.py"], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stdout[-2000:]
    workers = set(re.findall(r"\[(gw\d)\].*PASSED test_g\.py::test_g\d", res.stdout))
    assert len(workers) == 1, res.stdout[-2000:]
