"""The averaged models' coefficients computed once per run (issue 44, averaging/memo.py): inside
the scope a check enters (harness/door/coefficients.py) the closed form, the FPK and the
averaged SDE's tables of the exact and corrected models are bit for bit what they are without
it, and sigma_E^2 is computed once per grid, for the exact and the corrected model together."""

from __future__ import annotations

import numpy as np
import pytest
from vifpk.averaging import memo
from vifpk.averaging.exact import ExactModel
from vifpk.harness.door.coefficients import shared_coefficients
from vifpk.harness.door.solvers import closed_form, model_solution
from vifpk.montecarlo.averaged_sde import relaxation_time, sde_tables

import vifpk
from vifpk.core.registry import build_model

MODELS = ("exact", "corrected")


def _solvers(scene) -> dict[str, np.ndarray]:
    """What the check's three solvers take from the models, through the door: the closed
    forms' densities, the FPK's, and the averaged SDE's relaxation time and tables."""
    out = {}
    for m in MODELS:
        for name, res in (("closed", closed_form(scene, model=m, tail_mass=False)),
                          ("fpk", model_solution(scene, model=m, solver="fpk", cells=100))):
            for o in ("A", "x1", "x2"):
                out[f"{name}:{m}:{o}"] = np.asarray(res.data[o]["p"])
        out.update(_pieces(scene, m, tables=True))
    return out


def _pieces(scene, m: str, *, tables: bool = False) -> dict[str, np.ndarray]:
    """The model's own pieces the solvers call: the closed form's log_stationary_parts and
    period, drift and diffusion (the FPK's), and with ``tables`` the averaged SDE's relaxation
    time and coefficient tables."""
    model = build_model(scene, m)
    A = np.linspace(0.0, 2.0, 257)[1:]
    out = {f"parts:{m}:{k}": v for k, v in enumerate(model.log_stationary_parts(A))}
    out.update({f"T:{m}": model.period(A), f"drift:{m}": model.drift(A),
                f"diffusion:{m}": model.diffusion(A)})
    if tables:
        out[f"tau:{m}"] = np.array([relaxation_time(model.drift, model.diffusion, 2.0,
                                                    cells=100)])
        for k, tab in enumerate(sde_tables(model.drift, model.diffusion, 2.0, 401)):
            out[f"sde:{m}:{k}"] = tab
    return out


def _same_bits(compute) -> None:
    plain = compute()
    with shared_coefficients():
        assert memo.active()
        shared = compute()
        again = compute()  # every value from the memo now
    assert not memo.active()
    assert plain.keys() == shared.keys()
    for k in plain:
        assert np.array_equal(plain[k], shared[k]), k
        assert np.array_equal(plain[k], again[k]), k


def test_the_shared_coefficients_are_the_same_bits():
    scene = vifpk.scene("paper-base")
    _same_bits(lambda: {k: v for m in MODELS for k, v in _pieces(scene, m).items()})


@pytest.mark.slow
def test_the_solvers_get_the_same_bits_with_shared_coefficients():
    scene = vifpk.scene("paper-base", **{"averaging.points": 201,
                                         "averaging.phase_points": 65})
    _same_bits(lambda: _solvers(scene))


def test_sigma2_is_computed_once_per_grid_for_exact_and_corrected(monkeypatch):
    calls = []
    real = ExactModel.harmonics_of_Y

    def counted(self, A, T):
        calls.append(np.size(A))
        return real(self, A, T)

    monkeypatch.setattr(ExactModel, "harmonics_of_Y", counted)
    scene = vifpk.scene("paper-base")
    A = np.linspace(0.01, 2.0, 300)
    exact, corrected = build_model(scene, "exact"), build_model(scene, "corrected")
    exact.drift(A)
    alone = len(calls)  # the drift's grid and its four stencil grids
    assert alone == 5
    exact.diffusion(A)
    corrected.drift(A)
    corrected.diffusion(A)
    assert len(calls) == 2 * (alone + 1)  # without the memo: each model, each call
    calls.clear()
    with shared_coefficients():
        exact.drift(A)
        exact.diffusion(A)
        corrected.drift(A)
        corrected.diffusion(A)
    assert len(calls) == alone


def test_memo_arrays_are_read_only_and_nothing_is_kept_outside():
    m = build_model(vifpk.scene("paper-base"), "exact")
    A = np.linspace(0.1, 1.0, 7)
    with shared_coefficients():
        s2 = m.sigma2_external(A)
        with pytest.raises(ValueError):
            s2[0] = 0.0
        o = m.orbit(A)
        o["T"] = None  # a caller's own dict: the memo's entry keeps its arrays
        assert m.orbit(A)["T"] is not None
    s2[...]  # still readable
    assert m.sigma2_external(A).flags.writeable  # outside: computed, not recalled
