"""Noise kinds and impact laws as declared, registered objects (issue 43, items 1 and 2).

Fast tests, no simulation: kinds and laws registered here by entry point as another
distribution would (tests/conftest.py ``register_physics``) are validated from their
declarations, a solver without its piece refuses the scene in one line naming kind or law and
solver before any work (command line: exit 2; API: BadInput), a plugin that does not import
leaves every other kind and command working, and a law that does not DECLARE a constant
restitution is never taken for Newton's by the averaged models.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vifpk.core.protocols import (
    ImpactLawSpec,
    NoiseKindSpec,
    Param,
    show,
)
from vifpk.physics.impact import newton
from vifpk.physics.noise import white

#: white noise's pieces under another name, without Monte Carlo pieces
AVG_ONLY = NoiseKindSpec(name="avgonly", summary="white noise, averaging pieces only",
                         params=white.KIND.params, averaging=white.KIND.averaging)
#: white noise's pieces under another name, without averaging pieces
MC_ONLY = NoiseKindSpec(name="mconly", summary="white noise, Monte Carlo pieces only",
                        params=white.KIND.params, montecarlo=white.KIND.montecarlo)


def _linear_e(v, r0, c, r_min):
    return np.maximum(r_min, r0 - c * np.abs(v))


def _linear_loss(v, r0, c, r_min):
    e = _linear_e(v, r0, c, r_min)
    return (1.0 - e * e) * (0.5 * v * v)


#: e(v) = max(r_min, r0 - c |v|): no yield speed, not constant (issue 43's silent wrong answer)
LINEAR = ImpactLawSpec(
    name="linear", summary="e = max(r_min, r0 - c |v|)",
    params=(Param(name="r0", default=0.9, low=0.0, high=1.0, doc="e at v = 0"),
            Param(name="c", low=0.0, low_closed=True, doc="slope of e in |v|"),
            Param(name="r_min", default=0.3, low=0.0, high=1.0, doc="e at high speed")),
    constant=False, restitution=_linear_e, energy_loss=_linear_loss,
    limit=lambda r0, c, r_min: r_min if c > 0 else r0)
#: a constant restitution under its own parameter name: DECLARED constant
FIXED = ImpactLawSpec(
    name="fixed", summary="e = e0", constant=True,
    params=(Param(name="e0", default=0.9, low=0.0, high=1.0, physical=False, doc="e"),),
    restitution=newton.restitution, energy_loss=newton.energy_loss, limit=newton.limit)
#: Newton's restitution without the averaged models' piece
NO_LOSS = ImpactLawSpec(name="noloss", summary="Newton without energy_loss", constant=True,
                        params=newton.LAW.params, restitution=newton.restitution,
                        energy_loss=None, limit=newton.limit)
#: not an ImpactLaw: no constant
BROKEN = object()


@pytest.fixture
def plugins(register_physics):
    for name in ("avgonly", "mconly"):
        register_physics("vifpk.noise_kinds", name, f"tests.test_physics_plugins:"
                                                     f"{name.upper().replace('ONLY', '_ONLY')}")
    register_physics("vifpk.noise_kinds", "nomodule", "no_such_module_xyz:KIND")
    for name in ("linear", "fixed"):
        register_physics("vifpk.impact_laws", name, f"tests.test_physics_plugins:{name.upper()}")
    register_physics("vifpk.impact_laws", "noloss", "tests.test_physics_plugins:NO_LOSS")
    register_physics("vifpk.impact_laws", "broken", "tests.test_physics_plugins:BROKEN")


def _main(args):
    from vifpk.harness.cli.app import main

    try:
        return main(args)
    except SystemExit as exc:
        return exc.code


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert "internal error" not in err[0] and "please report" not in err[0], err
    return err[0]


# ------------------------------------------------------------------ registry and declarations
def test_the_built_ins_are_registered_by_entry_point_as_any_package_s():
    from importlib import metadata

    from vifpk.core import registry

    for group, names in (("vifpk.noise_kinds", registry.noise_kind_names()),
                         ("vifpk.impact_laws", registry.impact_law_names())):
        eps = {ep.name: ep for ep in metadata.entry_points(group=group)}
        assert {"ou", "white"} <= set(names) or {"newton", "johnson"} <= set(names)
        for n in names:
            assert eps[n].dist.metadata["Name"] == "vifpk" or n not in ("ou", "white",
                                                                          "newton", "johnson")
    assert registry.impact_law_params()["johnson"] == ("r", "v_yield")
    assert registry.IMPACT_TREATMENTS == ("exact", "transformed", "compounded")


def test_params_say_their_range_in_words_and_numbers_as_written():
    r = newton.R
    assert r.allowed == "0 < r <= 1" and r.check(1.0) is None and r.check(0.0) == r.allowed
    assert r.check(True) == r.allowed and r.check(math.nan) == r.allowed
    assert Param(name="c", low=0.0, low_closed=True, doc="").allowed == "a finite number >= 0"
    assert Param(name="x", doc="").allowed == "a finite number"
    assert [show(v) for v in (1.0000001, -0.0, 0.5, 5e-324, 2.0)] == \
        ["1.0000001", "0", "0.5", "5e-324", "2"]


def test_a_plugin_s_keys_are_validated_from_its_declaration(plugins):
    from vifpk.core.scene import SceneError, scene_from_dict

    def bad(doc):
        with pytest.raises(SceneError) as e:
            scene_from_dict(doc, source="s.toml")
        assert "\n" not in str(e.value)
        return str(e.value)

    wall = {"lower_wall": {"at": 0.0, "law": "linear", "c": 0.5}}
    s = scene_from_dict({"system": wall})
    assert s.system.walls[0].values == {"r0": 0.9, "c": 0.5, "r_min": 0.3}
    assert s.to_dict()["system"]["lower_wall"] == {"at": 0.0, "law": "linear", "r0": 0.9,
                                                   "c": 0.5, "r_min": 0.3}
    assert bad({"system": {"lower_wall": {"at": 0.0, "law": "linear"}}}) == (
        "s.toml: system.lower_wall.c is missing: the linear law needs it (slope of e in |v|); "
        "allowed: a finite number >= 0")
    assert bad({"system": {"lower_wall": {**wall["lower_wall"], "r_mn": 0.2}}}).endswith(
        "system.lower_wall.r_mn: unknown key; did you mean 'r_min'?")
    assert bad({"system": {"lower_wall": {**wall["lower_wall"], "r0": 1.0000001}}}).endswith(
        "system.lower_wall.r0 = 1.0000001 is out of range; allowed: 0 < r0 <= 1")
    assert bad({"system": {"lower_wall": {**wall["lower_wall"], "v_yield": 1.0}}}).endswith(
        "system.lower_wall.v_yield applies to law = 'johnson' only, not 'linear'")
    assert "impact law must be one of" in bad({"system": {"lower_wall": {"at": 0.0,
                                                                         "law": "linaer"}}})
    assert "did you mean 'linear'?" in bad({"system": {"lower_wall": {"at": 0.0,
                                                                      "law": "linaer"}}})
    # the noise: keys of the kind, the other kinds' keys named as theirs
    assert scene_from_dict({"noise": {"kind": "mconly", "D": 0.02}}).noise.values == {"D": 0.02}
    assert bad({"noise": {"kind": "white", "alpha1": 2.0}}).endswith(
        "noise.alpha1: unknown key for kind = 'white'; it belongs to kind = 'ou', not 'white'")
    assert bad({"noise": {"kind": "ou", "Dd": 2.0}}).endswith("did you mean 'D'?")
    assert bad({"noise": {"kind": "ou", "D": 0.0}}).endswith(
        "noise.D = 0 is out of range; allowed: a finite number > 0")


def test_switching_kind_or_law_keeps_only_what_the_new_one_declares(base):
    white_ = base.with_values({"noise.kind": "white"})
    assert white_.noise.values == {"D": base.noise.D}
    j = base.with_values({"system.lower_wall.law": "johnson", "system.lower_wall.v_yield": 0.5})
    back = j.with_values({"system.lower_wall.law": "newton"})
    assert back.system.walls == base.system.walls and back.system.r == base.system.r


def test_a_plugin_that_does_not_import_names_itself_and_blocks_nothing(plugins, capsys):
    from vifpk.core import registry

    failures = registry.physics_failures()
    assert "nomodule" in failures["noise kind nomodule"]
    assert "is not a vifpk.core.protocols.ImpactLaw" in failures["impact law broken"]
    assert "nomodule" not in registry.noise_kind_names()
    assert _main(["solve", "paper-base", "--set", "noise.kind=nomodule"]) == 2
    line = _one_line(capsys)
    assert "noise kind 'nomodule'" in line and "did not load" in line and "someone" in line
    assert _main(["models"]) == 0


# ----------------------------------------------------------------- refusals before any work
@pytest.mark.parametrize("args, needles", [
    (["solve", "paper-base", "--solver", "montecarlo", "--set", "noise.kind=avgonly"],
     ("noise kind 'avgonly' (from someone) has no montecarlo pieces", "montecarlo solver")),
    (["check", "paper-base", "--set", "noise.kind=avgonly"],
     ("noise kind 'avgonly' (from someone) has no montecarlo pieces",)),
    (["solve", "paper-base", "--model", "exact", "--set", "noise.kind=mconly"],
     ("noise kind 'mconly' (from someone) has no averaging pieces", "averaging solver")),
    (["check", "paper-base", "--set", "noise.kind=mconly"],
     ("noise kind 'mconly' (from someone) has no averaging pieces",)),
    (["passage", "paper-base", "--threshold", "1.0", "--model", "exact", "--set",
      "noise.kind=mconly"], ("noise kind 'mconly'", "averaging solver")),
    (["solve", "paper-base", "--model", "exact", "--set", "system.lower_wall.law=noloss"],
     ("impact law 'noloss' (from someone) lacks the piece 'energy_loss'",
      "averaging solver cannot take it")),
])
def test_a_solver_without_its_piece_refuses_in_one_line_before_any_work(
        plugins, no_computation, capsys, args, needles):
    assert _main(args) == 2
    line = _one_line(capsys)
    assert all(n in line for n in needles), line


def test_the_api_refuses_with_bad_input(plugins, no_computation):
    import vifpk
    from vifpk.core.result import BadInput

    with pytest.raises(BadInput, match="'avgonly' .* no montecarlo pieces"):
        vifpk.solve(vifpk.scene("paper-base", **{"noise.kind": "avgonly"}), "montecarlo")
    with pytest.raises(BadInput, match="'mconly' .* no averaging pieces"):
        vifpk.solve(vifpk.scene("paper-base", **{"noise.kind": "mconly"}), model="exact")


# --------------------------------------------------------------- the law's declared constancy
def test_a_law_without_a_yield_speed_is_never_taken_for_newton_s(plugins, base):
    """The silent wrong answer of issue 43: averaging/walls.py decided "Newton" by
    v_yield == inf, so e = max(r_min, r0 - c|v|) at x = 0 took the paper's path with e = r0
    (the exact model bit-identical to Newton's r = r0). Now only a DECLARED constant law does:
    the linear law takes the general walls' path, whose loss per impact is the law's own."""
    from vifpk.averaging.exact import ExactModel
    from vifpk.averaging.walls import is_paper_wall, walls_of

    lin = base.with_values({"system.lower_wall.law": "linear", "system.lower_wall.c": 0.5,
                            "system.lower_wall.r0": 0.9})
    newt = base.with_values({"system.lower_wall.r": 0.9})
    assert not is_paper_wall(walls_of(lin.system)) and is_paper_wall(walls_of(newt.system))
    m_lin, m_newt = ExactModel.from_scene(lin), ExactModel.from_scene(newt)
    assert not m_lin.barrier and m_lin.walls[0].law == "linear" and m_newt.barrier
    A = np.array([0.5, 1.0, 1.5])
    # faster impacts lose more than Newton's r0 = 0.9 would take: a smaller drift
    assert np.all(m_lin.drift(A) < m_newt.drift(A))
    # a law DECLARED constant under another parameter name is the paper's wall, bit for bit
    fixed = base.with_values({"system.lower_wall.law": "fixed", "system.lower_wall.e0": 0.9})
    m_fix = ExactModel.from_scene(fixed)
    assert m_fix.barrier and m_fix.r == 0.9
    np.testing.assert_array_equal(m_fix.drift(A), m_newt.drift(A))
    np.testing.assert_array_equal(m_fix.diffusion(A), m_newt.diffusion(A))


#: white noise's declared object under a second name, as another package would register it
WHITE_TWIN = NoiseKindSpec(name="white2", summary="white noise, registered again",
                           params=white.KIND.params, averaging=white.KIND.averaging,
                           montecarlo=white.KIND.montecarlo)


@pytest.mark.slow
def test_a_kind_registered_under_a_second_name_gives_bit_identical_results(register_physics,
                                                                           base):
    """The registry adds nothing of its own: the built-in white noise's object registered by
    entry point as "white2" (another distribution's) gives the same bits in the exact model
    and in a Monte Carlo run (a new record class, the same compiled pieces)."""
    from vifpk.averaging.exact import ExactModel
    from vifpk.montecarlo.simulate import Settings, simulate

    register_physics("vifpk.noise_kinds", "white2", "tests.test_physics_plugins:WHITE_TWIN")
    one = base.with_values({"noise.kind": "white"})
    two = base.with_values({"noise.kind": "white2"})
    A = np.linspace(0.05, 2.0, 40)
    m1, m2 = ExactModel.from_scene(one), ExactModel.from_scene(two)
    np.testing.assert_array_equal(m1.drift(A), m2.drift(A))
    np.testing.assert_array_equal(m1.diffusion(A), m2.diffusion(A))
    st = Settings(paths=16, blocks=4, dt=0.01, time=20.0, burn_in=5.0, seed=11, bins=20,
                  threads=1, floor=0.0, budget=0.0, sample_every=0.5, progress=False,
                  certificate=False, observables=("A", "moments", "energy"))
    r1, r2 = simulate(one.system, one.noise, st), simulate(two.system, two.noise, st)
    assert r1.data.keys() == r2.data.keys()
    for key, d in r1.data.items():  # every array of every observable, bit for bit
        for name, v in (d.items() if isinstance(d, dict) else [(key, d)]):
            if isinstance(v, np.ndarray):
                np.testing.assert_array_equal(v, r2.data[key][name] if isinstance(d, dict)
                                              else r2.data[key], err_msg=f"{key}.{name}")
