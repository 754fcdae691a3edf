"""The wheel ships what it needs: build it, install it into a fresh virtual environment, and
run the shipped scenes from an empty directory (issue 12.3).

The venv sees the site-packages of the interpreter running the tests (numpy, numba, py-pde,
... are not reinstalled): a ``.pth`` file lists them, because ``system_site_packages`` would
show the base interpreter's instead, which inside a virtualenv lacks them. vifpk itself must
come from the wheel: the test checks where ``harness`` is imported from and runs with no
PYTHONPATH, from a directory with no scenes/ in it. The venv has no pip of its own: the
running interpreter's pip installs into it (``pip --python``, pip >= 22.3).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from tests.conftest import ROOT

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
    # no pip of its own (ensurepip cost ~6 s of CPU): the running pip installs into it
    venv.create(env_dir, system_site_packages=False, with_pip=False)
    bin_dir = env_dir / ("Scripts" if os.name == "nt" else "bin")
    py = bin_dir / "python"
    _see_running_packages(py)
    _pip_install(py, "--force-reinstall", wheel)
    empty = tmp / "empty"
    empty.mkdir()
    return {"python": py, "vifpk": bin_dir / "vifpk", "bin": bin_dir, "cwd": empty,
            "venv": env_dir, "wheel": wheel}


def running_site_dirs() -> list[str]:
    """The site-packages folders of the interpreter running the tests, in its order: those of
    its own prefix (a virtualenv's, which may live inside the repository: CI's .venv does), of
    its base when the venv includes them, the user's, and any a ``.pth`` added. Never the
    repository's source folders (they would shadow the wheel): only folders named
    site-packages or dist-packages are kept, and a folder listed in a ``.pth`` is not a site
    folder, so the editable install's own ``.pth`` and finder in there are not processed."""
    dirs = [p for p in sys.path if Path(p).name in ("site-packages", "dist-packages")]
    return [p for p in dict.fromkeys(dirs) if Path(p).is_dir()]


def _see_running_packages(py: Path) -> None:
    """Append the running interpreter's site folders to the new venv's sys.path (a .pth file
    in the venv's own site-packages, so the wheel installed there comes first)."""
    site = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                          capture_output=True, text=True, check=True).stdout.strip()
    (Path(site) / "_vifpk_test_deps.pth").write_text("\n".join(running_site_dirs()) + "\n")


def _pip_install(py: Path, *args: str | Path) -> None:
    """``pip install --no-deps ARGS`` into the venv of ``py``: the running interpreter's pip
    with ``--python`` (pip >= 22.3), so the venv needs no pip of its own."""
    subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "-q",
                    "--no-deps", *map(str, args)], check=True, timeout=600,
                   env=_env(py.parent))


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
              "import vifpk.harness as h, vifpk.core.scene as s; print(h.__file__); "
              "print(s.shipped_scenes() / 'paper-base.toml')")
    assert res.returncode == 0, res.stderr
    where, scenes = res.stdout.split()
    venv_dir = installed["venv"].resolve()
    assert Path(where).resolve().is_relative_to(venv_dir), where
    assert Path(scenes).resolve().is_relative_to(venv_dir), scenes
    assert not Path(where).resolve().is_relative_to(ROOT.resolve())


def test_the_wheel_installs_one_name_vifpk(installed):
    """Issue 27: every module is vifpk.<package>; no generic top-level name (averaging, fpk,
    montecarlo, harness) lands in site-packages, and none imports from the installed wheel."""
    import zipfile

    names = zipfile.ZipFile(installed["wheel"]).namelist()
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"vifpk"}, tops
    assert "vifpk/scenes/paper-base.toml" in names
    for name in ("averaging", "fpk", "montecarlo", "harness"):
        res = run(installed, installed["python"], "-c", f"import {name}")
        assert res.returncode != 0 and "No module named" in res.stderr, (name, res.stderr)
    res = run(installed, installed["python"], "-m", "vifpk", "models")
    assert res.returncode == 0 and "exact" in res.stdout, res.stderr


def test_the_wheel_lists_the_subcommands_in_the_editable_order(installed):
    """Issue 38: the registry read vifpk's own entries from pyproject.toml in a source
    checkout (pyproject order) and from metadata in a wheel (by name), so ``vifpk --help``
    listed the subcommands in two orders. Now both read the metadata, and the help follows
    harness/cli/app.py's ORDER: the wheel's help equals the one of the tests' install."""
    from vifpk.harness.cli.app import build_parser

    here = list(build_parser()._subparsers._group_actions[0].choices)
    res = run(installed, installed["vifpk"], "--help")
    assert res.returncode == 0, res.stderr
    line = next(x for x in res.stdout.splitlines() if x.strip().startswith("{"))
    assert line.strip().strip("{}").split(",") == here, (line, here)


def test_the_venv_sees_the_packages_of_the_interpreter_running_the_tests(installed):
    """Issue 19 bug 4: numba, py-pde, ... come from the interpreter running the tests (a
    virtualenv, as the README tells users to work), not from the base interpreter behind it."""
    import numba
    import pde

    res = run(installed, installed["python"], "-c",
              "import numba, pde; print(numba.__file__); print(pde.__file__)")
    assert res.returncode == 0, res.stderr
    assert [Path(p).resolve() for p in res.stdout.split()] == \
        [Path(numba.__file__).resolve(), Path(pde.__file__).resolve()]


def test_shipped_scenes_carry_their_provenance(installed):
    """Issue 19 bug 3: a shipped scene read from the wheel's package data is named and hashed
    in the output's provenance (it used to be ``scene: None``)."""
    import hashlib
    import json

    for name in ("paper-base", "hard/r-low"):
        out = installed["cwd"] / "prov.json"
        res = run(installed, installed["vifpk"], "solve", name, "--solver", "averaging",
                  "--json", str(out))
        assert res.returncode == 0, res.stderr
        scene = json.loads(out.read_text())["info"]["provenance"]["scene"]
        assert scene is not None, name
        assert Path(scene["path"]).resolve().is_relative_to(installed["venv"].resolve())
        body = (ROOT / "scenes" / f"{name}.toml").read_bytes()
        assert scene["sha256"] == hashlib.sha256(body).hexdigest()
        out.unlink()


def test_solve_a_shipped_scene_from_an_empty_directory(installed):
    """The summary on the terminal (hard/r-low, a shipped scene in a subfolder, is solved from
    the wheel by test_shipped_scenes_carry_their_provenance)."""
    res = run(installed, installed["vifpk"], "solve", "paper-base", "--solver", "averaging")
    assert res.returncode == 0, res.stderr
    assert "mass check" in res.stdout


# The two tests below share one `vifpk check` run (the fixture ``checked``): each cold check
# compiles the wheel's Monte Carlo kernels (~20 s of CPU), and a second process was ~10 s more
# for the same installed code. They come last in the file: the plugin is installed before the
# check, so every test above (run in file order) sees the wheel alone.


@pytest.fixture(scope="module")
def checked(installed, tmp_path_factory: pytest.TempPathFactory
            ) -> subprocess.CompletedProcess[str]:
    """docs/examples/plugin installed with pip beside the wheel, then one small cross-check of
    a shipped scene with the plugin's model and a built-in one, from the empty folder, into
    ``out``. Small: 64 paths of 50 time units, and ``montecarlo.budget`` so small that the
    check does not extend the run (harness/workflows/check.py; as tests/conftest.py
    TINY_CHECK_SET): the installed files are the subject, not the physics."""
    src = tmp_path_factory.mktemp("plugin") / "plugin"
    shutil.copytree(ROOT / "docs" / "examples" / "plugin", src)
    _pip_install(installed["python"], src)
    small = ["--paths", "64", "--time", "50", "--seed", "1", "--set", "montecarlo.budget=0.001"]
    return run(installed, installed["vifpk"], "check", "paper-base", "--model",
               "white-envelope", "--model", "exact", "--out", "out", "--quiet", *small)


def test_small_check_and_figure_from_an_empty_directory(installed, checked):
    """The installed package runs a cross-check (its Monte Carlo kernels compiled from the
    wheel's files) and renders its report's figures, from a folder holding nothing of vifpk's.
    The wheel's files are the subject, not the physics (every model, and `vifpk figures`, are
    checked on the source tree; before 2026-11-28 this test also ran `vifpk figures --figure
    2`, 20 s of CI for the same installed code). The check is the plugin test's (``checked``):
    the built-in model ``exact`` is computed by the wheel's code as it would be alone."""
    assert checked.returncode == 0, checked.stderr
    assert "\nexact model:" in checked.stdout, checked.stdout
    assert (installed["cwd"] / "out" / "report.html").is_file()
    assert list((installed["cwd"] / "out").rglob("*.png"))  # the report's figures rendered


def test_a_plugin_package_is_listed_solved_and_checked(installed, checked):
    """docs/examples/plugin installed with pip beside the wheel (``checked``): its model works
    like a built-in one, without editing vifpk (issue 19.2)."""
    res = run(installed, installed["vifpk"], "models")
    assert res.returncode == 0, res.stderr
    assert "white-envelope" in res.stdout and "vifpk-white-envelope" in res.stdout
    res = run(installed, installed["vifpk"], "solve", "paper-base", "--model", "white-envelope")
    assert res.returncode == 0, res.stderr
    assert "FPK direct solve" in res.stdout
    assert checked.returncode == 0, checked.stderr
    assert checked.stdout.startswith("white-envelope model:")
    metrics = (installed["cwd"] / "out" / "metrics.json").read_text()
    assert '"white-envelope"' in metrics
    res = run(installed, installed["python"], "-c", "import vifpk; "
              "print(vifpk.model_names())")
    assert res.returncode == 0 and "white-envelope" in res.stdout, res.stderr
