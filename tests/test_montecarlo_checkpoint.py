"""montecarlo/checkpoint.py: a run continued from where it stopped (issue 29, item 3).

A run toward floor F1 that stops at its first check (8 windows) and is continued toward F2
makes, from window 8 on, the same decisions as a run made toward F2 from the start (the grow
rule sees the same windows, floor and target), so the two must agree bit for bit; continuing
must not run the pilots or the burn-in again (the path-steps say so); the checkpoint survives
bytes and any thread count; another run's checkpoint is refused.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.test_montecarlo import run

SMALL = {"paths": 256, "blocks": 16, "time": 400.0, "burn_in": 100.0, "dt": 0.04,
         "observables": ("A",), "seed": 11}


@pytest.fixture(scope="module")
def first(base):
    """A run that stops at its first check: any floor it reaches is below F1 = 1."""
    return run(base, **SMALL, floor=1.0, keep_state=True, threads=1)


def test_continued_run_is_the_run_made_toward_the_smaller_floor(base, first):
    ck = first.info["checkpoint"]
    assert ck.run_to == 8
    target = 0.6 * first.info["L1_floor"]["A"]
    more = run(base, **SMALL, floor=target, resume=ck.to_bytes(), threads=2)
    direct = run(base, **SMALL, floor=target, threads=1)
    np.testing.assert_array_equal(more.data["A"]["p"], direct.data["A"]["p"])
    np.testing.assert_array_equal(more.data["A"]["err"], direct.data["A"]["err"])
    assert more.info["L1_floor"]["A"] == direct.info["L1_floor"]["A"] <= target
    assert more.info["steps"] == direct.info["steps"]
    # only the new windows were simulated: no pilot, no burn-in again
    assert more.info["steps_this_run"] == more.info["steps"] - first.info["steps"]
    assert more.info["resumed"]["windows"] == 8
    assert more.info["convergence"]["equilibrated"] == direct.info["convergence"]["equilibrated"]


def test_checkpoint_bytes_round_trip(first):
    from vifpk.montecarlo.checkpoint import Checkpoint

    ck = first.info["checkpoint"]
    back = Checkpoint.from_bytes(ck.to_bytes())
    assert (back.key, back.run_to, back.n_burn, back.h, back.steps) == (
        ck.key, ck.run_to, ck.n_burn, ck.h, ck.steps)
    for k, v in ck.arrays.items():
        if v is None:
            assert back.arrays[k] is None
        else:
            np.testing.assert_array_equal(back.arrays[k], v)
    np.testing.assert_array_equal(back.hist["A"], ck.hist["A"])


@pytest.mark.parametrize("change", [{"seed": 12}, {"paths": 128}, {"dt": 0.02}])
def test_another_runs_checkpoint_is_refused(base, first, change):
    with pytest.raises(ValueError, match="belongs to another run"):
        run(base, **{**SMALL, **change}, floor=0.01, resume=first.info["checkpoint"])
