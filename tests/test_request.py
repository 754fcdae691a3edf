"""One request through one door (issue 27): the Python API refuses what the command line
refuses, with the same one-line message, before any work; the step follows the floor by one
rule that knows which fields were given; models say themselves where they apply."""

from __future__ import annotations

from pathlib import Path

import pytest
from vifpk.harness.cli.app import build_parser, main
from vifpk.harness.request import prepare as request

import vifpk
from tests.test_cli_validation import CATALOGUE, _materialise
from vifpk.core import registry
from vifpk.core.result import BadInput

# what a command-line case needs that the API does not have (files it writes, the terminal)
CLI_ONLY = ("--json", "--out", "--joint", "--quiet", "--yes", "--budget")


def _api_call(args: list[str]):
    """The API call equivalent to a ``solve``/``check`` command line: the command's own
    parser reads the values (the front ends differ only there), the API gets them as
    keywords."""
    ns = build_parser().parse_args(args)
    mc = {k: getattr(ns, k) for k in request.MC_OPTIONS if getattr(ns, k, None) is not None}
    if args[0] == "solve":
        kw = {k: v for k, v in (("model", ns.model), ("grid", ns.grid)) if v is not None}
        return lambda: vifpk.solve(ns.scene, ns.solver, set=list(ns.set), **kw, **mc)
    models = {"models": tuple(ns.model)} if ns.model else {}
    return lambda: vifpk.check(ns.scene, set=list(ns.set), **models, **mc)


# the command line's cost guard (refuse a run estimated over an hour unless --yes) is the one
# check the API leaves to its caller (docs/api.md): a script decides what it can afford
COST_GUARD = ("or add --yes", "estimated at least", "--yes", ": estimated")
API_CASES = [c for c in CATALOGUE if c[1][0] in ("solve", "check")
             and not any(a in CLI_ONLY for a in c[1]) and not any(
                 n in c[2] for n in COST_GUARD)]


def test_the_catalogue_has_api_cases():
    assert len(API_CASES) >= 30  # most solve/check cases need no file output


@pytest.mark.parametrize("case", API_CASES, ids=[c[0] for c in API_CASES])
def test_the_api_refuses_what_the_command_line_refuses_in_the_same_words(
        no_computation, tmp_path, capsys, case):
    args, needle = _materialise(case, tmp_path)
    try:
        call = _api_call(args)
    except SystemExit:  # refused by the parser itself (a type): the API has no such step
        pytest.skip("refused by argparse, before any request")
    assert main(args) == 2
    cli_line = capsys.readouterr().err.strip()
    with pytest.raises(BadInput) as exc:
        call()
    assert needle in str(exc.value)
    assert str(exc.value) in cli_line, (str(exc.value), cli_line)


# ----------------------------------------------------------------- the issue's reproducers
@pytest.mark.parametrize("call, needle", [
    (lambda: vifpk.solve("paper-base", "montecarlo", paths=33), "nearest valid: 64"),
    (lambda: vifpk.solve("paper-base", model="exact", paths=64, time=50),
     "--paths, --time: does not apply to --solver averaging"),
    (lambda: vifpk.check("paper-base", out=123), "out 123: not a folder path"),
    (lambda: vifpk.check("paper-base", models=()), "no model given"),
    (lambda: vifpk.check("paper-base", models="exact"), "give a list of model names"),
    (lambda: vifpk.check("systems/quintic", models=("paper",)),
     "--model paper: does not apply to this scene: system.restoring has a x^5 term"),
    (lambda: vifpk.solve(vifpk.scene("paper-fig2")), "noise.D varies over"),
    (lambda: vifpk.scene(42), "scene 42: not a scene"),
    (lambda: vifpk.check(None), "scene None: not a scene"),
    (lambda: vifpk.solve("paper-base", "fpk", grid=3), "--grid 3: out of range"),
    (lambda: vifpk.solve("paper-base", modle="exact"), "modle: not an option of solve"),
    (lambda: vifpk.solve("paper-base", out="x.json"), "out: not an option of solve"),
    (lambda: vifpk.solve("paper-base", "averaging", grid=100), "--grid: does not apply"),
    (lambda: vifpk.solve("paper-base", "oracle"), "--solver 'oracle': not a solver"),
    (lambda: vifpk.solve("paper-base", "montecarlo", paths=64.5), "--paths 64.5: not a whole"),
    (lambda: vifpk.solve("paper-base", "montecarlo", paths=int(1e12)), "memory"),
])
def test_api_reproducers_of_issues_27_and_28(no_computation, call, needle):
    with pytest.raises(BadInput, match=None) as exc:
        call()
    assert needle in str(exc.value)


def test_check_model_paper_outside_its_family_exits_2_in_one_line(no_computation, capsys):
    assert main(["check", "systems/quintic", "--model", "paper"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--model paper: does not apply to this scene" in err
    assert main(["check", "paper-base", "--model", "paper",
                 "--set", "system.restoring[2]=0.5"]) == 2


def test_a_paths_keyword_reaches_the_monte_carlo_as_paths(monkeypatch):
    """Issue 27: ``solve(..., "montecarlo", paths=64)`` raised KeyError 'edges_A' (the keyword
    reached the door as a histogram edge). Now it is a Monte Carlo option of the request."""
    seen = {}

    def door(scene, solver, **kw):
        seen.update(paths=scene.montecarlo.paths, solver=solver, kw=kw)
        return "ran"

    monkeypatch.setattr("vifpk.harness.door.solvers.run_solver", door)
    assert vifpk.solve("paper-base", "montecarlo", paths=64) == "ran"
    assert seen == {"paths": 64, "solver": "montecarlo", "kw": {"progress": False}}


# ------------------------------------------------------------------ the step and the floor
def test_scene_knows_which_fields_were_given(tmp_path: Path):
    f = tmp_path / "s.toml"
    f.write_text("[montecarlo]\ndt = 0.005\nfloor = 0.01\n")
    sc = vifpk.scene(str(f))
    assert {"montecarlo.dt", "montecarlo.floor"} <= sc.given
    assert "montecarlo.dt" not in vifpk.scene("paper-base").given
    assert "system.restoring" in vifpk.scene("paper-base").with_values(
        {"system.restoring[2]": 0.1}).given


def test_a_step_not_given_is_auto_and_a_given_one_stays(tmp_path: Path):
    """Issue 44: MonteCarloSettings.dt defaults to "auto" (the step from the accuracy asked
    for); a step in the scene file stays as written, with or without a floor."""
    f = tmp_path / "s.toml"
    f.write_text("[montecarlo]\ndt = 0.005\nfloor = 0.01\n")
    assert vifpk.scene(str(f)).montecarlo.dt == 0.005
    assert vifpk.scene("paper-base").montecarlo.dt == "auto"
    assert vifpk.scene("paper-base", **{"montecarlo.floor": 0.01}).montecarlo.dt == "auto"


# ------------------------------------------------------------------- where a model applies
def test_models_say_where_they_apply():
    quintic, base = vifpk.scene("systems/quintic"), vifpk.scene("paper-base")
    assert registry.model_applies("paper", base) is None
    assert "x^5" in registry.model_applies("paper", quintic)
    assert registry.model_applies("exact", quintic) is None
    kept, refused = registry.applicable(quintic, ("paper", "exact", "paper"))
    assert kept == ("exact",) and set(refused) == {"paper"}


def test_a_factory_without_applies_applies_everywhere_and_one_with_it_is_asked():
    def plain(scene):
        return scene

    def picky(scene):
        return scene

    picky.applies = lambda scene: "never"
    assert registry.applicability_of(plain) is None
    assert registry.applicability_of(picky)(None) == "never"


# ------------------------------------------------------------------- shared words, once each
def test_an_energy_only_run_is_accepted():
    """Issue 27: validate's copy of the observable names omitted `energy`, so a run recording
    only the power balance was refused; the check now reads the schema's own list."""
    from vifpk.harness.request import validate

    off = {f"observables.{k}": False for k in ("A", "x1", "x2", "moments", "events")}
    validate.observables(vifpk.scene("paper-base", **off, **{"observables.energy": True}))
    with pytest.raises(BadInput, match="observables.energy"):
        validate.observables(vifpk.scene("paper-base", **off))


def test_the_f_0_rule_has_one_wording_everywhere(no_computation, capsys, tmp_path):
    from vifpk.core.scene import no_noise

    scene = tmp_path / "quiet.toml"
    scene.write_text("[system]\nf = 0.0\n")
    said = no_noise(vifpk.scene(str(scene)).system)
    assert said and no_noise(vifpk.scene("paper-base").system) is None
    assert main(["check", str(scene), "--out", str(tmp_path / "o")]) == 3
    assert said in capsys.readouterr().err


def test_the_door_says_the_f_0_rule_in_its_words(tmp_path):
    from vifpk.harness.door.solvers import SolverFailure, montecarlo_solution

    from vifpk.core.scene import no_noise

    scene = tmp_path / "quiet.toml"
    scene.write_text("[system]\nf = 0.0\n")
    sc = vifpk.scene(str(scene))
    with pytest.raises(SolverFailure) as exc:
        montecarlo_solution(sc)
    assert str(exc.value) == no_noise(sc.system)


@pytest.mark.parametrize("call, needle", [
    (lambda: vifpk.check("paper-base", tolerance=-1), "--tolerance must be a number > 0"),
    (lambda: vifpk.check("paper-base", tolerance_metric="L7"), "--tolerance-metric must be"),
    (lambda: vifpk.check("paper-base", confidence=1.5), "--confidence must be between"),
])
def test_the_api_takes_the_tolerance_question_and_refuses_it_like_the_command(
        no_computation, capsys, call, needle):
    with pytest.raises(BadInput) as exc:
        call()
    assert needle in str(exc.value)
    flag = needle.split()[0]
    value = {"--tolerance": "-1", "--tolerance-metric": "L7", "--confidence": "1.5"}[flag]
    assert main(["check", "paper-base", flag, value]) == 2
    assert str(exc.value) in capsys.readouterr().err


def test_the_api_check_passes_its_tolerance_to_the_check(canned_check, monkeypatch):
    import vifpk.harness.workflows.check

    seen = {}
    real = vifpk.harness.workflows.check.cross_check

    def spy(scene, **kw):
        seen.update(kw)
        return real(scene, **kw)

    monkeypatch.setattr(vifpk.harness.workflows.check, "cross_check", spy)
    vifpk.check("paper-base", tolerance=0.05, confidence=0.9)
    assert seen["tolerance"].value == 0.05 and seen["tolerance"].confidence == 0.9
