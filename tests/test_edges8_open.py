"""Issue 45 item 1, "still open from earlier rounds" (docs/edges.md round 8), and the own
cases of round 8 that became fixes. Fast: refusals before any work, in-process."""

from __future__ import annotations

import errno
from pathlib import Path

import pytest
from vifpk.harness.cli.app import main

ROOT = Path(__file__).resolve().parents[1]
BD = "systems/bilateral-duffing"


@pytest.mark.parametrize("below", [float("nan"), -1.0, 0.0, "0.1", True])
def test_assert_averaging_error_refuses_a_bound_that_can_never_pass(monkeypatch, below):
    """``below=float("nan")`` ran the Monte Carlo, then failed as an AssertionError ("is not
    below nan"): a usage error, BadInput before any work."""
    import vifpk.harness.testing as testing

    import vifpk
    from vifpk.core.result import BadInput

    monkeypatch.setattr(testing, "mc_reference", lambda *a, **k: pytest.fail("MC ran"))
    with pytest.raises(BadInput, match=r"^below .*allowed: a finite number > 0"):
        vifpk.assert_averaging_error("paper-base", model="exact", below=below)


def test_json_dash_is_the_standard_output(tmp_path, monkeypatch, capsys):
    """``vifpk solve ... --json -`` wrote a file named "-"; now the JSON is the standard
    output, alone (no "wrote -" line), and no file is made."""
    import json

    monkeypatch.chdir(tmp_path)
    assert main(["solve", "paper-base", "--model", "exact", "--json", "-"]) == 0
    cap = capsys.readouterr()
    rec = json.loads(cap.out)
    assert rec["scene"]["name"] == "paper-base" and "wrote" not in cap.err
    assert list(tmp_path.iterdir()) == []


def test_version_does_not_load_the_workflow_plugins(monkeypatch, capsys):
    """A workflow plugin whose import hangs hung ``vifpk --version``: the parser (which loads
    every registered workflow) is not built for it."""
    import vifpk.harness.cli.app as app

    monkeypatch.setattr(app, "build_parser", lambda: pytest.fail("the parser was built"))
    assert app.main(["--version"]) == 0
    assert capsys.readouterr().out.startswith("vifpk ")


def test_a_full_disk_names_the_file_not_the_standard_output(tmp_path):
    """A full disk under --out (ENOSPC from a library's write into a temporary file names no
    file) was reported as "cannot write the standard output": atomic_path names its file."""
    from vifpk.core.io import atomic_path

    target = tmp_path / "figure.png"
    with pytest.raises(OSError) as exc, atomic_path(target):
        raise OSError(errno.ENOSPC, "No space left on device")
    assert exc.value.filename == str(target) and exc.value.errno == errno.ENOSPC
    assert list(tmp_path.iterdir()) == []  # the temporary file is gone


def test_an_adaptive_resolution_of_1e9_is_refused_as_too_fine(tmp_path):
    """``[adaptive] resolution = 1e9`` was refused as "must be a whole number" (it is one,
    written as a float); the reason is its size."""
    from vifpk.harness.sweeps.errors import SweepError
    from vifpk.harness.sweeps.spec import load_sweep

    text = (ROOT / "scenes" / "sweeps" / "r-mu-adaptive.toml").read_text()
    p = tmp_path / "s.toml"
    p.write_text(text.replace("resolution = 40", "resolution = 1e9"))
    with pytest.raises(SweepError, match=r"resolution = 1000000000: too fine .*allowed: 3 to"):
        load_sweep(p)


def test_workprecision_help_lists_only_its_options(capsys):
    """``vifpk workprecision -h`` listed --paths, --time, --floor and --budget, which it
    refuses; they are no longer listed (and still refused in one line)."""
    with pytest.raises(SystemExit):
        main(["workprecision", "-h"])
    out = capsys.readouterr().out
    for gone in ("--paths", "--time", "--floor", "--budget"):
        assert gone not in out
    for kept in ("--dt H", "--seed", "--yes", "--repeats", "--quick"):
        assert kept in out
    assert main(["workprecision", "paper-base", "--paths", "64"]) == 2
    assert "--paths: does not apply to workprecision" in capsys.readouterr().err


@pytest.mark.parametrize("args, words", [
    # exit 3 after the work ("drift or diffusion is not finite and positive on [2.99e-301,
    # 0.8]") where --start 0 works
    (["passage", "paper-base", "--threshold", "0.8", "--start", "1e-300"],
     "--start 1e-300: out of range; allowed: 0 (the rest state) or an amplitude 1e-100 <= A0"),
    (["transient", "paper-base", "--start", "1e-300", "--times", "1,2,3"],
     "--start 1e-300: out of range; allowed: an amplitude >= 1e-100"),
    # a wall's yield speed obeys the magnitude rule (v_yield = 1e-300 went to the solvers)
    (["solve", BD, "--model", "exact", "--set", "system.lower_wall.law=johnson", "--set",
      "system.lower_wall.v_yield=1e-300"],
     "system.lower_wall.v_yield = 1e-300 is out of range; allowed: 1e-100 <= |v_yield|"),
])
def test_tiny_amplitudes_and_speeds_are_refused(capsys, args, words):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and words in err, err
