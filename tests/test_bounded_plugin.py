"""A noise kind is what it declares, not what it is called (issue 43 item 5): vifpk's own
bounded-noise object, registered by another distribution under a second name
(``bounded-copy``, in the ``vifpk.noise_kinds`` entry-point group), gives bit-identical
results to the built-in in the averaged models and the Monte Carlo.

The second distribution is made visible without pip as in tests/test_registry.py: a
``*.dist-info`` folder (METADATA + entry_points.txt) on sys.path is what an installed
distribution is to importlib.metadata.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from vifpk.core import registry
from vifpk.core.scene import scene_from_dict

#: not an identifier: the Monte Carlo's record class names the kind through pieces._ident
COPY = "bounded-copy"
NOISE = {"amplitude": 0.3, "frequency": 1.2, "sigma": 1.0}


@pytest.fixture
def second_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """vifpk's bounded kind registered again, as ``bounded-copy``, by a distribution
    ``bounded-copy-plugin`` whose module only renames the built-in object."""
    info = tmp_path / "bounded_copy_plugin-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: bounded-copy-plugin\n"
                                   "Version: 0.1\n")
    (info / "entry_points.txt").write_text(
        f"[{registry.NOISE_GROUP}]\n{COPY} = bounded_copy_plugin:KIND\n")
    (tmp_path / "bounded_copy_plugin.py").write_text(
        "import dataclasses\n"
        "from vifpk.physics.noise.bounded import KIND as BUILTIN\n"
        f"KIND = dataclasses.replace(BUILTIN, name={COPY!r})\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    registry.refresh()
    yield
    monkeypatch.undo()
    registry.refresh()


def _scene(kind: str, *, walls: bool = False):
    """A Duffing oscillator under bounded noise, with the paper's wall (r = 0.9) or two walls
    at +-0.6 (r = 0.97)."""
    sys_ = {"restoring": [1.0, 0.5], "damping": [0.05], "mu": 0.0, "f": 1.0}
    if walls:
        sys_.update(lower_wall={"at": -0.6, "r": 0.97}, upper_wall={"at": 0.6, "r": 0.97})
    else:
        sys_["r"] = 0.9
    return scene_from_dict({"system": sys_, "noise": {"kind": kind, **NOISE}})


def test_the_copy_is_registered_from_its_distribution(second_name) -> None:
    assert COPY in registry.noise_kind_names()
    assert registry.physics_entry("noise kind", COPY).distribution == "bounded-copy-plugin"


def test_the_averaged_models_give_the_same_bits(second_name) -> None:
    """exact and compounded: drift, diffusion and p(A) bit for bit, at the paper's wall and
    between two walls."""
    from vifpk.averaging.corrected import CompoundedModel
    from vifpk.averaging.exact import ExactModel
    from vifpk.averaging.stationary import amplitude_density

    for walls in (False, True):
        for cls in (ExactModel, CompoundedModel):
            a = cls.from_scene(_scene("bounded", walls=walls))
            b = cls.from_scene(_scene(COPY, walls=walls))
            A = np.linspace(0.01, 2.0, 41)
            for name in ("drift", "diffusion"):
                assert np.array_equal(getattr(a, name)(A), getattr(b, name)(A))
            pa, pb = amplitude_density(a, points=201), amplitude_density(b, points=201)
            assert np.array_equal(pa.p, pb.p) and np.array_equal(pa.A, pb.A)


@pytest.mark.slow
@pytest.mark.xdist_group("bounded-linear")
def test_the_monte_carlo_gives_the_same_bits(second_name) -> None:
    """A short stationary run (the same seed): every moment and histogram bit for bit."""
    from vifpk.montecarlo.simulate import Settings, simulate

    edges = {"edges_A": np.linspace(0, 3, 16), "edges_x": np.linspace(-3, 3, 16),
             "edges_v": np.linspace(-3, 3, 16)}
    st = Settings(paths=64, blocks=4, dt=0.05, time=40.0, burn_in=10.0, seed=5, bins=15,
                  threads=1, floor=0.0, budget=0.0, sample_every=0.4, progress=False,
                  certificate=False, observables=("moments", "energy"), edges=edges)
    out = []
    for kind in ("bounded", COPY):
        sc = _scene(kind)
        out.append(simulate(sc.system, sc.noise, st))
    a, b = out
    assert a.data.keys() == b.data.keys()
    for key, arrays in a.data.items():
        for name, value in arrays.items():
            assert np.array_equal(np.asarray(value), np.asarray(b.data[key][name])), (key, name)
    assert a.info["moments"] == b.info["moments"]
