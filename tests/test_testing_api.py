"""harness.testing and the pytest plugin: pass when they should, fail readably, cache."""

from __future__ import annotations

import math
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest
from vifpk.harness import testing
from vifpk.harness.testing import assert_averaging_error, assert_density_close

from tests.conftest import ROOT

SMALL = {"paths": 128, "time": 400.0, "blocks": 16}


@pytest.fixture(autouse=True)
def isolated_cache(tmp_path):
    testing.configure(cache=tmp_path / "cache", refresh=False)
    yield
    testing.configure(cache=None, refresh=False)
    testing._STATE["cache"] = None


def gauss(mu=0.0, s=1.0):
    x = np.linspace(-8, 8, 4001)
    return {"x": x, "p": np.exp(-0.5 * ((x - mu) / s) ** 2) / (s * math.sqrt(2 * math.pi))}


def test_density_close_passes_and_fails_readably():
    assert_density_close(gauss(), gauss(0.001), atol=1e-2)
    with pytest.raises(AssertionError, match=r"L1 = 0\.0\d+ > tolerance 0\.01 = atol 0\.01 "
                                             r"\+ noise floor 0"):
        assert_density_close(gauss(), gauss(0.1), atol=1e-2)
    with pytest.raises(AssertionError, match="ks ="):
        assert_density_close(gauss(), gauss(0.5), atol=1e-2, metric="ks")
    assert_density_close((gauss()["x"], gauss()["p"]), gauss(), atol=1e-12)


def test_histogram_floor_is_added_automatically():
    edges = np.linspace(-4, 4, 41)
    c = 0.5 * (edges[1:] + edges[:-1])
    rng = np.random.default_rng(1)
    exact = np.exp(-0.5 * c**2) / math.sqrt(2 * math.pi)
    se = np.full(40, 0.01)
    hist = {"x": c, "p": exact + se * rng.standard_normal(40), "edges": edges, "err": se}
    m = assert_density_close(hist, gauss(), atol=0.0)  # passes on the floor alone
    assert m["L1"] <= m["L1_floor"] * 2
    with pytest.raises(AssertionError, match="noise floor"):
        assert_density_close(hist, gauss(0.3), atol=0.0)


# The pass/fail line between the two models at the base scene: the full check measures
# L1(A) = 0.076 +/- 0.002 (exact) and 0.484 +/- 0.002 (paper) against the original system
# (README, docs/numbers.json). At SMALL settings (128 paths) the noise floor is 0.057 and a
# run's L1 scatters by L1_err = 0.006 (measured: exact gives L1 = 0.057 +/- 0.006), so 0.2
# lies > 20 L1_err above exact's and below paper's (noise adds to L1, never makes 0.48 small).
BETWEEN_MODELS = 0.2


def test_averaging_error_pass_fail_and_message():
    m = assert_averaging_error("paper-base", "exact", below=BETWEEN_MODELS, **SMALL)
    assert m["L1"] < BETWEEN_MODELS
    with pytest.raises(AssertionError) as exc:
        assert_averaging_error("paper-base", "paper", below=BETWEEN_MODELS, **SMALL)
    msg = str(exc.value)
    # the paper model's L1 0.48 (README) with the noise of 128 paths on top (floor 0.057:
    # noise adds to L1, up to about twice its floor)
    got = re.search(r"averaging error of paper on p\(A\): L1 = ([0-9.]+) ", msg)
    assert got and 0.4 < float(got.group(1)) < 0.48 + 2 * 0.057
    assert "+/-" in msg and "noise floor" in msg and "128 paths" in msg
    assert "reproduce: vifpk solve paper-base --solver montecarlo --paths 128" in msg
    assert "(from cache)" in msg  # the second assertion reused the reference


@pytest.mark.slow
def test_user_model_protocol():
    from vifpk import averaging

    scene = testing._scene("paper-base")

    class Mine:  # the exact model's m and sigma^2, handed over as a user's object
        def __init__(self):
            self.m = averaging.build_model(scene, "exact")

        def drift(self, A):
            return self.m.drift(A)

        def diffusion(self, A):
            return self.m.diffusion(A)

    a = assert_averaging_error(scene, Mine(), below=BETWEEN_MODELS, observable="x2", **SMALL)
    b = assert_averaging_error(scene, "exact", below=BETWEEN_MODELS, observable="x2", **SMALL)
    # |L1(a, ref) - L1(b, ref)| <= L1(a, b) (triangle inequality; bin-averaging only shrinks
    # L1), the FPK route's discretisation error on x2: measured 7.7e-5 at 800 cells
    assert a["L1"] == pytest.approx(b["L1"], abs=5e-4)
    with pytest.raises(TypeError, match="provide drift"):
        assert_averaging_error(scene, object(), below=1.0, **SMALL)


def test_cache_is_hit_and_refreshed(pytester):
    pytester.makepyfile("""
        from vifpk.harness.testing import cache_stats

        def test_ref(vifpk_scene, vifpk_reference):
            ref = vifpk_reference(vifpk_scene("paper-base"), paths=32, time=20.0, blocks=16)
            print("CACHED", ref.cached)
            assert ref.data["A"]["p"].size > 0
    """)
    cache = pytester.path / "cache"
    # in-process (the plugin's options and fixtures are the same; the kernels stay compiled)
    first = pytester.runpytest_inprocess("-s", "--vifpk-cache", str(cache))
    first.assert_outcomes(passed=1)
    assert "CACHED False" in first.stdout.str()
    second = pytester.runpytest_inprocess("-s", "--vifpk-cache", str(cache))
    assert "CACHED True" in second.stdout.str()
    third = pytester.runpytest_inprocess("-s", "--vifpk-cache", str(cache), "--vifpk-refresh")
    assert "CACHED False" in third.stdout.str()
    assert len(list(cache.glob("*.npz"))) == 1


@pytest.mark.slow
def test_example_runs(tmp_path):
    example = tmp_path / "test_my_model.py"
    shutil.copy(ROOT / "docs" / "examples" / "test_my_model.py", example)
    shutil.copytree(ROOT / "docs" / "examples" / "plugin", tmp_path / "plugin")  # its model
    res = subprocess.run([sys.executable, "-m", "pytest", str(example), "-q", "-s",
                          "--vifpk-cache", str(tmp_path / "c"), "-p", "no:cacheprovider"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "2 passed" in res.stdout and "reproduce: vifpk solve" in res.stdout


@pytest.mark.parametrize("dt", ["scene", "auto"])
def test_reproduce_command_gives_the_same_reference(tmp_path, dt):
    """The command printed in a failure message rebuilds the reference bit for bit: run here
    in-process (harness.cli.app.main), with the scene's dt and with ``dt = "auto"``. Issue 19
    bug 2: with "auto" the command used to crash formatting dt with ``:g`` (after the Monte
    Carlo had run); it must say ``--dt auto``."""
    import json
    import shlex

    from vifpk.harness.cli.app import main

    values = {"noise.kind": "white", "montecarlo.paths": 32, "montecarlo.time": 20.0,
              "montecarlo.blocks": 16}
    if dt == "auto":
        values["montecarlo.dt"] = "auto"
    ref = testing.mc_reference(testing._scene("paper-base").with_values(values))
    if dt == "auto":
        assert " --dt auto " in ref.info["command"]
    out = tmp_path / "ref.json"
    cmd = ref.info["command"].replace("reference.json", str(out))
    assert cmd.startswith("vifpk solve ")
    assert main(shlex.split(cmd)[1:]) == 0
    got = json.loads(out.read_text())
    assert got["info"]["settings"]["dt"] == ref.info["settings"]["dt"]
    for key in ("A", "x1", "x2"):
        assert np.array_equal(np.array(got["pdf"][key]["p"]), ref.data[key]["p"])


# ---------------------------------------------------------------- issue 39: Y03, Y08, Y05
@pytest.fixture
def mfpt_calls(monkeypatch):
    """The time-domain doubles (tests/time_doubles.py: exponential first-passage times,
    T_exact / T_original - 1 = -1/6 exactly), with the list of the original system's runs.
    One warm-up call first: what it imports stays loaded when a later pytester fixture
    unloads what was imported after its creation."""
    import vifpk.harness.door.timedomain as door

    from tests import time_doubles as td

    td.install(monkeypatch)
    calls = []

    def counted(scene, **kw):
        calls.append(kw)
        return td.passage_montecarlo(scene, **kw)

    monkeypatch.setattr(door, "passage_montecarlo", counted)
    testing.assert_mfpt_close("paper-base", "exact", threshold=1.4, start=0.5, rtol=0.5,
                              paths=200)
    calls.clear()
    testing._STATE["stats"].update(hits=0, misses=0)
    return calls


def test_y03_y08_mfpt_references_are_cached_on_disk(mfpt_calls, tmp_path):
    """assert_mfpt_close's Monte Carlo of the original system goes through the reference
    cache (it was run again at every call): a second call reads it from the cache folder and
    gives the same metrics; another threshold, paths or seed is another key; --vifpk-refresh
    (configure(refresh=True)) runs it again."""
    from vifpk.harness.testing import assert_mfpt_close

    calls = mfpt_calls
    kw = {"threshold": 1.5, "start": 0.5, "rtol": 0.5, "paths": 400}
    first = assert_mfpt_close("paper-base", "exact", **kw)
    assert first["mfpt_error"]["value"] == pytest.approx(-1 / 6, abs=0.1)  # 400 exp. draws
    second = assert_mfpt_close("paper-base", "exact", **kw)
    assert len(calls) == 1 and testing.cache_stats() == {"hits": 1, "misses": 1}
    assert second["mfpt_error"] == first["mfpt_error"]
    assert len(list((tmp_path / "cache").glob("passage-*.npz"))) == 2  # and the warm-up's
    assert_mfpt_close("paper-base", "exact", **dict(kw, threshold=1.6))
    assert_mfpt_close("paper-base", "exact", **dict(kw, paths=401))
    assert_mfpt_close(testing._scene("paper-base").with_values({"montecarlo.seed": 7}),
                      "exact", **kw)
    assert len(calls) == 4
    testing.configure(refresh=True)
    assert_mfpt_close("paper-base", "exact", **kw)
    assert len(calls) == 5


def test_y08_vifpk_mfpt_uses_the_vifpk_cache_option(mfpt_calls, pytester):
    """The ``vifpk_mfpt`` fixture caches in the folder ``--vifpk-cache`` names (issue 39 Y08:
    it was not cached at all)."""
    calls = mfpt_calls
    pytester.makepyfile("""
        def test_mfpt(vifpk_mfpt):
            vifpk_mfpt("paper-base", "exact", threshold=1.5, start=0.5, rtol=0.5, paths=200)
    """)
    cache = pytester.path / "mine"  # one run (the hits: the test above)
    pytester.runpytest_inprocess("--vifpk-cache", str(cache)).assert_outcomes(passed=1)
    assert len(calls) == 1
    assert len(list(cache.glob("passage-*.npz"))) == 1


def test_y05_vifpk_cache_naming_a_file_is_a_usage_error(pytester):
    """``--vifpk-cache`` naming a file: pytest's usage error in one line naming the option,
    no traceback, no test run (a folder under a file is refused by the same check)."""
    f = pytester.path / "afile"
    f.write_text("x")
    pytester.makepyfile("def test_x():\n    pass\n")
    res = pytester.runpytest_inprocess("--vifpk-cache", str(f))
    assert res.ret == pytest.ExitCode.USAGE_ERROR
    err = res.stderr.str()
    assert f"--vifpk-cache {f}: {f} is a file, not a folder" in err
    assert "Traceback" not in err + res.stdout.str()
