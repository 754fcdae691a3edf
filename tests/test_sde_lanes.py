"""The averaged SDE's time-domain and splitting kernels in vector lanes (montecarlo/sde_lanes.py,
sde_lanes_splitting.py; issue 44): a path's numbers must not depend on the lane it ran in, the
paths beside it, the refill of lanes whose paths ended, the thread count or the cut into
calls. Each kernel runs N paths at once (lanes refilled; two threads when numba has them) and
the same paths one per call (one lane), every output compared bit for bit; the first passage
is also checked against the scheme stepped by hand, one path at a time in Python with
averaged_sde.sde_step and sde_time's crossing rule. That the lanes give the numbers of the
kernels that stepped one path at a time before is benchmarks/mc_identity.py's (its ``sde.*``
arrays against main before the change: 0 differ); the physics is unchanged with the bits
(tests/test_time_sde.py: the Rayleigh MFPT and the CIR law in closed form;
tests/test_passage_routes.py: the FPK's reliability; tests/test_splitting.py: the scale
function and Pontryagin's MFPT).
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from vifpk.montecarlo.averaged_sde import sde_step, sde_tables
from vifpk.montecarlo.passage_kernels import BRIDGE_FLOOR
from vifpk.montecarlo.rng import block_seeds, uniform
from vifpk.montecarlo.sde_time import sde_snapshots

H = 0.05


def drift(A):
    return -0.05 * A + 0.01 / A


def diffusion(A):
    return 0.02 + 0.0 * A


def _tables():
    grid, a_tab, b_tab = sde_tables(drift, diffusion, 1.5, 4001)
    return a_tab, b_tab, 1.0 / (grid[1] - grid[0])


def _threads() -> int:
    return min(2, numba.config.NUMBA_NUM_THREADS)


def test_snapshots_are_the_same_for_any_lanes_threads_and_cut():
    """70 paths in 3 blocks (groups of LANES across blocks, a short last group): the law at
    t = 0, 1, 20 equal bit for bit on 1 and 2 threads, and with each block's paths one per
    call; a block's paths are a prefix of a larger run's (per-path streams)."""
    kw = dict(start=0.4, times=[0.0, 1.0, 20.0], edges_A=np.linspace(0, 2, 21), dt=H, seed=12,
              progress=False)
    numba.set_num_threads(1)
    one = sde_snapshots(drift, diffusion, paths=70, blocks=3, **kw)
    numba.set_num_threads(_threads())
    two = sde_snapshots(drift, diffusion, paths=70, blocks=3, **kw)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    np.testing.assert_array_equal(one.data["snapshots"]["A"]["p"],
                                  two.data["snapshots"]["A"]["p"])
    # the kernel itself: the whole call against one path per call
    from vifpk.montecarlo.sde_lanes import run_sde_snapshots
    a_tab, b_tab, inv_d = _tables()
    count = np.array([24, 23, 23], np.int64)
    offset = np.array([0, 24, 47], np.int64)
    marks = np.array([0, 20, 400], np.int64)
    starts = np.linspace(0.1, 1.2, 70)

    def run(k, calls):
        hist, bad = np.zeros((3, 3, 20)), np.zeros(70, np.int64)
        st = block_seeds(12, 3, 24)
        for c in range(calls):
            run_sde_snapshots(st, starts, offset, count, np.full(3, c * k, np.int64), k, marks,
                              H, a_tab, b_tab, inv_d, 0.0, 10.0, hist, bad)
        return hist, bad
    whole, bad = run(24, 1)
    alone, _ = run(1, 24)
    assert not bad.any() and whole[:, 2].sum() > 60
    np.testing.assert_array_equal(whole, alone)


def _passage_by_hand(z0, words, n_max, Ac, a_tab, b_tab, inv_d):
    """One path stepped alone: sde_time's rule (the crossing at a step's end, or inside it
    with the Brownian bridge's probability), with the compiled step and uniform."""
    s0, s1, s2, s3 = (np.uint64(w) for w in words)
    A, Z, sq, last = z0, z0 * z0, math.sqrt(H), a_tab.size - 1
    for n in range(1, n_max + 1):
        Z, bb, _r, *w = sde_step(Z, s0, s1, s2, s3, H, sq, a_tab, b_tab, inv_d, last)
        s0, s1, s2, s3 = (np.uint64(x) for x in w)  # (numba hands them back as int)
        A1 = math.sqrt(Z)
        if A1 >= Ac:
            return (n - 1 + (Ac - A) / (A1 - A)) * H
        arg = 2.0 * (Ac - A) * (Ac - A1) / (bb * bb * H)
        if arg < -math.log(BRIDGE_FLOOR):
            u, *w = uniform(s0, s1, s2, s3)
            s0, s1, s2, s3 = (np.uint64(x) for x in w)
            if u < math.exp(-arg):
                return (n - 1 + (Ac - A) / ((Ac - A) + (Ac - A1))) * H
        A = A1
    return math.inf


@pytest.mark.slow  # numba compilation of three kernels (~15 s cold)
@pytest.mark.xdist_group("sde-lanes")
def test_passage_and_splitting_paths_are_the_same_in_any_lane():
    """First passage of 70 paths in 3 blocks from starts spread below Ac = 1 (crossings at a
    step's end and by the bridge, censoring at n_max): equal with all paths in one call and
    one path per call; the first 6 equal to the scheme stepped by hand. The splitting's AMS
    advance (levels, successes, returns, time-outs) and cycles (cycle starts, successes,
    time-outs): 70 paths at once against one per call, every record and summary."""
    from vifpk.montecarlo.ams import words
    from vifpk.montecarlo.sde_lanes import run_sde_passage
    from vifpk.montecarlo.sde_lanes_splitting import advance_sde, cycles_sde

    a_tab, b_tab, inv_d = _tables()
    count = np.array([24, 23, 23], np.int64)
    offset = np.array([0, 24, 47], np.int64)
    starts = np.linspace(0.05, 0.95, 70)
    n_max, Ac = 2000, 1.0

    def passage(k, calls):
        fpt, cens, bad = np.zeros(70), np.zeros(70, np.bool_), np.zeros(70, np.int64)
        st = block_seeds(11, 3, 24)
        for c in range(calls):
            run_sde_passage(st, starts, offset, count, np.full(3, c * k, np.int64), k, n_max,
                            n_max * H, H, Ac, a_tab, b_tab, inv_d, fpt, cens, bad)
        return fpt, cens, bad
    numba.set_num_threads(_threads())
    fpt, cens, bad = passage(24, 1)
    numba.set_num_threads(1)
    f1, c1, _ = passage(1, 24)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert not bad.any() and 0 < cens.sum() < 60
    np.testing.assert_array_equal(fpt, f1)
    np.testing.assert_array_equal(cens, c1)
    st = block_seeds(11, 3, 24)
    for g in range(6):
        t = _passage_by_hand(starts[g], st[0, g], n_max, Ac, a_tab, b_tab, inv_d)
        assert (fpt[g] == t) if not cens[g] else t == math.inf, (g, fpt[g], t)

    N, M, q_lo, q_hi = 70, 8, 0.2**2, 0.9**2
    rng = words(4, (8,), N)

    def advance(one_by_one):
        recs = np.zeros((N, M + 1, 2))
        recs[:, 0, 0] = np.linspace(0.25, 0.8, N) ** 2
        recs[:, 0, 1] = np.linspace(0.0, 50.0, N)
        rows, start = np.arange(N, dtype=np.int64), np.zeros(N, np.int64)
        maxlev, outcome = np.zeros(N, np.int64), np.zeros(N, np.int64)
        for sl in ([slice(j, j + 1) for j in range(N)] if one_by_one else [slice(0, N)]):
            advance_sde(recs, rows[sl], start[sl], rng[sl], maxlev, outcome, q_lo, q_hi, M,
                        60.0, H, a_tab, b_tab, inv_d)
        return recs, maxlev, outcome

    def cycles(one_by_one):
        z0 = np.linspace(0.01, 0.5, N) ** 2
        e, sm = np.zeros((N, 3, 2)), np.zeros((N, 7))
        for sl in ([slice(j, j + 1) for j in range(N)] if one_by_one else [slice(0, N)]):
            ee, ss = np.zeros((z0[sl].size, 3, 2)), np.zeros((z0[sl].size, 7))
            cycles_sde(z0[sl], rng[sl], 4, 0.15**2, 0.3**2, 1.2**2, 100.0, H, a_tab, b_tab,
                       inv_d, ee, ss)
            e[sl], sm[sl] = ee, ss
        return e, sm

    numba.set_num_threads(_threads())
    together = advance(False), cycles(False)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    alone = advance(True), cycles(True)
    for x, y in zip(together[0] + together[1], alone[0] + alone[1], strict=True):
        np.testing.assert_array_equal(x, y)
    outcome, sm = together[0][2], together[1][1]
    assert {-1, 0, 1} <= set(outcome.tolist()), outcome  # time-outs, returns, successes
    assert sm[:, 4].sum() > 0 and sm[:, 5].sum() > 0 and sm[:, 2].sum() > N  # successes,
    # time-outs, cycles
