"""The physics layer (vifpk/physics) and the Monte Carlo's one physics record (issue 37).

Fast tests, no simulation: no solver decides by a noise kind's name or by ``alpha1 is None``;
a kind without Monte Carlo pieces is refused in one line naming kind and solver; the record's
class is the noise kind's, and its coefficients are the kind's closed forms.
"""

from __future__ import annotations

import math
import re
from types import SimpleNamespace

import pytest

from tests.conftest import ROOT
from vifpk.core.protocols import AveragingNoise, NoiseKindSpec, Param

# the spellings of a kind test: ``kind ==`` / ``kind !=`` / ``kind in``, ``alpha1 is (not) None``
KIND_TEST = re.compile(r"\bkind\s*(==|!=|in\b)|alpha1\"?\]?\s+is\s+(not\s+)?None")


@pytest.mark.parametrize("package", ["montecarlo"])
def test_no_solver_tests_a_noise_kind_by_name(package):
    hits = []
    for path in sorted((ROOT / package).rglob("*.py")):
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#", 1)[0]
            if KIND_TEST.search(code):
                hits.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()}")
    assert not hits, hits


def test_the_grep_catches_the_old_spellings():
    for bad in ('"alpha1": float(noise.alpha1) if noise.kind == "ou" else None',
                'if alpha1 is None:', 'if phys["alpha1"] is not None:'):
        assert KIND_TEST.search(bad), bad


#: a kind with averaging pieces only (tests register it as another distribution would)
HARMONIC = NoiseKindSpec(name="harmonic", summary="averaging pieces only",
                         params=(Param(name="D", default=0.01, low=0.0, doc="intensity"),),
                         averaging=AveragingNoise(spectral_density=lambda w, D: D + 0 * w))


def test_a_kind_without_monte_carlo_pieces_is_refused_in_one_line(register_physics):
    import importlib

    import vifpk.physics.noise as N
    from vifpk.core.result import BadInput

    plan = importlib.import_module("vifpk.montecarlo.plan")
    register_physics("vifpk.noise_kinds", "harmonic", "tests.test_physics_record:HARMONIC")
    system = SimpleNamespace(omega0=1.0, alpha=0.6, c1=0.025, c2=0.05, mu=0.0, r=0.9, f=1.0)
    with pytest.raises(N.NoPiece) as e:
        plan.physics(system, SimpleNamespace(kind="harmonic", values={"D": 0.01}))
    msg = str(e.value)
    assert isinstance(e.value, BadInput)
    assert msg == ("noise kind 'harmonic' (from someone) has no montecarlo pieces: the "
                   "montecarlo solver cannot take it")


def test_the_record_is_the_kinds_and_holds_its_closed_forms():
    from vifpk.montecarlo.pieces import record, record_class
    from vifpk.montecarlo.plan import physics

    from vifpk.core.scene import load_scene

    sc = load_scene("paper-base")
    h = 0.01
    rec = record(physics(sc.system, sc.noise), h)
    assert type(rec) is record_class("ou", "newton", None)
    a1, D = sc.noise.alpha1, sc.noise.D
    assert rec.ou_a == pytest.approx(math.exp(-a1 * h), rel=1e-15)
    # the OU update keeps the stationary variance D / alpha1: a^2 D/alpha1 + s^2 = D/alpha1
    assert rec.ou_a ** 2 * D / a1 + rec.ou_s ** 2 == pytest.approx(D / a1, rel=1e-14)
    assert rec.xi_sd == pytest.approx(math.sqrt(D / a1)) and rec.bridge is None
    white = SimpleNamespace(kind="white", values={"D": 0.02})
    rec = record(physics(sc.system, white), h)
    assert type(rec) is record_class("white", "newton", None)
    # the kick's variance is 2 D f^2 h (E[W W] = 2 D delta)
    assert rec.kick ** 2 == pytest.approx(2 * 0.02 * sc.system.f ** 2 * h, rel=1e-14)
    assert rec.bridge == pytest.approx(2 * 0.02 * sc.system.f ** 2) and rec.xi_sd == 0.0


def test_a_cached_kernel_of_a_kind_this_process_lacks_does_not_break_it():
    """numba's cache index of a kernel pickles the record classes it was compiled for in any
    process: one of a plugin kind since uninstalled must load (as a stand-in, never used)."""
    import pickle

    from vifpk.montecarlo import pieces

    cls = pickle.loads(pickle.dumps(pieces.record_class("ou", "newton", None)))
    assert cls is pieces.record_class("ou", "newton", None)
    data = pickle.dumps(cls, protocol=0).replace(b"Record_ou_newton_None",
                                                  b"Record_gone_newton_None")
    stand_in = pickle.loads(data)
    assert stand_in.__name__ == "Record_gone_newton_None" and stand_in not in pieces._PIECES
