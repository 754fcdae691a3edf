"""Command line: ``vifpk solve SCENE --solver averaging|fpk|montecarlo ...`` and
``vifpk check SCENE [--out DIR]`` (the cross-check and its error report).

Exit codes: 0 success; 2 bad input (one line naming the field, no traceback, no output
file); 3 the solver could not produce a result (one line saying why); 130 interrupted.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Sequence
from typing import Any

from vifpk.harness.request import prepare as request
from vifpk.harness.request import validate

from vifpk.core import registry
from vifpk.core.defaults import BURN_FACTOR
from vifpk.core.scene import Scene

EXIT_INTERNAL = 1  # a bug: one line, the traceback under --debug
EXIT_BAD_INPUT = 2  # bad input: one line naming it, before any work, nothing written
EXIT_SOLVER = 3  # a solver could not produce a result (SolverFailure, mapped at the door)


SET_HELP = ("override a scene value, e.g. noise.D=0.02 (repeatable; default: none, the scene "
            "as written)")


QUIET_HELP = "no progress on the terminal (default: progress on stderr)"


class _Once(argparse._StoreAction):
    """A value option given twice is refused (the last would silently win), as ``--set``
    given twice for one key is."""

    def __call__(self, parser, namespace, values, option_string=None):  # type: ignore[override]
        seen = namespace.__dict__.setdefault("_given", {})
        if self.dest in seen:
            parser.error(f"{option_string} given twice ({seen[self.dest]} and {values}); give "
                         "it once")
        seen[self.dest] = values
        super().__call__(parser, namespace, values, option_string)


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.register("action", None, _Once)
        self.register("action", "store", _Once)

    def error(self, message: str) -> None:  # one line, exit 2
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: error: {message}\n")


def concrete_scene(path: str, overrides: Sequence[str]) -> Scene:
    """Load a scene, apply ``--set`` overrides; a sweep must be pinned to one value
    (request.concrete)."""
    return request.concrete(path, overrides)


def _mc_summary(info: dict[str, Any]) -> str:
    st = info["settings"]
    lines = [f"montecarlo: {info['status']['message']} ({st['paths']} paths, dt {st['dt']:g}, "
             f"time {st['time']:g} after burn-in {st['burn_in']:g}; effects {info['effects']})"]
    if "moments" in info:
        a = info["moments"]["A"]["mean"]
        lines.append(f"  amplitude A: mean {a['value']:.5g} +/- {a['err']:.2g} (batch error)")
    if info.get("L1_floor"):
        floors = ", ".join(f"{k} {v:.2g}" for k, v in info["L1_floor"].items())
        lines.append(f"  L1 noise floor: {floors}")
    if "events" in info:
        ev = info["events"]
        lines.append(
            f"  impacts per unit time {ev['impacts_per_time']['value']:.4g} +/- "
            f"{ev['impacts_per_time']['err']:.2g}; stuck fraction "
            f"{ev['stuck_fraction']['value']:.3g} +/- {ev['stuck_fraction']['err']:.2g}; "
            f"chatter-guard entries {ev['chatter_entries']}")
    conv = info.get("convergence", {})
    if conv.get("equilibrated") is not None:
        burn = f"burn-in {conv['burn_in']:g}"
        if "relaxation_time" in conv:
            burn += (f" = {BURN_FACTOR:g} x measured relaxation time "
                     f"{conv['relaxation_time']:.3g}")
        if conv["equilibrated"]:
            lines.append(f"  equilibrated: yes (R-hat {conv['rhat']:.4f} <= "
                         f"{conv['rhat_limit']:.4f}, drift {conv['drift_z']:+.1f} s.e., ESS "
                         f"{conv['ess']:.0f}; {burn})")
        else:
            lines.append(f"  NOT equilibrated: {conv['reason']} ({burn})")
    if conv.get("target_floor"):
        lines.append(f"  target floor {conv['target_floor']:g}: "
                     + ("reached" if conv["reached"] else "NOT reached")
                     + f" (floor {conv['floor']:.4g}; stopped: {conv['stopped']})")
    atom = info.get("atoms", {}).get("x2")
    if atom and atom["weight"] > 0:
        lines.append(f"  atom of p(x2) at v = 0 (mass at rest): weight {atom['weight']:.4g} "
                     f"+/- {atom['err']:.2g}, kept out of the x2 bins")
    sec = info["seconds"]
    lines.append(f"  time: compile {sec['compile']:.2f} s, run {sec['run']:.2f} s "
                 f"({info['steps_per_second'] / 1e6:.0f} M steps/s on {info['threads']} threads)")
    return "\n".join(lines)


def _fpk2d_summary(info: dict[str, Any]) -> str:
    """The original system's FPK in a few lines: the law's A, its error estimate, the walls'
    impact rates and the power balance."""
    s, g, e, d = (info["summary"], info["grid"], info["discretisation_error"],
                  info["diagnostics"])
    lines = [
        f"original-fpk: {info['status']['message']}",
        f"  amplitude A: mean {s['mean']:.6g}, mode {s['mode']:.6g}, std {s['std']:.6g}",
        f"  grid: {g['cells'][0]} x {g['cells'][1]} cells on x in [{g['x'][0]:.4g}, "
        f"{g['x'][1]:.4g}], v in [{g['v'][0]:.4g}, {g['v'][1]:.4g}] (E_max {g['E_max']:.4g})",
        f"  discretisation error (L1, Richardson, order {e['order']}): p(A) {e['L1_A']:.2g}, "
        f"p(x1) {e['L1_x1']:.2g}, p(x2) {e['L1_x2']:.2g} (asked {e['accuracy']:g})",
        *[f"  {w['side']} wall at {w['at']:g} ({w['law']}): {w['impacts_per_time']:.6g} "
          "impacts per unit time" for w in info["walls"]],
        f"  power balance: input {info['energy']['input']:.6g}, relative residual "
        f"{info['energy']['relative_residual']:.1e}; negative mass {d['negative_mass']:.1e}",
        f"  time: {info['seconds']['total']:.2f} s (CPU)",
    ]
    return "\n".join(lines)


def _summary(result: Any) -> str:
    info = result.info
    if info["solver"] == "montecarlo":
        return _mc_summary(info)
    if info["solver"] == "original-fpk":
        return _fpk2d_summary(info)
    s, d = info["summary"], info["diagnostics"]
    lines = [
        f"{info['solver']} ({info.get('model', '-')}): {info['status']['message']}",
        *([f"  method: {info['method']}"] if info.get("closed_form") is False else []),
        *([f"  period T(A): {info['period']}"] if str(info.get("period", "model")) != "model"
          else []),
        f"  amplitude A: mean {s['mean']:.6g}, mode {s['mode']:.6g}, std {s['std']:.6g}",
        f"  grid: {info['grid'].get('points', info['grid'].get('cells'))} points on "
        f"[{info['grid']['A_min']:.4g}, {info['grid']['A_max']:.4g}]",
        f"  mass check: {d['mass']:.12f} (mass outside grid {d['tail_mass']:.1e}), "
        f"min p = {d['min']:.3g}",
        f"  time: {info['seconds']['total'] * 1e3:.1f} ms",
    ]
    return "\n".join(lines)


def _provenance(args: argparse.Namespace) -> dict[str, Any]:
    """The provenance block of this run (vifpk/core/provenance.py)."""
    from vifpk.core import provenance

    scene = getattr(args, "scene", None)
    return provenance.collect(argv=getattr(args, "argv", None),
                              scene_path=provenance.scene_file(scene) if scene else None,
                              overrides=getattr(args, "set", []))


def _mc_given(args: argparse.Namespace) -> list[str]:
    """The Monte Carlo options given on the command line (names without dashes)."""
    return [k for k in validate.MC_OPTIONS if getattr(args, k, None) is not None]


def _mc_options(args: argparse.Namespace) -> dict[str, Any]:
    """The Monte Carlo options on the command line, by flag name (None: not given)."""
    return {k: getattr(args, k, None) for k in validate.MC_OPTIONS}


def _checked_scene(args: argparse.Namespace, *, mc: bool) -> Scene:
    """The concrete scene with the options applied, every check done (request.py)."""
    return request.with_mc_options(concrete_scene(args.scene, args.set), _mc_options(args),
                                   mc=mc)


def _add_tolerance_options(p: argparse.ArgumentParser) -> None:
    """The tolerance verdict's question (harness/workflows/tolerance.py; checked in cmd_check)."""
    from vifpk.harness.request.tolerance import METRICS, OBSERVABLES

    from vifpk.core.defaults import TOLERANCE, TOLERANCE_CONFIDENCE

    p.add_argument("--tolerance", type=float, default=TOLERANCE, metavar="T",
                   help="the largest averaging error accepted; each model is called inside / "
                        "outside / undecided and the recommendation follows it (default "
                        f"{TOLERANCE:g})")
    p.add_argument("--tolerance-metric", default="L1", metavar="METRIC",
                   help=f"the distance the tolerance is on, one of {', '.join(METRICS)} "
                        "(default L1)")
    p.add_argument("--tolerance-observable", default="A", metavar="OBS",
                   help=f"the density it is on, one of {', '.join(OBSERVABLES)} (default A)")
    p.add_argument("--confidence", type=float, default=TOLERANCE_CONFIDENCE, metavar="C",
                   help="the confidence of the inside/outside classes, in (0.5, 1) "
                        f"(default {TOLERANCE_CONFIDENCE:g})")


def add_scene(p: argparse.ArgumentParser) -> None:
    """The positional scene every scene command takes."""
    p.add_argument("scene", help="scene TOML file (or the name of a shipped scene)")


def add_set(p: argparse.ArgumentParser) -> None:
    """``--set SECTION.KEY=VALUE`` (repeatable)."""
    p.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help=SET_HELP)


def add_quiet(p: argparse.ArgumentParser) -> None:
    """``--quiet``: no progress on the terminal."""
    p.add_argument("--quiet", action="store_true", help=QUIET_HELP)


def _add_mc_options(p: argparse.ArgumentParser) -> None:
    add_mc_option(p, "paths", help="Monte Carlo: number of paths, a whole multiple of "
                  "montecarlo.blocks (default: the scene's montecarlo.paths)")
    add_mc_option(p, "dt", help='Monte Carlo: time step, or "auto" (the largest with bias '
                  "below half the target floor) (default: the scene's montecarlo.dt)")
    p.add_argument("--time", type=float, metavar="T",
                   help="Monte Carlo: simulated time sampled per path after the burn-in "
                        "(default: the scene's montecarlo.time)")
    add_mc_option(p, "seed", help="Monte Carlo: root seed (default: the scene's "
                  "montecarlo.seed)")
    p.add_argument("--floor", type=float, metavar="F",
                   help="Monte Carlo: simulate until the L1 noise floor of p(A) is at most F "
                        "(default: the scene's montecarlo.floor; 0: sample exactly --time)")
    p.add_argument("--budget", type=float, metavar="SECONDS",
                   help="Monte Carlo: wall seconds allowed to reach the floor, 0: no limit "
                        "(default: the scene's montecarlo.budget, 600 unless set)")
    p.add_argument("--yes", action="store_true",
                   help="run even when the estimated cost exceeds an hour (default: off)")


def _whole_number(text: str) -> int:
    """An option's whole number; "1e6" is accepted when it is whole (ranges: validate.py)."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and v == int(v)):
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number")
    return int(v)


def _dt_value(text: str) -> float | str:
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number or 'auto'") from None


#: the Monte Carlo options every command shares, declared once here (issue 38 item 1): the flag,
#: its type (the range is checked in harness/request/validate.py) and its metavar; the help is
#: each command's (``add_mc_option``'s ``help``), since what the option means differs
_MC_DECLARED: dict[str, dict[str, Any]] = {
    "paths": {"type": _whole_number, "metavar": "N"},
    "dt": {"type": _dt_value, "metavar": "H|auto"},
    "seed": {"type": _whole_number, "metavar": "S"},
}


def add_mc_option(p: argparse.ArgumentParser, name: str, *, help: str,
                  metavar: str | None = None) -> None:
    """``--<name>`` (paths, dt or seed) as declared in ``_MC_DECLARED``, with this command's
    help (and metavar, e.g. "H" where "auto" does not apply)."""
    d = _MC_DECLARED[name]
    p.add_argument(f"--{name}", type=d["type"], metavar=metavar or d["metavar"],
                   help=help)



def _model_name(text: str) -> str:
    """A registered averaged model (vifpk.core.registry); else one line listing them."""
    names = registry.model_names()
    if text not in names:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a registered model; registered: {', '.join(names)} "
            "(vifpk models lists them; docs/plugins.md adds one)")
    return text

