"""The ``vifpk`` command: the parser of every subcommand and ``main``, which maps what a
command raises to an exit code.

Exit codes: 0 success; 1 internal error (a bug: one line, the traceback under ``--debug``);
2 bad input (one line naming the field, no traceback, no output file); 3 a solver could not
produce a result (one line saying why: SolverFailure, mapped at the door only); 130
interrupted.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from collections.abc import Sequence
from typing import Any

from vifpk.harness.cli.commands import (
    cmd_bifurcation,
    cmd_check,
    cmd_figures,
    cmd_models,
    cmd_solve,
    cmd_sweep,
    cmd_workprecision,
)
from vifpk.harness.cli.options import (
    EXIT_BAD_INPUT,
    EXIT_INTERNAL,
    EXIT_SOLVER,
    QUIET_HELP,
    SET_HELP,
    _add_mc_options,
    _add_tolerance_options,
    _model_name,
    _Parser,
    _whole_number,
)
from vifpk.harness.door.solvers import SolverFailure
from vifpk.harness.request import validate

from vifpk.core.defaults import BIFURCATION_MODELS, CHECK_MODELS, FPK_CELLS
from vifpk.core.guard import PluginError
from vifpk.core.registry import SOLVERS
from vifpk.core.result import BadInput


def build_parser() -> argparse.ArgumentParser:
    from vifpk.harness.outputs.provenance import vifpk_version
    from vifpk.harness.workflows.bifurcation import VARIABLES
    from vifpk.harness.workflows.figures import FIGURES

    p = _Parser(prog="vifpk", description="How wrong is a stochastic-averaging approximation?")
    p.add_argument("--version", action="version", version=f"vifpk {vifpk_version()}",
                   help="print the version and exit")
    p.add_argument("--debug", action="store_true",
                   help="on a failure, print the traceback (a solver's failure with its cause; "
                        "default: one line; also VIFPK_TRACEBACK=1)")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    s = sub.add_parser("solve", help="solve one scene with one solver")
    s.add_argument("scene", help="scene TOML file (or the name of a shipped scene)")
    s.add_argument("--solver", choices=SOLVERS, default="averaging",
                   help="averaging: closed form of an averaged model; fpk: its Fokker-Planck "
                        "equation; montecarlo: the original system (default: %(default)s)")
    s.add_argument("--model", type=_model_name, metavar="NAME",
                   help="averaged model for --solver averaging|fpk: any registered one, "
                        "built-in or a plugin's (`vifpk models` lists them, docs/plugins.md; "
                        "default: paper)")
    s.add_argument("--json", metavar="OUT",
                   help="write the solution record to OUT (default: print a summary)")
    s.add_argument("--grid", type=_whole_number, metavar="N",
                   help=f"FPK: number of cells, >= 4 (default: {FPK_CELLS})")
    _add_mc_options(s)
    s.add_argument("--joint", action="store_true",
                   help="include the joint PDF in the JSON (default: off)")
    s.add_argument("--allow-unequilibrated", action="store_true",
                   help="Monte Carlo: exit 0 with a warning when the equilibration "
                        "certificate's R-hat or drift fails (default: exit 3, the output "
                        "still written)")
    s.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help=SET_HELP)
    s.set_defaults(func=cmd_solve)
    c = sub.add_parser("check", help="cross-check the averaged models (default: "
                                     f"{', '.join(CHECK_MODELS)}; outside the paper's family "
                                     "without paper) against the Monte Carlo of the original "
                                     "system and write an error report")
    c.add_argument("scene", help="scene TOML file (or the name of a shipped scene)")
    c.add_argument("--out", metavar="DIR", help="report directory (default: out/<scene name>)")
    c.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help=SET_HELP)
    c.add_argument("--model", action="append", type=_model_name, metavar="NAME",
                   help="an averaged model to check, any registered one (repeat for several; "
                        f"default: {', '.join(CHECK_MODELS)})")
    c.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    _add_tolerance_options(c)
    _add_mc_options(c)
    c.set_defaults(func=cmd_check)
    b = sub.add_parser("bifurcation", help="find the critical mu or r of the P-bifurcation of "
                                           "each averaged model and check it by Monte Carlo")
    b.add_argument("scene", help="scene TOML file (or the name of a shipped scene)")
    b.add_argument("--vary", choices=tuple(VARIABLES), required=True,
                   help="the parameter to vary (required; the other one stays at the scene's "
                        "value, and the output names it)")
    b.add_argument("--range", nargs=2, type=float, metavar=("LO", "HI"),
                   help="search interval (default: mu 0 0.05, r 0.9 1)")
    b.add_argument("--model", action="append", type=_model_name, metavar="NAME",
                   help="an averaged model whose critical value to find, any registered one "
                        f"(repeat for several; default: {', '.join(BIFURCATION_MODELS)})")
    b.add_argument("--json", metavar="OUT", help="write the result as JSON (default: none)")
    b.add_argument("--no-mc", action="store_true",
                   help="skip the Monte Carlo check (default: run it on both sides)")
    b.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help=SET_HELP)
    b.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    _add_mc_options(b)
    b.set_defaults(func=cmd_bifurcation)
    f = sub.add_parser("figures", help="redraw the paper's Figures 2-6: two averaged models "
                                       "(the paper's and the exact one) against the Monte "
                                       "Carlo of the original system")
    f.add_argument("--out", default="out/figures", metavar="DIR",
                   help="directory for paper-fig*.png and figures.json/.md "
                        "(default: %(default)s)")
    f.add_argument("--figure", type=int, action="append", choices=tuple(FIGURES),
                   help="only this figure (repeatable; default: all of 2-6)")
    f.add_argument("--scene", metavar="SCENE",
                   help="instead of the paper's figures, draw the PDFs and the joint density "
                        "of this scene (any system; a list-valued parameter gives a row per "
                        "value): SCENE-pdfs.png, SCENE-joint.png "
                        "(default: none, the paper's Figures 2-6)")
    f.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    _add_mc_options(f)
    f.set_defaults(func=cmd_figures)
    w = sub.add_parser("workprecision", help="what accuracy costs in time, for every solver")
    w.add_argument("scene", help="scene TOML file (or the name of a shipped scene)")
    w.add_argument("--out", metavar="DIR",
                   help="directory for workprecision.png/.md/.json "
                        "(default: out/<scene>-workprecision)")
    w.add_argument("--quick", action="store_true",
                   help="short ladders, a smoke test (default: the full ladders)")
    w.add_argument("--repeats", type=_whole_number, default=3,
                   help="timed repeats after the warm-up, 1-100 (default: %(default)s)")
    w.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                   help=SET_HELP)
    w.add_argument("--quiet", action="store_true", help=QUIET_HELP)
    _add_mc_options(w)
    w.set_defaults(func=cmd_workprecision)
    sw = sub.add_parser("sweep", help="run a workflow over a parameter grid (serial, process "
                                      "pool or dask) and write sweep.nc and maps")
    sw.add_argument("sweep", help="sweep TOML file (or the name of a shipped sweep)")
    sw.add_argument("--executor", default="serial", metavar="E",
                    help="serial | processes:N | dask:N | tcp://HOST:PORT (default serial)")
    sw.add_argument("--out", metavar="DIR", help="output directory (default out/<sweep name>)")
    sw.add_argument("--quiet", action="store_true",
                    help="no progress lines on the terminal (default: one line a point)")
    sw.add_argument("--yes", action="store_true",
                    help="run even when the estimated cost exceeds an hour (default: off)")
    sw.set_defaults(func=cmd_sweep)
    from vifpk.harness.cli.timedomain import add_commands

    add_commands(sub, _model_name, SET_HELP, QUIET_HELP)
    ms = sub.add_parser("models", help="list the registered averaged models (built-in and "
                                       "plugins, docs/plugins.md)")
    ms.set_defaults(func=cmd_models)
    return p


def _first_warning(caught: list[Any]) -> str:
    """' (numpy: overflow encountered in multiply, averaging/paper.py:165)' or ''."""
    if not caught:
        return ""
    w = caught[0]
    where = "/".join(str(w.filename).split("/")[-2:])
    return f" (numpy: {w.message}, {where}:{w.lineno})"


def main(argv: Sequence[str] | None = None) -> int:
    """The ``vifpk`` command. Exit codes: 0, 1 internal error (a bug), 2 bad input, 3 a solver
    could not produce a result (SolverFailure, mapped at the door), 130 Ctrl-C.

    numpy RuntimeWarnings are caught (never printed): a run that then fails names the first
    one in its one-line message; a run whose results are finite drops them."""
    import warnings

    from vifpk.harness.outputs import signals

    parser = build_parser()
    from_command_line = argv is None  # the console script: Ctrl-C watchdog (not in-process)
    argv = sys.argv[1:] if argv is None else list(argv)
    if not argv:  # `vifpk` alone: the usage and the commands, exit 2
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    args = parser.parse_args(argv)
    debug = bool(getattr(args, "debug", False) or os.environ.get("VIFPK_TRACEBACK"))
    args.argv = ["vifpk", *(sys.argv[1:] if argv is None else argv)]
    try:
        validate.environment()
    except BadInput as exc:
        print(f"vifpk: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    signals.reset()
    if from_command_line:
        signals.install()
    caught: list[Any] = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", RuntimeWarning)
            code = int(args.func(args))
            sys.stdout.flush()  # a closed pipe shows here, not at exit
            return code
    except BadInput as exc:  # a scene field, an option, an output folder
        print(f"vifpk: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (SolverFailure, PluginError) as exc:  # PluginError: names the plugin and its file
        if debug:
            traceback.print_exception(exc)
        print(f"vifpk: {exc}{_first_warning(caught)}", file=sys.stderr)
        return EXIT_SOLVER
    except MemoryError:
        print("vifpk: out of memory: a grid, histogram or sample size is too large for this "
              "machine; reduce it (e.g. averaging.phase_points, montecarlo.bins, --grid)",
              file=sys.stderr)
        return EXIT_SOLVER
    except KeyboardInterrupt:  # Ctrl-C, or SIGTERM (signals.Terminated)
        signals.announce()
        return signals.exit_code()
    except BrokenPipeError:  # e.g. `vifpk solve ... | head -2`: the reader left
        _silence_stdout()
        return 141
    except OSError as exc:  # a full disk, a read-only or vanished folder, `> /dev/full`
        _silence_stdout()
        where = f" {exc.filename}" if exc.filename else " the standard output"
        print(f"vifpk: cannot write{where} ({exc.strerror or exc}); the run's output is "
              "incomplete", file=sys.stderr)
        return EXIT_SOLVER
    except Exception as exc:  # noqa: BLE001 - a bug: one line, the traceback under --debug
        if not from_command_line and not debug:
            raise  # in-process callers (the Python API, tests) get the exception itself
        if debug:
            traceback.print_exception(exc)
        tb = traceback.extract_tb(exc.__traceback__)[-1]
        where = "/".join(tb.filename.split("/")[-2:])
        text = str(exc).splitlines()[0][:300] if str(exc) else ""
        print(f"vifpk: internal error: {type(exc).__name__}: {text} ({where}:{tb.lineno})"
              f"{_first_warning(caught)}; please report it (vifpk --debug ... shows the "
              "traceback)", file=sys.stderr)
        return EXIT_INTERNAL


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush stays quiet."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


if __name__ == "__main__":
    sys.exit(main())
