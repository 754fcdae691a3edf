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
