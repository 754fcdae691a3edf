"""Issue 39 (edges, round 7): band sweeps and the sweep extra, as a user meets them. Fast: the
sweep file is parsed and refused before any work (nothing runs, nothing is written)."""

from __future__ import annotations

import builtins
import sys
from pathlib import Path

import pytest
from vifpk.harness.sweeps import executors
from vifpk.harness.sweeps.errors import SweepError
from vifpk.harness.sweeps.spec import load_sweep

ROOT = Path(__file__).resolve().parents[1]
BAND = (ROOT / "scenes" / "sweeps" / "r-mu-adaptive.toml").read_text()


def _sweep(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(text.replace('scene = "paper-base"', 'scene = "paper-base"'))
    return p


@pytest.mark.parametrize("resolution, method, refused", [
    (1_000_000, "band", True), (65, "band", True), (64, "band", False),
    (1001, "verdict", True)])
def test_b19_a_lattice_too_fine_is_refused_before_work(tmp_path, resolution, method, refused):
    """B19: `resolution = 1000000` ran 65 s and then ran out of memory; the band's candidates
    weigh resolution^2 places with their covariance (MAX_CANDIDATES = 4096: 64 in 2-D)."""
    text = BAND.replace("resolution = 40", f"resolution = {resolution}\nmethod = \"{method}\"")
    path = _sweep(tmp_path, text)
    if refused:
        with pytest.raises(SweepError, match=r"resolution = \d+: too fine.*allowed: 3 to"):
            load_sweep(path)
    else:
        assert load_sweep(path).adaptive["resolution"] == resolution


def test_x02_a_missing_library_is_named(monkeypatch):
    """X02: `pip install -e .` without the sweep extra said "(None is missing)": the message
    names each missing library (here xarray, failing on an import of its own) and the extra."""
    real = builtins.__import__

    def fake(name, *args, **kwargs):
        if name == "xarray":
            raise ImportError("No module named 'pandas'", name="pandas")
        if name == "sklearn":
            raise ImportError("No module named 'sklearn'", name="sklearn")
        return real(name, *args, **kwargs)

    for mod in ("xarray", "sklearn"):
        monkeypatch.delitem(sys.modules, mod, raising=False)
    monkeypatch.setattr(builtins, "__import__", fake)
    with pytest.raises(SweepError) as e:
        executors.require_output_libraries(surface=True)
    msg = str(e.value)
    assert "xarray: No module named 'pandas'" in msg and "scikit-learn missing" in msg
    assert "None" not in msg and "\n" not in msg
    assert "pip install xarray netCDF4 scikit-learn" in msg  # dependencies since issue 45


def test_x02_the_cli_refuses_a_band_sweep_without_the_extra(tmp_path, monkeypatch, capsys):
    """The command line, with scikit-learn hidden: exit 2, one line, nothing written."""
    from vifpk.harness.cli.app import main

    monkeypatch.setitem(sys.modules, "sklearn", None)
    out = tmp_path / "out"
    code = main(["sweep", str(ROOT / "scenes" / "sweeps" / "r-mu-adaptive.toml"),
                 "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "scikit-learn" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_a_sweep_varies_wall_keys_and_parametric_noise(tmp_path):
    """Issue 37: "system.upper_wall.r" and "parametric.stiffness" are sweep keys; a wall table's
    unknown sub-key is refused in one line naming the allowed ones."""
    sweep = load_sweep(ROOT / "scenes" / "sweeps" / "bilateral-r-Dk.toml")
    assert [name for name, _ in sweep.vary] == ["system.upper_wall.r", "parametric.stiffness"]
    bad = tmp_path / "bad.toml"
    bad.write_text('scene = "systems/bilateral-duffing"\nworkflow = "check"\n[vary]\n'
                   '"system.upper_wall.rr" = [0.9, 0.95]\n')
    with pytest.raises(SweepError, match=r"unknown key; did you mean "
                                         r"'system.upper_wall.r'\?"):  # issue 45
        load_sweep(bad)
