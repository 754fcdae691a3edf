"""The built-in workflows' command-line options: one argparse builder each, named by the
workflow's record (``add_arguments``, a vifpk.core.protocols.Ref; the records are
harness/workflows/specs.py and the ``SPEC`` of check.py, bifurcation.py, figures.py and
workprecision.py), from which cli/app.py builds the subcommands. (The time domain's are
cli/timedomain.py.)
"""

from __future__ import annotations

import argparse

from vifpk.harness.cli.options import (
    _add_mc_options,
    _add_tolerance_options,
    _model_name,
    _whole_number,
    add_mc_option,
    add_quiet,
    add_scene,
    add_set,
)

from vifpk.core.defaults import BIFURCATION_MODELS, CHECK_MODELS, FPK_CELLS
from vifpk.core.registry import CLOSED_FORM, solver_names


def solve_arguments(p: argparse.ArgumentParser) -> None:
    """``vifpk solve``'s options."""
    add_scene(p)
    p.add_argument("--solver", choices=solver_names(), default=CLOSED_FORM,
                   help="averaging: closed form of an averaged model; fpk (or a registered "
                        "plugin's, docs/plugins.md): its Fokker-Planck equation; montecarlo: "
                        "the original system; original-fpk: the original system's own FPK "
                        "in (x, v), white noise (default: %(default)s)")
    p.add_argument("--model", type=_model_name, metavar="NAME",
                   help="averaged model for --solver averaging|fpk: any registered one, "
                        "built-in or a plugin's (`vifpk models` lists them, docs/plugins.md; "
                        "default: paper)")
    p.add_argument("--json", metavar="OUT",
                   help="write the solution record to OUT (default: print a summary)")
    p.add_argument("--grid", type=_whole_number, metavar="N",
                   help=f"FPK: number of cells, >= 4 (default: {FPK_CELLS}); original-fpk: "
                        "cells per axis (default: from the accuracy, docs/fpk2d.md)")
    _add_mc_options(p)
    p.add_argument("--joint", action="store_true",
                   help="include the joint PDF in the JSON (default: off)")
    p.add_argument("--allow-unequilibrated", action="store_true",
                   help="Monte Carlo: exit 0 with a warning when the equilibration "
                        "certificate's R-hat or drift fails (default: exit 3, the output "
                        "still written)")
    add_set(p)


def check_arguments(p: argparse.ArgumentParser) -> None:
    """``vifpk check``'s options."""
    add_scene(p)
    p.add_argument("--out", metavar="DIR", help="report directory (default: out/<scene name>)")
    add_set(p)
    p.add_argument("--model", action="append", type=_model_name, metavar="NAME",
                   help="an averaged model to check, any registered one (repeat for several; "
                        f"default: {', '.join(CHECK_MODELS)})")
    add_quiet(p)
    _add_tolerance_options(p)
    _add_mc_options(p)


def bifurcation_arguments(p: argparse.ArgumentParser) -> None:
    """``vifpk bifurcation``'s options."""
    from vifpk.harness.workflows.bifurcation import VARIABLES

    add_scene(p)
    p.add_argument("--vary", choices=tuple(VARIABLES), required=True,
                   help="the parameter to vary (required; the other one stays at the scene's "
                        "value, and the output names it)")
    p.add_argument("--range", nargs=2, type=float, metavar=("LO", "HI"),
                   help="search interval (default: mu 0 0.05, r 0.9 1)")
    p.add_argument("--model", action="append", type=_model_name, metavar="NAME",
                   help="an averaged model whose critical value to find, any registered one "
                        f"(repeat for several; default: {', '.join(BIFURCATION_MODELS)})")
    p.add_argument("--json", metavar="OUT", help="write the result as JSON (default: none)")
    p.add_argument("--no-mc", action="store_true",
                   help="skip the Monte Carlo check (default: run it on both sides)")
    add_set(p)
    add_quiet(p)
    _add_mc_options(p)


def figures_arguments(p: argparse.ArgumentParser) -> None:
    """``vifpk figures``'s options."""
    from vifpk.harness.workflows.figures import FIGURES

    p.add_argument("--out", default="out/figures", metavar="DIR",
                   help="directory for paper-fig*.png and figures.json/.md "
                        "(default: %(default)s)")
    p.add_argument("--figure", type=int, action="append", choices=tuple(FIGURES),
                   help="only this figure (repeatable; default: all of 2-6)")
    p.add_argument("--scene", metavar="SCENE",
                   help="instead of the paper's figures, draw the PDFs and the joint density "
                        "of this scene (any system; a list-valued parameter gives a row per "
                        "value): SCENE-pdfs.png, SCENE-joint.png "
                        "(default: none, the paper's Figures 2-6)")
    add_quiet(p)
    _add_mc_options(p)


def workprecision_arguments(p: argparse.ArgumentParser) -> None:
    """``vifpk workprecision``'s options."""
    add_scene(p)
    p.add_argument("--out", metavar="DIR",
                   help="directory for workprecision.png/.md/.json "
                        "(default: out/<scene>-workprecision)")
    p.add_argument("--quick", action="store_true",
                   help="short ladders, a smoke test (default: the full ladders)")
    p.add_argument("--repeats", type=_whole_number, default=3,
                   help="timed repeats after the warm-up, 1-100 (default: %(default)s)")
    add_set(p)
    add_quiet(p)
    # its ladders set the paths and the time, and time fixed steps: only these Monte Carlo
    # options apply (-h listed all of them, issue 45); the others stay parsed, not listed,
    # and are refused in one line (commands.cmd_workprecision)
    add_mc_option(p, "dt", metavar="H", help="Monte Carlo: time step of the ladders "
                  "(default: the scene's montecarlo.dt)")
    add_mc_option(p, "seed", help="Monte Carlo: root seed (default: the scene's "
                  "montecarlo.seed)")
    add_mc_option(p, "paths", help=argparse.SUPPRESS)
    for name in ("time", "floor", "budget"):
        p.add_argument(f"--{name}", type=float, help=argparse.SUPPRESS)
    p.add_argument("--yes", action="store_true",
                   help="run even when the estimated cost exceeds an hour (default: off)")


def sweep_arguments(p: argparse.ArgumentParser) -> None:
    """``vifpk sweep``'s options."""
    p.add_argument("sweep", help="sweep TOML file (or the name of a shipped sweep)")
    p.add_argument("--executor", default="serial", metavar="E",
                    help="serial | processes:N | dask:N | tcp://HOST:PORT (default serial)")
    p.add_argument("--out", metavar="DIR", help="output directory (default out/<sweep name>)")
    p.add_argument("--quiet", action="store_true",
                    help="no progress lines on the terminal (default: one line a point)")
    p.add_argument("--yes", action="store_true",
                    help="run even when the estimated cost exceeds an hour (default: off)")


def models_arguments(p: argparse.ArgumentParser) -> None:
    """``vifpk models`` takes no options."""
