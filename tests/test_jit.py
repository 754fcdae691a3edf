"""montecarlo._jit.over_blocks: every block once, on one thread each, for any thread count;
and after a fork (a sweep's process-pool worker inherits the parent's pool object but not its
threads) the child still runs its blocks instead of waiting on threads it does not have."""

from __future__ import annotations

import multiprocessing

import numba
import numpy as np
import pytest
from vifpk.montecarlo._jit import jit, over_blocks


@jit(nogil=True)
def _mark(first, every, count, owner):
    for b in range(first, count.shape[0], every):
        count[b] += 1
        owner[b] = first


def _run(n_blocks: int, threads: int) -> tuple[np.ndarray, np.ndarray]:
    count, owner = np.zeros(n_blocks, np.int64), np.full(n_blocks, -1, np.int64)
    old = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        over_blocks(_mark, n_blocks, count, owner)
    finally:
        numba.set_num_threads(old)
    return count, owner


@pytest.mark.parametrize("threads", sorted({1, numba.config.NUMBA_NUM_THREADS}))
@pytest.mark.parametrize("n_blocks", [1, 2, 5])
def test_every_block_once_on_its_thread(n_blocks: int, threads: int):
    count, owner = _run(n_blocks, threads)
    n = min(threads, n_blocks)
    assert count.tolist() == [1] * n_blocks
    assert owner.tolist() == [b % n for b in range(n_blocks)]  # thread t: blocks t, t + n, ...


def _child(q) -> None:
    q.put(_run(5, numba.config.NUMBA_NUM_THREADS)[0].tolist())


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="one numba thread: no pool")
def test_a_forked_child_runs_its_blocks():
    _run(4, 2)  # the parent's pool exists
    ctx = multiprocessing.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_child, args=(q,))
    p.start()
    try:
        assert q.get(timeout=60) == [1] * 5
    finally:
        p.join(timeout=60)
        if p.is_alive():
            p.kill()
