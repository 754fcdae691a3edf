"""The original system's splitting kernels in vector lanes (montecarlo/splitting_lanes.py,
issue 44): a path's result must not depend on the lane it ran in, on the paths beside it or
on the refill of lanes whose paths ended. Each kernel is run on 70 paths at once (lanes
refilled, two threads when numba has them) and on the same 70 generators one path per call
(one lane), every output array compared bit for bit. That the lanes give the numbers of the
kernels that stepped one path at a time with kernels.strang_step is benchmarks/mc_identity.py's
(the splitting runs of paper-base and hard/white against main before the change: 0 arrays
differ)."""

from __future__ import annotations

import numba
import numpy as np
import pytest

N = 70


def _setup(name):
    from vifpk.montecarlo import splitting_kernels as SK
    from vifpk.montecarlo.ams import words
    from vifpk.montecarlo.geometry import energy, potential
    from vifpk.montecarlo.pieces import record
    from vifpk.montecarlo.plan import bounds, fold, physics

    from vifpk.core.scene import load_scene

    sc = load_scene(f"scenes/{name}.toml")
    ph = physics(sc.system, sc.noise)
    h = 0.02
    rec = record(ph, h)
    starts = np.zeros((N, 5))
    SK.orbit_starts(0.45, starts, words(3, (7,), N), ph["w0sq"], ph["alpha"], ph["khi"],
                    (fold(ph), *bounds(ph)), rec)

    def U(A):
        return float(potential(A, ph["w0sq"], ph["alpha"], ph["khi"]))

    def E(x, v):
        return float(energy(x, v, ph["w0sq"], ph["alpha"], ph["khi"]))
    return h, rec, (rec.bridge, rec.pk, rec.pc), starts, words(4, (8,), N), U, E


def _threads():
    return min(2, numba.config.NUMBA_NUM_THREADS)


@pytest.mark.slow  # numba compilation of both kernels for two physics records
@pytest.mark.parametrize("name, t_adv, a_hi, t_cyc", [
    pytest.param("paper-base", 20.0, 0.6, 200.0,
                 marks=pytest.mark.xdist_group("splitting-paper-base")),
    pytest.param("hard/white", 15.0, 0.8, 30.0,
                 marks=pytest.mark.xdist_group("splitting-white"))])
def test_a_splitting_path_is_the_same_in_any_lane(name, t_adv, a_hi, t_cyc):
    """advance_orig (AMS) from orbit starts between the levels, until absorbed or t_max (some
    paths time out), and cycles_orig with a burn-in (restarts) and few cycles: every record,
    level, outcome, entry and summary equal whether 70 paths share the lanes or run alone;
    successes, returns, time-outs and restarts all occur."""
    from vifpk.montecarlo import splitting_kernels as SK
    from vifpk.montecarlo.splitting_kernels import level_of
    from vifpk.montecarlo.splitting_lanes import advance_orig, cycles_orig

    h, rec, B, starts, rng, U, E = _setup(name)
    q_lo, q_hi, M, t_max = U(0.3), U(0.7), 20, t_adv
    lev0 = np.array([level_of(E(s[0], s[1]), q_lo, M / (q_hi - q_lo), M) for s in starts],
                    dtype=np.int64)

    def advance(groups):
        recs = np.zeros((N, M + 1, 5))
        recs[np.arange(N), lev0] = starts
        maxlev = np.zeros(N, np.int64)
        outcome = np.zeros(N, np.int64)
        for rows in groups:
            advance_orig(recs, rows, lev0[rows], rng[rows], maxlev, outcome,
                         (q_lo, q_hi, M, t_max), h, B, rec)
        return recs, maxlev, outcome

    def cycles(groups):
        entries = np.zeros((N, 3, 5))
        summary = np.zeros((N, 7))
        for rows in groups:
            e, s = np.zeros((rows.size, 3, 5)), np.zeros((rows.size, 7))
            cycles_orig(starts[rows], rng[rows], (3, U(0.3), U(0.4), U(a_hi), t_cyc, 500), h,
                        B, rec, e, s)
            entries[rows], summary[rows] = e, s
        return entries, summary

    all_rows = [np.arange(N, dtype=np.int64)]
    one_by_one = [np.array([j], dtype=np.int64) for j in range(N)]
    with_threads = numba.get_num_threads()
    numba.set_num_threads(_threads())
    try:
        together = advance(all_rows), cycles(all_rows)
    finally:
        numba.set_num_threads(with_threads)
    alone = advance(one_by_one), cycles(one_by_one)
    for got, want in zip((*together[0], *together[1]), (*alone[0], *alone[1]), strict=True):
        assert np.array_equal(got, want, equal_nan=True)
    outcome, summary = together[0][2], together[1][1]
    for o in (SK.OUT_SUCCESS, SK.OUT_FAIL, SK.OUT_TIMEOUT):
        assert np.any(outcome == o), o
    assert np.any(summary[:, 4] > 0) and np.any(summary[:, 5] == 1.0)  # successes, t_max
    assert summary[:, 6].sum() > 0  # burn-ins restarted
