"""Splitting (montecarlo/splitting.py) against closed forms of a 1-D diffusion.

The Rayleigh amplitude of a linear oscillator under white noise,
dA = (-beta A / 2 + sigma^2 / (2 A)) dt + sigma dB, c = beta / (2 sigma^2):
  scale density s(A) = exp(-int 2m / sigma^2) = e^{c A^2} / A, S(A) = Ei(c A^2) / 2, so
  P(reach Ac before a0 | a) = (Ei(c a^2) - Ei(c a0^2)) / (Ei(c Ac^2) - Ei(c a0^2));
  MFPT with a reflecting origin (Pontryagin): T(a) = int_a^Ac s(y) int_0^y 2 / (sigma^2 s(z))
  dz dy = (1 / beta) [Ei(c y^2) - ln(c y^2)]_a^Ac.
Tolerances: the estimators are unbiased for the simulated chain, so the truth should lie
within a few standard errors; we allow |z| < 4 (a false alarm once in ~16000 runs of an
unbiased estimator with a normal error). The time-step bias of the chain against the continuous
closed form was measured well below one standard error at these settings (coverage of the 95%
interval at p = 1.3e-8 over 100 seeds: benchmarks/results/splitting_coverage.json).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import expi
from vifpk.montecarlo.splitting import (
    SplittingSettings,
    ams,
    cycle_mfpt,
    sde_escape_probability,
    sde_passage_splitting,
)

# xdist_group: tests that run the same compiled kernel shape go to one worker (CI's --dist
# loadgroup), so it is compiled once rather than by both workers at the same time.
BETA, S2 = 1.0, 0.5
C = BETA / (2 * S2)


def drift(A):
    return -BETA * A / 2 + S2 / (2 * A)


def diffusion(A):
    return S2 + 0 * A


def p_exact(a, lo, hi):
    return (expi(C * a * a) - expi(C * lo * lo)) / (expi(C * hi * hi) - expi(C * lo * lo))


def mfpt_exact(a, hi):
    return (expi(C * hi * hi) - expi(C * a * a) - np.log(hi * hi / (a * a))) / BETA


def z_score(est, truth):
    return (est["value"] - truth) / est["stderr"]


@pytest.mark.xdist_group("splitting-sde")
@pytest.mark.slow  # numba compilation: ~10 s on a fresh clone
def test_escape_probability_matches_the_scale_function():
    s = SplittingSettings(groups=10, particles=50, levels=50, dt=2e-3, seed=3)
    r = sde_escape_probability(drift, diffusion, low=0.5, threshold=2.5, start=1.0, settings=s)
    p = r.data["p"]
    assert abs(z_score(p, p_exact(1.0, 0.5, 2.5))) < 4
    assert p["ci"][0] < p["value"] < p["ci"][1]
    assert r.info["timeouts"] == 0


@pytest.mark.xdist_group("splitting-sde")
@pytest.mark.slow  # numba compilation: ~10 s on a fresh clone
def test_same_seed_same_answer_for_any_thread_count():
    s = dict(groups=4, particles=40, levels=40, dt=2e-3, seed=11)
    one = sde_escape_probability(drift, diffusion, low=0.5, threshold=2.5, start=1.0,
                                 settings=SplittingSettings(threads=1, **s))
    two = sde_escape_probability(drift, diffusion, low=0.5, threshold=2.5, start=1.0,
                                 settings=SplittingSettings(threads=2, **s))
    assert one.data["p"]["runs"] == two.data["p"]["runs"]
    other = sde_escape_probability(drift, diffusion, low=0.5, threshold=2.5, start=1.0,
                                   settings=SplittingSettings(threads=2, **dict(s, seed=12)))
    assert other.data["p"]["runs"] != one.data["p"]["runs"]


def test_ams_is_unbiased_with_ties_on_a_toy_chain():
    """A chain whose level moves by +-1 (a fair walk on 0..M from 1, absorbed at 0 and M):
    every score ties with many others, the case GAMS's kill-all-ties rule is for.
    P(reach M before 0 | 1) = 1 / M (gambler's ruin). The mean of 200 independent runs of 20
    particles must be within 4 standard errors of 1 / M."""
    from vifpk.montecarlo import splitting_kernels as SK

    M = 8

    def advance(recs, rows, start, rng, maxlev, outcome):
        for j, row in enumerate(rows):
            g = np.random.default_rng(rng[j])
            x = recs[row, start[j], 0]
            lev = int(start[j])
            while 0 < x < M:
                x += 1 if g.random() < 0.5 else -1
                if x > lev:
                    lev = int(x)
                    recs[row, lev, 0] = x
            maxlev[row] = lev
            outcome[row] = SK.OUT_SUCCESS if x >= M else SK.OUT_FAIL

    G, N = 200, 20
    starts = np.ones((G, N, 1))
    out = ams(advance, starts, starts[..., 0], q_lo=0.0, q_hi=float(M), levels=M, kill=3,
              seed=5)
    p = out["p"]
    assert abs((p.mean() - 1 / M) / (p.std(ddof=1) / np.sqrt(G))) < 4


def test_cycle_mfpt_formula_and_delta_method():
    """T = E[W] + (1 - q_w) E[tau] / p on exact group values; the standard error of a ratio
    tau / p with independent errors is T sqrt(cv_tau^2 + cv_p^2) to first order."""
    G = 4000
    g = np.random.default_rng(0)
    n = np.full(G, 100.0)
    S = n * (2.0 + 0.05 * g.standard_normal(G))  # tau: 2 +- 0.05 a group
    p = 1e-3 * (1 + 0.1 * g.standard_normal(G))
    rec = cycle_mfpt(np.zeros(G), np.zeros(G), S, n, p)
    assert rec["value"] == pytest.approx(2.0 / p.mean() * (S.sum() / n.sum() / 2.0), rel=1e-12)
    expected = 2000.0 * np.sqrt(0.025**2 + 0.1**2) / np.sqrt(G)
    assert rec["stderr"] == pytest.approx(expected, rel=0.05)  # 5%: sampling of 4000 groups


def test_bad_levels_raise():
    s = SplittingSettings(groups=2, particles=10, levels=10, dt=1e-2)
    with pytest.raises(ValueError, match="low < start"):
        sde_escape_probability(drift, diffusion, low=1.0, threshold=2.0, start=0.5, settings=s)
    with pytest.raises(ValueError, match="kill"):
        sde_escape_probability(drift, diffusion, low=0.5, threshold=2.0, start=1.0,
                               settings=SplittingSettings(groups=2, particles=10, kill=10))


@pytest.mark.xdist_group("splitting-sde")
@pytest.mark.slow
def test_escape_probability_of_1e_minus_8():
    """p = 1.3e-8, 20 AMS runs of 100 particles (~10 s)."""
    s = SplittingSettings(groups=20, particles=100, levels=100, dt=1e-3, seed=7)
    r = sde_escape_probability(drift, diffusion, low=0.5, threshold=4.7, start=1.0, settings=s)
    truth = p_exact(1.0, 0.5, 4.7)
    assert truth < 2e-8
    assert abs(z_score(r.data["p"], truth)) < 4


@pytest.mark.xdist_group("splitting-sde")
@pytest.mark.slow
def test_mfpt_by_cycles_matches_pontryagin():
    """MFPT from A = 0.4 to Ac = 4.7 (1.9e8 time units; the cycle's success probability is
    ~1e-8): cycle decomposition with direct cycles and AMS, against the closed form."""
    s = SplittingSettings(groups=20, particles=100, levels=100, dt=1e-3, seed=2)
    r = sde_passage_splitting(drift, diffusion, threshold=4.7, start=0.4, low=0.5, entry=1.0,
                              settings=s)
    m = r.info["mfpt"]
    truth = mfpt_exact(0.4, 4.7)
    assert truth > 1e8
    assert m["p"]["value"] < 1e-7
    assert abs(z_score(m, truth)) < 4
    assert m["stderr"] / m["value"] < 0.15


@pytest.mark.xdist_group("splitting-sde")
@pytest.mark.slow
def test_groups_give_the_same_numbers_in_one_batch_or_several():
    """rel_ci > 0 adds batches of groups; group g's streams are keyed by g, so 2 batches of 2
    groups give the numbers of 1 batch of 4."""
    kw = dict(particles=30, levels=30, dt=2e-3, seed=8, paths=4, cycles=10)
    one = sde_passage_splitting(drift, diffusion, threshold=2.5, start=0.4, low=0.5, entry=1.0,
                                settings=SplittingSettings(groups=4, **kw))
    two = sde_passage_splitting(drift, diffusion, threshold=2.5, start=0.4, low=0.5, entry=1.0,
                                settings=SplittingSettings(groups=2, rel_ci=1e-9,
                                                           max_groups=4, **kw))
    assert two.info["groups"] == 4 and "NOT reached" in two.info["target"]
    assert one.info["mfpt"]["p"]["runs"] == two.info["mfpt"]["p"]["runs"]
    assert one.info["mfpt"]["value"] == two.info["mfpt"]["value"]


@pytest.mark.xdist_group("splitting-sde")
@pytest.mark.slow
def test_mfpt_by_cycles_at_a_threshold_direct_cycles_reach():
    """At Ac = 2.5 (p ~ 2e-2, T ~ 100) some direct cycles succeed: the cycle bookkeeping of
    successes (their duration is the time to Ac) is then exercised."""
    s = SplittingSettings(groups=20, particles=100, levels=100, dt=1e-3, seed=4)
    r = sde_passage_splitting(drift, diffusion, threshold=2.5, start=0.4, low=0.5, entry=1.0,
                              settings=s)
    assert r.info["direct_successes"] > 0
    assert abs(z_score(r.info["mfpt"], mfpt_exact(0.4, 2.5))) < 4


# ------------------------------------------------------------------ the original system
@pytest.fixture(scope="module")
def paper_base():
    from vifpk.core.scene import load_scene

    return load_scene("paper-base")


@pytest.mark.xdist_group("splitting-paper-base")
@pytest.mark.slow
def test_original_system_splitting_agrees_with_direct_first_passage(paper_base):
    """Threshold A = 0.9 on paper-base (a cycle succeeds with p ~ 3e-2; MFPT ~ 5e3): the MFPT
    by splitting and by montecarlo.first_passage (an independent code: its own kernel loop,
    no cycles, no splitting) from the same start law, 400 paths, within 4 combined standard
    errors."""
    from vifpk.montecarlo import PassageSettings, first_passage
    from vifpk.montecarlo.splitting import passage_splitting

    s = SplittingSettings(groups=20, particles=100, levels=100, dt=0.01, seed=1)
    sc = paper_base
    r = passage_splitting(sc.system, sc.noise, s, threshold=0.9, start=0.4, low=0.27,
                          entry=0.41)
    d = first_passage(sc.system, sc.noise,
                      PassageSettings(paths=400, blocks=16, dt=0.01, horizon=2e5, seed=5,
                                      threads=0, progress=False),
                      threshold=0.9, start=0.4)
    t = d.data["fpt"]["time"]
    assert not d.data["fpt"]["censored"].any()
    m = r.info["mfpt"]
    assert 1e-2 < m["p"]["value"] < 1e-1
    se = t.std(ddof=1) / np.sqrt(t.size)
    assert abs(m["value"] - t.mean()) < 4 * np.hypot(m["stderr"], se)


@pytest.mark.xdist_group("splitting-paper-base")
@pytest.mark.slow
def test_original_system_same_seed_same_answer_for_any_thread_count(paper_base):
    from vifpk.montecarlo.splitting import passage_splitting

    sc = paper_base
    kw = dict(groups=3, particles=20, levels=30, dt=0.02, seed=9, paths=4, cycles=6)
    one, two = (passage_splitting(sc.system, sc.noise, SplittingSettings(threads=n, **kw),
                                  threshold=0.9, start=0.4, low=0.27, entry=0.41)
                for n in (1, 2))
    assert one.info["mfpt"] == two.info["mfpt"]
    assert one.info["iterations"] == two.info["iterations"]


@pytest.mark.parametrize("bad, needle", [
    ({"dt": -0.01}, "dt = -0.01"), ({"particles": 0}, "particles = 0"),
    ({"groups": 1}, "groups = 1"), ({"levels": float("nan")}, "levels = nan"),
    ({"kill": 5, "particles": 5}, "kill = 5"), ({"dt": 1.0, "max_time": 1.0}, "dt = 1"),
])
def test_bad_settings_are_one_line_before_any_run(bad, needle):
    """Review of issue 31: dt < 0 ran forever, particles = 0 failed in numpy, groups = 1 died
    on a Student-t with no degree of freedom; each is refused by the settings themselves."""
    from vifpk.montecarlo.splitting import SplittingSettings

    from vifpk.core.result import BadInput

    with pytest.raises(BadInput) as err:
        SplittingSettings(**bad)
    assert needle in str(err.value) and "\n" not in str(err.value)
