"""The check report as written output: one run id in every file, provenance in every output,
the folder swap under SIGKILL, byte-identical metrics.json for one seed, modes under a umask.

One cross-check of the tiny scene (tests/data/tiny.toml) is computed for the session
(tests/conftest.py ``tiny_check``) and reused; the kill tests re-write its report in
subprocesses that pause at a named moment of the writing (``VIFPK_TEST_PAUSE``,
harness/outputs/outdir.py) and are SIGKILLed there, their figures blank PNGs carrying the run
id (tests/conftest.py ``blank_png``; the swap is their subject, the run fixture's report has
the real figures). The byte-identical test is in the slow tier.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import pickle
import re
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from vifpk.harness.cli.app import main
from vifpk.harness.outputs.report import write_report

from tests.conftest import TINY_CHECK_SET
from vifpk.core import provenance
from vifpk.core.io import dumps

ROOT = Path(__file__).resolve().parent.parent
TINY = str(ROOT / "tests" / "data" / "tiny.toml")
RUN_ID = re.compile(r"\d{8}T\d{6}Z-[0-9a-f]{6}")
KEYS = {"run_id", "created", "vifpk", "git", "versions", "command", "scene", "overrides"}


@pytest.fixture(scope="module")
def run(tmp_path_factory, tiny_check):
    tmp = tmp_path_factory.mktemp("report")
    res = tiny_check
    prov = provenance.collect(argv=["vifpk", "check", TINY], scene_path=TINY)
    # as `vifpk check` writes it: with the run's counted RuntimeWarnings (none here)
    write_report(res, tmp / "first", prov=prov, runtime_warnings=[])
    (tmp / "res.pickle").write_bytes(pickle.dumps(res))
    return {"res": res, "prov": prov, "dir": tmp / "first", "pickle": tmp / "res.pickle"}


def run_ids(folder: Path) -> set[str]:
    """The run id of each file of a report folder (a complete set has exactly one)."""
    from PIL import Image

    ids = {json.loads((folder / "metrics.json").read_text())["provenance"]["run_id"]}
    for name in ("report.md", "report.html"):
        ids |= set(RUN_ID.findall((folder / name).read_text()))
    with np.load(folder / "arrays.npz") as z:
        ids.add(str(z["run_id"]))
    for png in sorted((folder / "figures").glob("*.png")):
        with Image.open(png) as im:
            im.load()
            ids.add(im.text["vifpk run id"])
    return ids


def _prov(run_id: str) -> dict:
    return provenance.collect(argv=["vifpk", "check", TINY], scene_path=TINY, run_id=run_id)


def test_every_file_carries_the_same_run_id_and_the_provenance(run):
    folder, prov = run["dir"], run["prov"]
    assert run_ids(folder) == {prov["run_id"]}
    m = json.loads((folder / "metrics.json").read_text())
    assert set(m["provenance"]) == KEYS and m["provenance"] == json.loads(dumps(prov))
    assert m["provenance"]["scene"]["sha256"] == hashlib.sha256(Path(TINY).read_bytes()
                                                                ).hexdigest()
    for name in ("report.md", "report.html"):
        text = (folder / name).read_text()
        assert text.count(prov["run_id"]) >= 2, name  # under the title and in the block
        for key in ("created", "vifpk", "command"):
            assert prov[key] in text.replace("&#x27;", "'"), (name, key)
        assert prov["scene"]["sha256"] in text and "numpy" in text


def test_timings_and_provenance_are_the_only_machine_dependent_keys(run):
    m = json.loads((run["dir"] / "metrics.json").read_text())
    assert list(m)[-2:] == ["timings", "provenance"]
    assert "steps_per_second" not in json.dumps({k: v for k, v in m.items()
                                                 if k not in ("timings", "provenance")})
    assert m["timings"]["steps_per_second"]["mc:original"] > 0


@pytest.mark.slow  # a second real check in a new process (bit-for-bit reproducibility)
def test_metrics_byte_identical_across_runs_and_modes_follow_umask(run, tmp_path: Path):
    """A second run of the same scene and seed, in a new process with another thread count and
    umask 027: metrics.json without "timings" and "provenance" is byte-identical."""
    out = tmp_path / "second"
    env = dict(os.environ, PYTHONPATH=str(ROOT), NUMBA_NUM_THREADS="1")
    sets = [a for s in TINY_CHECK_SET for a in ("--set", s)]  # as the session's check
    subprocess.run([sys.executable, "-m", "vifpk", "check", TINY, *sets, "--out", str(out),
                    "--quiet"], env=env, check=True, capture_output=True,
                   preexec_fn=lambda: os.umask(0o027))
    a = (run["dir"] / "metrics.json").read_text()
    b = (out / "metrics.json").read_text()
    assert a.split('\n "timings"')[0] == b.split('\n "timings"')[0]

    def strip(text: str) -> str:
        d = json.loads(text)
        del d["timings"], d["provenance"]
        return dumps(d)

    assert strip(a) == strip(b)
    for p in [out, *out.rglob("*")]:
        want = (0o777 if p.is_dir() else 0o666) & ~0o027
        assert p.stat().st_mode & 0o777 == want, p


# the figures are 1 x 1 PNGs carrying the run id (tests/conftest.py blank_png): the swap is the
# subject, drawing them cost ~2 s of CPU a kill (the real ones: the run fixture's report)
_KILLED = textwrap.dedent("""
    import pickle, sys
    from tests.conftest import blank_png
    from vifpk.core import provenance
    from vifpk.harness.outputs import report
    from vifpk.harness.outputs.report import write_report

    report._figure_densities = report._figure_decomposition = blank_png
    res = pickle.loads(open(sys.argv[1], "rb").read())
    prov = provenance.collect(argv=["vifpk", "check"], run_id=sys.argv[3])
    write_report(res, sys.argv[2], prov=prov)
""")


@pytest.mark.slow
@pytest.mark.parametrize("moment", ["fill", "before-swap", "after-swap"])
def test_sigkill_while_writing_leaves_one_whole_set(run, tmp_path: Path, moment, blank_figures):
    import shutil

    out = tmp_path / "rep"
    shutil.copytree(run["dir"], out)  # the old set
    flag = tmp_path / "go"
    new = "20261123T000001Z-000002"
    env = dict(os.environ, PYTHONPATH=str(ROOT), VIFPK_TEST_PAUSE=moment,
               VIFPK_TEST_PAUSE_FILE=str(flag))
    proc = subprocess.Popen([sys.executable, "-c", _KILLED, str(run["pickle"]), str(out), new],
                            env=env)
    reached = Path(str(flag) + ".reached")
    for _ in range(6000):  # up to 60 s to import, render and reach the moment
        if reached.exists() or proc.poll() is not None:
            break
        time.sleep(0.01)
    assert reached.exists(), f"never reached {moment} (exit {proc.poll()})"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    want = new if moment == "after-swap" else run["prov"]["run_id"]
    assert run_ids(out) == {want}
    write_report(run["res"], out, prov=_prov("20261123T000002Z-000003"))
    assert run_ids(out) == {"20261123T000002Z-000003"}
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".rep.")] == []
    assert not list(out.glob(".*"))


def test_overrides_name_the_title_and_the_default_folder(run, tmp_path: Path, monkeypatch,
                                                         capsys, blank_figures):
    """Figures blank (tests/conftest.py ``blank_png``): names and overrides are the subject."""
    import vifpk.harness.workflows.check

    monkeypatch.setattr(vifpk.harness.workflows.check, "cross_check",
                        lambda scene, quiet, **_: dataclasses.replace(run["res"], scene=scene))
    monkeypatch.chdir(tmp_path)
    assert main(["check", TINY, "--set", "system.mu=0.01", "--quiet"]) == 0
    folder = tmp_path / "out" / "tiny+system.mu=0.01"
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [folder.name]
    md = (folder / "report.md").read_text()
    assert md.startswith("# Error report: tiny+system.mu=0.01\n") and "--set system.mu=0.01" in md
    m = json.loads((folder / "metrics.json").read_text())
    assert m["provenance"]["overrides"] == ["system.mu=0.01"]
    assert m["scene"]["name"] == "tiny+system.mu=0.01" and m["scene"]["system"]["mu"] == 0.01


def test_solve_json_carries_the_provenance(tmp_path: Path):
    out = tmp_path / "s.json"
    assert main(["solve", TINY, "--solver", "averaging", "--set", "noise.D=0.02",
                 "--json", str(out)]) == 0
    p = json.loads(out.read_text())["info"]["provenance"]
    assert set(p) == KEYS and p["overrides"] == ["noise.D=0.02"]
    assert p["command"].startswith("vifpk solve ") and "noise.D=0.02" in p["command"]
    assert p["scene"]["sha256"] == hashlib.sha256(Path(TINY).read_bytes()).hexdigest()


def test_the_one_line_answer_comes_first(run):
    """Issue 28 (day-one path): report.html and report.md put the recommendation above the
    verdict table and its paragraphs, not below them."""
    import html

    rec = run["res"].recommendation
    assert rec
    for name, shown in (("report.html", html.escape(rec)), ("report.md", rec)):
        text = (run["dir"] / name).read_text()
        assert 0 <= text.index(shown) < text.index("Verdict: is each averaged model usable "
                                                   "here?"), name
