"""harness/outputs/runwarnings.py: the counted RuntimeWarnings of a run come out in one order,
whichever part of the run warned first (the check runs its parts side by side, issue 44), so
metrics.json stays byte-identical for a seed (docs/report.md, "Same seed, same metrics")."""

from __future__ import annotations

import threading
import warnings

from hypothesis import given, settings
from hypothesis import strategies as st
from vifpk.harness.outputs.runwarnings import RunWarnings

#: (file, line, message) of the warnings a run raises; lines 9 and 10x apart so that a string
#: sort of "file:line" would put them in the wrong order
RAISED = [("/x/averaging/paper.py", 9, "overflow encountered in exp"),
          ("/x/averaging/paper.py", 100, "overflow encountered in exp"),
          ("/x/fpk/scheme.py", 31, "invalid value encountered in divide"),
          ("/x/montecarlo/tuning.py", 7, "divide by zero encountered in log")]


def _records(order: list[int], repeats: list[int]) -> list[dict]:
    tally = RunWarnings()
    with tally.recording():
        for i in order:
            file, line, message = RAISED[i]
            for _ in range(repeats[i]):
                warnings.warn_explicit(message, RuntimeWarning, file, line)
    return tally.records()


@settings(max_examples=30, deadline=None)
@given(st.permutations(range(len(RAISED))), st.lists(st.integers(1, 3), min_size=4, max_size=4))
def test_records_do_not_depend_on_the_order_raised(order, repeats):
    got = _records(order, repeats)
    assert got == _records(list(range(len(RAISED))), repeats)
    assert [w["where"] for w in got] == ["averaging/paper.py:9", "averaging/paper.py:100",
                                         "fpk/scheme.py:31", "montecarlo/tuning.py:7"]
    assert [w["count"] for w in got] == repeats


def test_threads_warning_side_by_side_give_one_list():
    """Two threads warn in either order; the counted list is the same."""
    def run(first: int) -> list[dict]:
        tally = RunWarnings()
        with tally.recording():
            for i in (first, 1 - first):
                t = threading.Thread(target=warnings.warn_explicit,
                                     args=(RAISED[2 * i][2], RuntimeWarning, RAISED[2 * i][0],
                                           RAISED[2 * i][1]))
                t.start()
                t.join()
        return tally.records()

    assert run(0) == run(1) and len(run(0)) == 2
