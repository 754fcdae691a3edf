"""montecarlo/certificate.py's rank-normalised R-hat against ArviZ's on shared draws.

ArviZ's ``rhat(method="rank")`` (Vehtari et al. 2021) splits each chain in two halves before
rank-normalising; the certificate does not split (its chains are groups of independent
replicas, see the module). So the certificate's R-hat of the split draws must equal ArviZ's of
the unsplit ones, to rounding: the same ranks (average ties), the same Blom offset 3/8, the
same bulk and folded-tail variants and the same variance ratio.
"""

from __future__ import annotations

import numpy as np
import pytest
from vifpk.montecarlo.certificate import rank_rhat

az = pytest.importorskip("arviz")


def split_chains(x: np.ndarray) -> np.ndarray:
    """ArviZ's split: the first and the last half of each chain as chains of their own."""
    half = x.shape[1] // 2
    return np.concatenate([x[:, :half], x[:, -half:]], axis=0)


@pytest.mark.parametrize("case", ["mixed", "shifted chain", "heavy tails", "ties", "scale"])
def test_rank_rhat_matches_arviz(case: str):
    rng = np.random.default_rng(20261123)
    x = rng.normal(size=(8, 200))
    if case == "shifted chain":  # one chain has not forgotten its start: R-hat >> 1
        x[0] += 1.5
    elif case == "heavy tails":
        x = rng.standard_cauchy(size=(8, 200))
    elif case == "ties":
        x = np.round(x, 1)
    elif case == "scale":  # same location, one chain wider: only the folded (tail) R-hat sees it
        x[3] *= 4.0
    ours = rank_rhat(split_chains(x))
    theirs = float(az.rhat(x, method="rank"))
    assert ours == pytest.approx(theirs, rel=1e-12, abs=1e-12)
    if case in ("shifted chain", "scale"):
        assert ours > 1.05


def test_f_quantile_and_ranks_match_scipy():
    """The certificate's own F quantile (rhat_limit) and average ranks, which replace
    scipy.stats (its import cost more than a run's certificate, issue 44), against scipy's:
    the quantile within 1e-9 relative (the bisection is exact to 1e-16; the log-gamma
    differences lose digits as d2 grows), the ranks and normal scores to rounding."""
    stats = pytest.importorskip("scipy.stats")
    from vifpk.montecarlo.certificate import average_ranks, f_quantile, normal_scores

    for q in (0.5, 0.9, 1 - 1e-4):
        for d1 in (1, 3, 31, 255):
            for d2 in (4, 62, 992, 8000, 261120):
                assert f_quantile(q, d1, d2) == pytest.approx(stats.f.ppf(q, d1, d2),
                                                              rel=1e-9)
    rng = np.random.default_rng(44)
    x = np.round(rng.normal(size=(16, 64)), 1)  # many ties
    assert np.array_equal(average_ranks(x.ravel()), stats.rankdata(x.ravel()))
    want = stats.norm.ppf((stats.rankdata(x.ravel()) - 0.375) / (x.size + 0.25))
    assert np.allclose(normal_scores(x).ravel(), want, rtol=0, atol=1e-14)
