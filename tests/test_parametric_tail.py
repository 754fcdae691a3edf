"""The large-energy tail of the averaged law under parametric noise (vifpk.core.energy; issue 37,
docs/averaging.md section 12 "The tail"), against independent truths:

- the linear oscillator's closed form of section 12, p(E) ~ (s + b E)^(-2a/b - 2), and the exact
  second-moment system's mean-square boundary det M = 0 (tests/test_parametric_growth.py);
- the averaged model's own density (averaging/, orbit averages by quadrature of the whole
  polynomial orbit, walls and lower terms included) at large amplitude: its log-slope tends to
  the closed-form exponent.
"""

from __future__ import annotations

import numpy as np
import pytest
from vifpk.harness.request import validate
from vifpk.harness.request.errors import InputError

from vifpk.core.energy import parametric_tail
from vifpk.core.scene import load_scene, scene_from_dict
from vifpk.core.system import _trim


def _linear(k: float, w: float, D_k: float, D_c: float):
    return scene_from_dict({"system": {"restoring": [w * w], "damping": [k], "mu": 0.0,
                                       "barrier": False},
                            "parametric": {"stiffness": D_k, "damping": D_c}})


@pytest.mark.parametrize("D_k", [0.05, 0.1, 0.2])
def test_the_linear_oscillator_against_its_closed_form(D_k):
    """kappa = 2 + 2a/b (a = k - D_k w^2 - 2 D_c k^2, b = D_k w^2 + 3 D_c k^2: section 12's
    a and b with k = 2 zeta w); the stationary law's bound on D_k is 2k - D_c k^2 (2a/b > -1)
    over w^2, the mean energy's is (k - 2 D_c k^2) / w^2: det M = 0 of the exact second
    moments, whose growth rate the Monte Carlo measures. Pure arithmetic (< 1 ms)."""
    k, w, D_c = 0.2, 1.3, 0.1
    tail = parametric_tail((s := _linear(k, w, D_k, D_c)).system, s.parametric)
    a, b = k - D_k * w * w - 2 * D_c * k * k, D_k * w * w + 3 * D_c * k * k
    assert abs(tail.kappa - (2 + 2 * a / b)) < 1e-12
    assert abs(tail.bounds["parametric.stiffness"] - (2 * k - D_c * k * k) / w ** 2) < 1e-12
    assert abs(tail.mean_bounds["parametric.stiffness"] - (k - 2 * D_c * k * k) / w ** 2) < 1e-12
    assert tail.mean_finite == (a > 0) and tail.normalisable == (2 * a / b > -1)
    m = np.array([[0, 2, 0], [-w * w, D_c * k * k - k, 1],
                  [2 * D_k * w ** 4, -2 * w * w, 4 * D_c * k * k - 2 * k]])
    assert (np.linalg.det(m) < 0) == tail.mean_finite  # det M = 4 w^2 (D_k w^2 + 2 D_c k^2 - k)


def test_the_refusal_names_the_key_and_its_bound():
    """paper-base (c2 x^2 x' against the stiffness noise, both ~ A^6): above D_k = 1/12 no
    stationary law; refused in one line before any work. 1e300 is refused by the magnitude
    rule (docs/edges.md H059, H060)."""
    scene = load_scene("paper-base")
    validate.stationary_density(scene.with_values({"parametric.stiffness": 0.08}))
    with pytest.raises(InputError, match=r"parametric.stiffness = 0.1 is out of range for this "
                                         r"scene; allowed: 0 <= parametric.stiffness < 0.08333"):
        validate.stationary_density(scene.with_values({"parametric.stiffness": 0.1}))
    with pytest.raises(InputError, match=r"parametric.damping = 1e\+300 is out of range"):
        validate.scene_magnitudes(scene.with_values({"parametric.damping": 1e300}))


@pytest.mark.slow
@pytest.mark.parametrize("name, values", [
    ("paper-base", {"parametric.stiffness": 0.01, "system.barrier": False}),
    ("paper-base", {"parametric.damping": 0.01}),
    ("systems/offset-parametric", {}),
    (None, {"parametric.stiffness": 0.3}),
])
def test_the_averaged_models_tail(name, values):
    """The exact model's log p_A between A = 2e4 and 4e4 against (q - 1) - q kappa (p_A = p_E
    dE/dA, E ~ A^q / q, q = 4 here). The lower terms (impacts ~ A^5 against A^6, the linear
    spring and damping) fall off as 1/A: measured -22.9999998 (-23, a tie with c2),
    -1.66669 (-5/3: the damping noise outgrows c2 x^2 x', kappa = 7/6 at every D_c: a law
    exists, E[H] is infinite) and +1.99289 (+2: offset-parametric's stiffness noise ~ A^6
    outgrows its impacts ~ A^5 beyond E ~ 1.7e4; kappa = 1/4, no stationary law strictly);
    0.71 off at A = 200-400; and a linear spring with a Newton wall at -0.3 (r = 0.8, d0 =
    0.01), where the impacts, the damping and the stiffness noise are all ~ E: -0.66123 against
    -0.66122 (1 - 2 kappa, q = 2; kappa = 0.831 at D_k = 0.3, above its bound 0.249: no law).
    Each case's bound is its own 1/A estimate (REVIEW1 finding 10): the same log-slope on
    [1e4, 2e4] differs from it by the 1/A term itself (d(A) = c/A halves from one window to
    the next, so d2 = d1 - d2 = |s1 - s2|); bound 2 |s1 - s2| (a factor 2 for the 1/A^2
    terms) + 1e-6 (the quadrature's floor). About 1-2 s each."""
    from vifpk.averaging.solve import build_model
    from vifpk.averaging.stationary import _cumulative

    if name is None:
        scene = scene_from_dict({"system": {"restoring": [1.0], "damping": [0.01], "mu": 0.0,
                                            "lower_wall": {"at": -0.3, "r": 0.8}},
                                 "noise": {"kind": "white", "D": 0.01}})
    else:
        scene = load_scene(name)
    scene = scene.with_values(values)
    q = 2 * len(_trim(tuple(scene.system.restoring_law)))  # E ~ A^q / q: the top spring term
    tail = parametric_tail(scene.system, scene.parametric)
    edges = np.linspace(0.0, 4e4, 4001)
    psi, log_pre, _ = _cumulative(build_model(scene, "exact"), edges)
    lp = log_pre + psi
    def slope(a, b):
        i, j = np.searchsorted(edges, [a, b])
        return (lp[j] - lp[i]) / np.log(edges[j] / edges[i])

    s1, s2 = slope(1e4, 2e4), slope(2e4, 4e4)
    bound = 2 * abs(s1 - s2) + 1e-6
    assert abs(s2 - ((q - 1) - q * tail.kappa)) < bound, (s1, s2, bound, tail)


def test_the_monte_carlos_growth_cause_reads_the_parametric_noise():
    """The cause a blow-up's line leads with (montecarlo.failures.growth): nothing below the
    mean-square bound (k - 2 D_c k^2) / w^2 = 0.1136 of the linear oscillator of the first
    test, past it the infinite mean energy, above the law's bound 0.2343 no stationary law.
    Without the [parametric] section it said nothing in all three."""
    from vifpk.montecarlo.failures import growth

    causes = {}
    for D_k in (0.1, 0.2, 0.3):
        s = _linear(0.2, 1.3, D_k, 0.1)
        causes[D_k] = growth(s.system, s.parametric)
        assert growth(s.system) == ""
    assert causes[0.1] == ""
    assert "mean energy is infinite" in causes[0.2]
    assert "grows without bound" in causes[0.3] and "no stationary law" in causes[0.3]


def test_the_heavy_tail_words_are_chosen_by_the_exception_type():
    """REVIEW1 finding 8: harness/door/solvers._heavy_tail rewords the averaging's "density
    does not decay" by its type (averaging.DensityDoesNotDecay), not by matching its text:
    any other NoStationaryDensity, whatever its words, passes through unchanged."""
    from vifpk.harness.door.solvers import _heavy_tail

    from vifpk import averaging

    scene = _linear(0.2, 1.3, 0.05, 0.1)  # a law exists, with a power-law tail
    with pytest.raises(averaging.NoStationaryDensity, match="decays too slowly"):
        with _heavy_tail(scene):
            raise averaging.DensityDoesNotDecay("grid exhausted")
    with pytest.raises(averaging.NoStationaryDensity, match="^other: does not decay$"):
        with _heavy_tail(scene):
            raise averaging.NoStationaryDensity("other: does not decay")
