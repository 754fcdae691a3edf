"""harness/sweeps/band.py: the band refiner's arithmetic against exact Gaussian-process
identities (issue 29, item 3), on the synthetic map of tests/test_surface.py (known truth,
known noise; no simulation).

- the rank-one update of the posterior equals a refit with the observation added (R&W 2006
  eq. 2.24: an exact identity);
- an extension (a point's noise variance from A to B) equals a second observation at the point
  with variance A B / (A - B) (precisions add: exact);
- the expected band area after an observation (the preposterior formula) equals the mean, over
  simulated observations, of the band area of the refitted posterior (Monte Carlo, its own
  standard error as the tolerance);
- the batch is a pure function of the surface, keeps to the budget, and takes more samples at
  a noisy point on the boundary when a new point costs much more.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

pytest.importorskip("sklearn", reason="scikit-learn: the sweep and test extras")

from sklearn.gaussian_process import GaussianProcessRegressor  # noqa: E402
from vifpk.harness.sweeps.band import (  # noqa: E402
    EXTEND_VARIANCE,
    Candidate,
    Z,
    _cov,
    choose,
    eval_grid,
    expected_area,
    lattice,
)
from vifpk.harness.sweeps.surface import BAND, fit_surface  # noqa: E402

from tests.test_surface import AXES, LATTICE, T, _observe  # noqa: E402


@pytest.fixture(scope="module")
def surface():
    L, s = _observe(0.3, 5)
    return fit_surface(LATTICE, L, s, tolerance=T, axes=AXES)


def _refit(sf, extra_x, extra_noise, extra_y=None, alpha=None):
    """The surface's regressor refitted (same kernel, no optimiser) with extra observations."""
    m = sf._model
    X = np.vstack([m.X_train_, extra_x])
    y = np.concatenate([m.y_train_, extra_y if extra_y is not None else np.zeros(len(extra_x))])
    a = np.concatenate([alpha if alpha is not None else m.alpha, extra_noise])
    g = GaussianProcessRegressor(kernel=m.kernel_, alpha=a, optimizer=None, normalize_y=False)
    return g.fit(X, y)


def test_z_is_the_band():
    from scipy.special import ndtri

    assert BAND[0] == pytest.approx(1 - BAND[1])
    assert Z == pytest.approx(-ndtri(BAND[0]), abs=1e-12)


def test_rank_one_update_is_a_refit(surface):
    """sd'(x)^2 = sd(x)^2 - cov(x, c)^2 / (sd(c)^2 + n): the refit's posterior variance (exact
    identity, to rounding)."""
    e = eval_grid(2)[::7]
    c = np.array([[0.41, 0.37]])
    n = 0.05
    cov_ec = _cov(surface._model, e, c)[:, 0]
    var_c = _cov(surface._model, c, c)[0, 0]
    update = np.diag(_cov(surface._model, e, e)) - cov_ec**2 / (var_c + n)
    _, sd = _refit(surface, c, [n]).predict(e, return_std=True)
    np.testing.assert_allclose(update, sd**2, rtol=1e-6, atol=1e-10)


def test_extension_is_a_second_observation(surface):
    """A point's noise variance A -> B (the fitted alpha of point i) gives the posterior of a
    second observation at the point with variance A B / (A - B) (precisions add)."""
    m = surface._model
    i = 24
    big = float(m.alpha[i])
    small = EXTEND_VARIANCE * big
    alpha = m.alpha.copy()
    alpha[i] = small
    e = eval_grid(2)[::5]
    _, sd_b = _refit(surface, np.empty((0, 2)), [], alpha=alpha).predict(e, return_std=True)
    _, sd_2 = _refit(surface, m.X_train_[i:i + 1], [big * small / (big - small)],
                     extra_y=m.y_train_[i:i + 1]).predict(e, return_std=True)
    np.testing.assert_allclose(sd_b, sd_2, rtol=1e-6, atol=1e-10)


def test_expected_band_area_is_the_mean_over_simulated_observations(surface):
    """The preposterior formula against simulation: draw the observation at c from its
    predictive law, refit, measure the band's area; the mean of 120 draws agrees with
    expected_area within 4 standard errors of that mean."""
    m, mean = surface._model, surface._mean
    e = eval_grid(2)[::3]
    c = np.array([[0.45, 0.5]])
    n = 0.02
    mu_e, sd_e = m.predict(e, return_std=True)
    mu_c, sd_c = m.predict(c, return_std=True)
    a = math.log(T) - (mu_e + mean)
    cov_ec = _cov(m, e, c)[:, 0]
    after = sd_e**2 - cov_ec**2 / (sd_c[0] ** 2 + n)
    formula = float(expected_area(a, sd_e**2, after[:, None])[0])
    rng = np.random.default_rng(3)
    areas = []
    for y in mu_c[0] + math.sqrt(sd_c[0] ** 2 + n) * rng.standard_normal(120):
        g = _refit(surface, c, [n], extra_y=[y])
        mu2, sd2 = g.predict(e, return_std=True)
        areas.append(np.mean(np.abs(math.log(T) - (mu2 + mean)) < Z * sd2))
    areas = np.array(areas)
    se = areas.std(ddof=1) / math.sqrt(areas.size)
    assert abs(areas.mean() - formula) < 4 * se + 1e-3, (areas.mean(), formula, se)
    now = float(np.mean(np.abs(a) < Z * sd_e))
    assert formula < now  # an observation near the boundary shrinks the band


def test_choice_is_pure_and_keeps_to_the_budget(surface):
    cands = [Candidate(unit=u, cost=10.0) for u in lattice(2, 12)]
    one = choose(surface, cands, 5, new_noise_sd=0.3 * T)
    two = choose(surface, cands, 5, new_noise_sd=0.3 * T)
    assert one == two and len(one) == 5 and len({c.unit for c in one}) == 5
    assert all(c.kind == "new" and c.gain > 0 for c in one)
    capped = choose(surface, cands, 5, new_noise_sd=0.3 * T, budget=25.0)
    assert len(capped) == 2  # 10 + 10 <= 25 < 30
    assert choose(surface, [], 5, new_noise_sd=0.3 * T) == []


def test_more_samples_where_a_noisy_point_sits_on_the_boundary():
    """A point on the true boundary with a large error bar, new points 20 x dearer than its
    extension: the batch extends it first."""
    L, s = _observe(0.1, 2)
    x = LATTICE.copy()
    on = np.array([[0.45, 0.30]])  # near the boundary u = b(v)
    x = np.vstack([x, on])
    L = np.append(L, T)
    s = np.append(s, 0.8 * T)
    sf = fit_surface(x, L, s, tolerance=T, axes=AXES)
    tau = float(sf.log_noise_sd[-1])
    cands = [Candidate(unit=u, cost=20.0) for u in lattice(2, 12)]
    cands.append(Candidate(unit=(0.45, 0.30), key="noisy", noise_sd=tau, cost=1.0))
    picked = choose(sf, cands, 3, new_noise_sd=0.1 * T)
    assert picked[0].key == "noisy" and picked[0].kind == "extend"
    assert sum(c.key == "noisy" for c in picked) == 1  # once a batch
