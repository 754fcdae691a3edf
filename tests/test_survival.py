"""harness.workflows.survival against exact identities and known laws; coverage measured over seeds.
Binomial tolerances: over S seeds a rate p is measured within 3 sqrt(p (1-p) / S)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from vifpk.harness.workflows.survival import (
    bridge_sup_cdf,
    fpt_density_l1,
    hall_wellner_c,
    kaplan_meier,
    relative_mfpt_error,
    restricted_mean,
    restricted_model_mean,
    sup_distance,
)

SEEDS = 200


def test_kaplan_meier_without_censoring_is_the_empirical_survival_function():
    rng = np.random.default_rng(3)
    t = np.round(rng.exponential(1.0, 300), 1)  # rounded: many ties
    km = kaplan_meier(t, np.zeros(t.size, bool))
    for x in np.concatenate([km["t"], km["t"] + 0.05]):
        assert km["R"][np.searchsorted(km["t"], x, side="right") - 1] == pytest.approx(
            np.mean(t > x), abs=1e-14)
    # Greenwood without censoring is the binomial variance R (1 - R) / n
    assert np.allclose(km["se"] ** 2, km["R"] * (1 - km["R"]) / t.size, atol=1e-15)


def test_hall_wellner_critical_value_limits():
    # a = 1: Kolmogorov's 95% point 1.3581 (the KS band, the band without censoring)
    assert hall_wellner_c(1.0) == pytest.approx(1.35810, abs=1e-4)
    # small a: sup over [0, a] of a bridge ~ sqrt(a) sup of Brownian motion on [0, 1], whose
    # two-sided 95% point is 2.2414 (Feller's series); the bridge's pull-back makes it smaller
    assert hall_wellner_c(1e-4) / math.sqrt(1e-4) == pytest.approx(2.2414, rel=2e-3)
    c = np.linspace(0.3, 2.0, 20)
    p = [bridge_sup_cdf(x, 0.5) for x in c]
    assert np.all(np.diff(p) > 0) and 0 < p[0] < p[-1] < 1


def _exp_sample(rng, n, rate, cens_rate):
    T = rng.exponential(1 / rate, n)
    C = rng.exponential(1 / cens_rate, n) if cens_rate > 0 else np.full(n, np.inf)
    return np.minimum(T, C), C < T


def _covered(km, R_true):
    t, lo, up = km["t"], km["lower"], km["upper"]
    right = np.append(t[1:], np.inf)
    return bool(np.all(up >= R_true(t)) and np.all(lo <= R_true(right)))


@pytest.mark.parametrize("law", ["exponential", "weibull"])
def test_hall_wellner_band_covers_at_the_nominal_rate(law):
    """200 seeds, n = 200, random censoring by an independent exponential (30% censored for
    the exponential law, 33% for the Weibull). Measured: exponential 0.945, Weibull (shape 2)
    0.930 (with 400 seeds: 0.953, 0.938; at n = 1000: 0.940, 0.955); the tolerance is 3
    binomial standard deviations (0.046) around 0.95."""
    hits = 0
    for seed in range(SEEDS):
        rng = np.random.default_rng(seed)
        if law == "exponential":
            t, cen = _exp_sample(rng, 200, 1.0, 0.43)

            def R_true(x):
                return np.exp(-x)
        else:
            T = rng.weibull(2.0, 200)
            C = rng.exponential(2.5, 200)
            t, cen = np.minimum(T, C), C < T

            def R_true(x):
                return np.exp(-np.asarray(x) ** 2)
        hits += _covered(kaplan_meier(t, cen), R_true)
    rate = hits / SEEDS
    assert abs(rate - 0.95) <= 3 * math.sqrt(0.95 * 0.05 / SEEDS), rate


def test_restricted_mean_matches_the_exponential_closed_form_and_its_stderr():
    """mu(tau) = (1 - e^{-lambda tau}) / lambda. Over 200 seeds: the mean estimate within
    3 standard errors of the mean, and the z-scores' spread within 4 standard deviations of 1
    (sd of a sample sd over 200 draws ~ 0.05). Measured: mean z -0.08, sd of z 0.96."""
    lam, tau = 0.5, 3.0
    exact = (1 - math.exp(-lam * tau)) / lam
    vals, z = [], []
    for seed in range(SEEDS):
        rng = np.random.default_rng(1000 + seed)
        t, cen = _exp_sample(rng, 300, lam, 0.2)
        r = restricted_mean(t, cen, tau)
        assert r["restricted"]
        vals.append(r["value"])
        z.append((r["value"] - exact) / r["stderr"])
    vals, z = np.array(vals), np.array(z)
    assert abs(vals.mean() - exact) <= 3 * vals.std(ddof=1) / math.sqrt(SEEDS)
    assert abs(z.std(ddof=1) - 1) <= 4 * 0.05, z.std(ddof=1)


def test_uncensored_mean_is_the_sample_mean_and_not_restricted():
    rng = np.random.default_rng(7)
    t = rng.exponential(2.0, 500)
    r = restricted_mean(t, np.zeros(t.size, bool))
    assert r["value"] == pytest.approx(t.mean(), rel=1e-12) and not r["restricted"]
    # the variance formula is then the plug-in (n - 1)/n s^2 / n
    assert r["stderr"] == pytest.approx(t.std() / math.sqrt(t.size), rel=1e-9)


def test_model_comparisons_true_model_within_floor_wrong_model_beyond():
    rng = np.random.default_rng(11)
    horizon = 2.0
    T = rng.exponential(1.0, 4000)
    t, cen = np.minimum(T, horizon), T > horizon  # censored at the horizon (passage MC style)
    km = kaplan_meier(t, cen)
    tm = np.linspace(0, 5, 5001)
    good = sup_distance(tm, np.exp(-tm), km)
    bad = sup_distance(tm, np.exp(-1.2 * tm), km)
    assert good["inside_band"] and good["value"] < good["floor"]
    assert not bad["inside_band"] and bad["value"] > 2 * bad["floor"]
    mc = restricted_mean(t, cen, horizon)
    assert mc["restricted"]
    e = relative_mfpt_error(restricted_model_mean(tm, np.exp(-tm), horizon), mc)
    assert abs(e["value"]) < 3 * e["err"] and e["restricted"]
    # a model curve ending before the horizon continues with its decay rate (here exact)
    short = tm[tm <= 1.0]
    assert restricted_model_mean(short, np.exp(-short), horizon, decay_rate=1.0) == (
        pytest.approx(1 - math.exp(-horizon), rel=1e-6))  # trapezoid on 1e-3 steps: 1e-7
    with pytest.raises(ValueError, match="decay_rate"):
        restricted_model_mean(short, np.exp(-short), horizon)


def test_fpt_density_l1_floor_is_the_noise_level():
    """For the true model the mean L1 over seeds equals the floor (E|N(0, sd)| = sqrt(2/pi)
    sd per bin); measured ratio 0.995 +- 0.027 over 40 seeds; 10% allows the seeds' spread
    and the multinomial's departure from normal in sparse bins."""
    ratios = []
    for seed in range(40):
        rng = np.random.default_rng(500 + seed)
        T = rng.exponential(1.0, 3000)
        t, cen = np.minimum(T, 3.0), T > 3.0
        tm = np.linspace(0, 4, 4001)
        r = fpt_density_l1(tm, np.exp(-tm), t, cen, edges=np.linspace(0, 3, 21))
        ratios.append(r["value"] / r["floor"])
    assert np.mean(ratios) == pytest.approx(1.0, abs=0.1)
    wrong = fpt_density_l1(tm, np.exp(-1.3 * tm), t, cen, edges=np.linspace(0, 3, 21))
    assert wrong["value"] > 2 * wrong["floor"]  # measured 3.0x


def test_bad_input():
    with pytest.raises(ValueError, match="one length"):
        kaplan_meier([1.0, 2.0], [False])
    with pytest.raises(ValueError, match=">= 0"):
        kaplan_meier([-1.0], [False])
