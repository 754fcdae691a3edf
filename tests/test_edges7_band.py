"""Issue 39, round 7: the tolerance range (K05) and band sweeps with checkpoints (B39-B50):
refused in one line naming the input and its range, or recomputed and said; never a false
message. docs/edges.md ("Round 7 ... helper edges39") lists them."""

from __future__ import annotations

import pytest


def _main(args):
    from vifpk.harness.cli.app import main

    try:
        return main(args)
    except SystemExit as exc:
        return exc.code


# ------------------------------------------------------------ K05: the tolerance's range
@pytest.mark.parametrize(("metric", "value", "top"), [
    ("L1", "5", "2"), ("L1", "2", "2"), ("ks", "1", "1"), ("hellinger", "1.5", "1")])
def test_k05_a_tolerance_at_or_above_the_metric_s_maximum_is_refused(no_computation, capsys,
                                                                     tmp_path, metric, value,
                                                                     top):
    """L1 <= 2, KS <= 1, Hellinger <= 1 between any two densities (harness/workflows/
    compare.py's definitions): such a tolerance can never fail, so it is not a question."""
    out = tmp_path / "o"
    assert _main(["check", "paper-base", "--tolerance", value, "--tolerance-metric", metric,
                  "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--tolerance" in err[0] and f"< {top} for" in err[0], err
    assert metric in err[0] and not out.exists()


def test_k05_a_tolerance_below_the_maximum_and_any_w1_are_accepted():
    from vifpk.harness.request.tolerance import Tolerance

    assert Tolerance(value=1.99, metric="L1").value == 1.99
    assert Tolerance(value=0.99, metric="ks").value == 0.99
    assert Tolerance(value=50.0, metric="w1").value == 50.0  # W1 is unbounded
