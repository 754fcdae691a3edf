"""The wheel ships what it needs: build it, install it into a fresh virtual environment, and
run the shipped scenes from an empty directory (issue 12.3).

The venv sees the system's site-packages (numpy, numba, py-pde, ... are not reinstalled), but
vifpk itself must come from the wheel: the test checks where ``harness`` is imported from and
runs with no PYTHONPATH, from a directory with no scenes/ in it.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from .conftest import ROOT

# one wheel and venv for the module: under xdist the three tests stay on one worker
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("wheel")]


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    tmp = tmp_path_factory.mktemp("wheel")
    dist = tmp / "dist"
    # build from a copy of the sources: setuptools writes build/ and *.egg-info in-tree
    src = tmp / "src"
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns(
        ".git", "build", "dist", "*.egg-info", "out", "__pycache__", ".*cache*", ".venv*"))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(dist),
                    str(src)], check=True, timeout=600)
    (wheel,) = dist.glob("vifpk-*.whl")
    env_dir = tmp / "venv"
    venv.create(env_dir, system_site_packages=True, with_pip=True)
    bin_dir = env_dir / ("Scripts" if os.name == "nt" else "bin")
    py = bin_dir / "python"
    subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", "--force-reinstall",
                    str(wheel)], check=True, timeout=600, env=_env(bin_dir))
    empty = tmp / "empty"
    empty.mkdir()
    return {"python": py, "vifpk": bin_dir / "vifpk", "bin": bin_dir, "cwd": empty,
            "venv": env_dir}


def _env(bin_dir: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = f"{bin_dir}{os.pathsep}{env.get('PATH', '')}"
    return env


def run(inst: dict[str, Path], *args: str, timeout: float = 600
        ) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(a) for a in args], cwd=inst["cwd"], env=_env(inst["bin"]),
                          capture_output=True, text=True, timeout=timeout)


def test_vifpk_comes_from_the_wheel(installed):
    res = run(installed, installed["python"], "-c",
              "import harness, vifpk.core.scene as s; print(harness.__file__); "
              "print(s.shipped_scenes() / 'paper-base.toml')")
    assert res.returncode == 0, res.stderr
    where, scenes = res.stdout.split()
    venv_dir = installed["venv"].resolve()
    assert Path(where).resolve().is_relative_to(venv_dir), where
    assert Path(scenes).resolve().is_relative_to(venv_dir), scenes
    assert not Path(where).resolve().is_relative_to(ROOT.resolve())


def test_solve_a_shipped_scene_from_an_empty_directory(installed):
    res = run(installed, installed["vifpk"], "solve", "paper-base", "--solver", "averaging")
    assert res.returncode == 0, res.stderr
    assert "mass check" in res.stdout
    res = run(installed, installed["vifpk"], "solve", "hard/r-low", "--solver", "averaging")
    assert res.returncode == 0, res.stderr


def test_small_check_and_figure_from_an_empty_directory(installed):
    small = ["--paths", "32", "--time", "50", "--seed", "1"]
    res = run(installed, installed["vifpk"], "check", "paper-base", "--out", "out", "--quiet",
              *small)
    assert res.returncode == 0, res.stderr
    assert (installed["cwd"] / "out" / "report.html").is_file()
    res = run(installed, installed["vifpk"], "figures", "--figure", "2", "--out", "figs",
              "--quiet", *small)
    assert res.returncode == 0, res.stderr
    assert list((installed["cwd"] / "figs").glob("paper-fig2*.png"))
