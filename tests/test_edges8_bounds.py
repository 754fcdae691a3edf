"""Issue 45 item 1, the reproducers left open by round 8 (docs/edges.md, round 8b): a
parametric intensity the solvers cannot hold is refused before any work, in one line, exit
2, named after the key that breaks it. Fast: the request asks the door for the closed form's
own scan of the exact model's law (harness/door/reach.py ``law_reach``), no solver runs.

Before (at aa1e12c) each of these was accepted and then failed after the closed form (~2 s),
the FPK (14 s) or the Monte Carlo (58 s) with exit 3; the kappa > 1 bound that validation
enforced (1/12 on paper-base) is not the one the solvers need.
"""

from __future__ import annotations

import pytest
from vifpk.harness.cli.app import main

import vifpk
from vifpk.core.result import BadInput

# (scene, --set, the key named, words of the reason)
CASES = [
    # kappa = 1.03 > 1: a law exists, but it falls by e^7 only before A = 1e4
    ("paper-base", ["parametric.stiffness=0.08"], "parametric.stiffness = 0.08",
     "a law exists, but its tail is too heavy for the solvers"),
    # D_c = 100 on the linear oscillator: kappa = 1.11
    ("systems/linear-ou", ["parametric.damping=100"], "parametric.damping = 100",
     "its tail is too heavy"),
    # the damping noise breaks it, not the stiffness noise (it was blamed before)
    ("systems/offset-parametric", ["parametric.damping=1e6"], "parametric.damping = 1e+06",
     "no metastable law either"),
    # no stationary law, and the crossover E ~ 0.09 lies inside the bulk: no metastable law
    ("systems/quintic", ["parametric.stiffness=0.01"], "parametric.stiffness = 0.01",
     "outgrows every loss beyond E ~ 0.0907"),
    ("systems/offset-parametric", ["parametric.stiffness=0.5"], "parametric.stiffness = 0.5",
     "no metastable law either"),
    # a free Duffing (no wall) with friction and D_k
    ("paper-base", ["system.r=1", "parametric.stiffness=0.05", "system.c2=0", "system.c1=-0.02",
                    "system.mu=0.05"], "parametric.stiffness = 0.05", "no metastable law"),
]


# the fast tier refuses three (one scan each, ~1-3 s); those whose blame needs a scan per
# intensity (offset-parametric, two keys) and the check run in the slow tier
FAST = (0, 1, 3)


@pytest.mark.parametrize("scene, sets, key, words, command",
                         [pytest.param(*c, "solve", marks=() if i in FAST else pytest.mark.slow)
                          for i, c in enumerate(CASES)]
                         + [pytest.param(*CASES[2], "check", marks=pytest.mark.slow)])
def test_a_law_the_solvers_cannot_hold_is_refused_before_work(capsys, scene, sets, key,
                                                              words, command):
    args = [command, scene, "--quiet"] if command == "check" else [command, scene]
    for s in sets:
        args += ["--set", s]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"vifpk: error: {key} is out of range")
    assert words in err[0] and "allowed: a smaller " + key.split(" =")[0] in err[0]
    assert "Traceback" not in err[0]


@pytest.mark.parametrize("call", [vifpk.solve, vifpk.check])
def test_the_python_api_refuses_them_alike(call):
    scene, sets, key, _ = CASES[0]
    with pytest.raises(BadInput, match=key):
        call(scene, set=sets)


@pytest.mark.parametrize("scene, values", [
    ("systems/offset-parametric", {}),  # metastable, the cut-off stated (E ~ 1.72e4)
    ("paper-base", {"parametric.stiffness": 0.02}),  # kappa = 3.4: falls by e^65
    ("paper-base", {"parametric.damping": 0.1}),  # kappa = 7/6 at every D_c, yet it falls
])
def test_laws_the_solvers_hold_stay_accepted(scene, values):
    from vifpk.harness.request.prepare import prepare_solve

    req = prepare_solve(vifpk.scene(scene, **values), model="exact")
    assert req.model == "exact"
