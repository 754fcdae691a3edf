"""Property tests (hypothesis) over the valid parameter box: every density the averaged
models return is finite, non-negative, normalised and holds its mass."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from averaging import solve

from .conftest import vary

# the box: wide but with a stationary density (c2 > 0 bounds the energy)
params = st.fixed_dictionaries({
    "c1": st.floats(-0.2, 0.2),
    "c2": st.floats(0.01, 0.5),
    "alpha": st.floats(0.0, 5.0),
    "mu": st.floats(0.0, 0.1),
    "r": st.floats(0.3, 1.0),
    "D": st.floats(1e-4, 1.0),
    "alpha1": st.floats(0.1, 20.0),
    "kind": st.sampled_from(["ou", "white"]),
    "f": st.floats(0.2, 3.0),
})


def check(result) -> None:
    for key in ("A", "x1", "x2", "E"):
        d = result.data[key]
        assert np.all(np.isfinite(d["p"])) and np.min(d["p"]) >= 0.0
        assert abs(np.trapezoid(d["p"], d["x"]) - 1.0) < 1e-10
    assert result.info["diagnostics"]["tail_mass"] < 1e-8
    assert result.info["status"]["ok"]


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(params)
def test_paper_model_densities(base, p):
    check(solve(vary(base, **p), model="paper"))


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(params, st.sampled_from(["sgn", "additive"]), st.sampled_from(["exact", "transformed"]))
def test_exact_model_densities(base, p, noise, impact):
    check(solve(vary(base, **p), model="exact", noise=noise, impact=impact))
