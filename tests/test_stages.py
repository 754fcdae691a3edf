"""harness/workflows/stages.py and the check's concurrent runs (harness/workflows/checkruns.py,
averaging.memo.carry): work beside the caller returns or raises as if run in place, the lines
of stages run beside are printed by the caller's thread, a failure among the averaged SDEs is
the one a run one after another would raise, and a carried memo is shared."""

from __future__ import annotations

import re
import threading
import time

import numpy as np
import pytest
from vifpk.harness.workflows import checkruns
from vifpk.harness.workflows.stages import Beside, Stages


def test_beside_returns_the_value_or_raises_the_exception():
    assert Beside(lambda a, b: a + b, 2, 3).result() == 5
    failing = Beside(lambda: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        failing.result()
    assert isinstance(failing.failed(), ZeroDivisionError)


def test_beside_runs_in_another_thread_while_the_caller_goes_on():
    started, release = threading.Event(), threading.Event()

    def work():
        started.set()
        release.wait(5)
        return threading.current_thread().name

    b = Beside(work, name="vifpk-test")
    assert started.wait(5) and b.failed() is None  # still running: nothing failed yet
    release.set()
    assert b.result() == "vifpk-test"


def test_stages_print_the_lines_of_work_beside_at_the_caller_s_next_line(capsys):
    st = Stages(3, quiet=False)
    st("first")
    st.beside("beside one", 0.25)
    before = capsys.readouterr().err
    assert before == "[1/3] first ..."  # the line beside is not printed from the other thread
    st("second")
    st.done()
    err = capsys.readouterr().err
    assert "[2/3] beside one ... 0.2 s (beside the others)" in err or \
        "[2/3] beside one ... 0.3 s (beside the others)" in err
    assert re.match(r" \d+\.\d s\n\[2/3\] beside one", err) and "[3/3] second ..." in err
    assert set(st.seconds) == {"first", "beside one", "second"}
    assert st.seconds["beside one"] == 0.25


def test_quiet_stages_print_nothing_and_keep_the_seconds(capsys):
    st = Stages(2, quiet=True)
    st("a")
    st.beside("b", 1.0)
    st.done()
    assert capsys.readouterr().err == "" and st.seconds["b"] == 1.0


def _fake_runs(monkeypatch, delays, failing):
    """checkruns.sde_run replaced: model m sleeps delays[m], then fails if in ``failing``."""
    def fake(scene, m, closed, edges, st, burn_in, budget, stages):
        time.sleep(delays[m])
        if m in failing:
            raise RuntimeError(f"{m} failed")
        return f"result {m}", 0

    monkeypatch.setattr(checkruns, "sde_run", fake)


def test_the_sdes_results_come_in_model_order(monkeypatch):
    _fake_runs(monkeypatch, {"a": 0.2, "b": 0.0, "c": 0.05}, set())
    models = ("a", "b", "c")
    out = checkruns.sde_runs(None, models, dict.fromkeys(models), {}, None, None, 1.0,
                             Stages(3, quiet=True))
    assert list(out) == list(models) and out["b"] == ("result b", 0)


def test_a_failure_among_the_sdes_is_the_first_model_s_in_order(monkeypatch):
    """a fails late, b early: a run one after another would have raised a's."""
    _fake_runs(monkeypatch, {"a": 0.3, "b": 0.0, "c": 0.0}, {"a", "b"})
    models = ("a", "b", "c")
    with pytest.raises(RuntimeError, match="a failed"):
        checkruns.sde_runs(None, models, dict.fromkeys(models), {}, None, None, 1.0,
                           Stages(3, quiet=True))


def test_no_sde_starts_after_one_failed(monkeypatch):
    ran = []
    real = {"a": 0.0, "b": 1.0, "c": 0.0, "d": 0.0}

    def fake(scene, m, *args):
        ran.append(m)
        time.sleep(real[m])
        if m == "a":
            raise RuntimeError("a failed")
        return m, 0

    monkeypatch.setattr(checkruns, "sde_run", fake)
    models = ("a", "b", "c", "d")
    with pytest.raises(RuntimeError, match="a failed"):
        checkruns.sde_runs(None, models, dict.fromkeys(models), {}, None, None, 1.0,
                           Stages(4, quiet=True))
    assert "c" not in ran and "d" not in ran  # b was already running beside a


def test_a_carried_memo_is_shared_by_the_thread():
    from vifpk.averaging import memo

    calls = []

    def compute():
        calls.append(1)
        return np.arange(3.0)

    grid = np.linspace(0.0, 1.0, 5)
    with memo.shared():
        first = memo.recall("t", ("p",), grid, compute)
        other = Beside(memo.carry(lambda: memo.recall("t", ("p",), grid, compute))).result()
        alone = Beside(lambda: memo.active()).result()  # a thread not carried: no memo
    assert len(calls) == 1 and np.array_equal(first, other) and alone is False
