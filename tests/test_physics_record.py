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


def test_a_kind_without_monte_carlo_pieces_is_refused_in_one_line(monkeypatch):
    import importlib

    import vifpk.core.registry as reg
    import vifpk.physics.noise as N

    plan = importlib.import_module("vifpk.montecarlo.plan")

    monkeypatch.setattr(reg, "NOISE_KINDS", (*reg.NOISE_KINDS, "harmonic"))
    monkeypatch.setattr(N, "NOISE_KINDS", (*reg.NOISE_KINDS,))
    monkeypatch.setattr(plan, "NOISE_KINDS", (*reg.NOISE_KINDS,))
    system = SimpleNamespace(omega0=1.0, alpha=0.6, c1=0.025, c2=0.05, mu=0.0, r=0.9, f=1.0)
    with pytest.raises(N.NoPiece) as e:
        plan.physics(system, SimpleNamespace(kind="harmonic", D=0.01))
    msg = str(e.value)
    assert "harmonic" in msg and "montecarlo" in msg and "\n" not in msg


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
    white = SimpleNamespace(kind="white", D=0.02, alpha1=1.0)
    rec = record(physics(sc.system, white), h)
    assert type(rec) is record_class("white", "newton", None)
    # the kick's variance is 2 D f^2 h (E[W W] = 2 D delta)
    assert rec.kick ** 2 == pytest.approx(2 * 0.02 * sc.system.f ** 2 * h, rel=1e-14)
    assert rec.bridge == pytest.approx(2 * 0.02 * sc.system.f ** 2) and rec.xi_sd == 0.0
