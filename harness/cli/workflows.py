"""The built-in workflows (issue 27): each a vifpk.core.protocols.WorkflowSpec registered in
pyproject.toml's ``vifpk.workflows`` entry-point group, from which the command line builds its
subcommands (cli/app.py) and sweeps take their point functions (sweeps/points.py). A new
workflow is one module holding its spec plus one entry-point line (docs/plugins.md).
"""

from __future__ import annotations

import argparse

from vifpk.harness import testing
from vifpk.harness.cli import commands, timedomain
from vifpk.harness.cli.options import (
    _add_mc_options,
    _add_tolerance_options,
    _model_name,
    _whole_number,
    add_quiet,
    add_scene,
    add_set,
)
from vifpk.harness.sweeps import points

import vifpk.api as api
from vifpk.core.defaults import BIFURCATION_MODELS, CHECK_MODELS, FPK_CELLS
from vifpk.core.protocols import WorkflowSpec
from vifpk.core.registry import CLOSED_FORM, solver_names


def solve_arguments(p: argparse.ArgumentParser) -> None:
    """``vifpk solve``'s options."""
    add_scene(p)
    p.add_argument("--solver", choices=solver_names(), default=CLOSED_FORM,
                   help="averaging: closed form of an averaged model; fpk (or a registered "
                        "plugin's, docs/plugins.md): its Fokker-Planck equation; montecarlo: "
                        "the original system (default: %(default)s)")
    p.add_argument("--model", type=_model_name, metavar="NAME",
                   help="averaged model for --solver averaging|fpk: any registered one, "
                        "built-in or a plugin's (`vifpk models` lists them, docs/plugins.md; "
                        "default: paper)")
    p.add_argument("--json", metavar="OUT",
                   help="write the solution record to OUT (default: print a summary)")
    p.add_argument("--grid", type=_whole_number, metavar="N",
                   help=f"FPK: number of cells, >= 4 (default: {FPK_CELLS})")
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
    _add_mc_options(p)


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



SOLVE = WorkflowSpec(
    "solve", "solve one scene with one solver",
    add_arguments=solve_arguments, command=commands.cmd_solve, api=api.solve)
CHECK = WorkflowSpec(
    "check", "cross-check the averaged models (default: "
    f"{', '.join(CHECK_MODELS)}; outside the paper's family "
    "without paper) against the Monte Carlo of the original "
    "system and write an error report",
    add_arguments=check_arguments, command=commands.cmd_check,
    sweep_point=points.check_point, api=api.check, assertion=testing.assert_averaging_error)
BIFURCATION = WorkflowSpec(
    "bifurcation", "find the critical mu or r of the P-bifurcation of "
    "each averaged model and check it by Monte Carlo",
    add_arguments=bifurcation_arguments, command=commands.cmd_bifurcation,
    sweep_point=points.bifurcation_point)
FIGURES = WorkflowSpec(
    "figures", "redraw the paper's Figures 2-6: two averaged models "
    "(the paper's and the exact one) against the Monte "
    "Carlo of the original system",
    add_arguments=figures_arguments, command=commands.cmd_figures)
WORKPRECISION = WorkflowSpec(
    "workprecision", "what accuracy costs in time, for every solver",
    add_arguments=workprecision_arguments, command=commands.cmd_workprecision)
SWEEP = WorkflowSpec(
    "sweep", "run a workflow over a parameter grid (serial, process "
    "pool or dask) and write sweep.nc and maps",
    add_arguments=sweep_arguments, command=commands.cmd_sweep, api=api.sweep)
MODELS = WorkflowSpec(
    "models", "list the registered averaged models (built-in and "
    "plugins, docs/plugins.md)",
    add_arguments=models_arguments, command=commands.cmd_models)
PASSAGE = WorkflowSpec(
    "passage", "first passage out of A < Ac: reliability R(t), FPT density and MFPT of each "
    "averaged model against the original system",
    add_arguments=timedomain.passage_arguments, command=timedomain.cmd_passage,
    sweep_point=points.passage_point, api=api.passage, assertion=testing.assert_mfpt_close)
TRANSIENT = WorkflowSpec(
    "transient", "the law of the amplitude at given times from a start A0: each averaged model "
    "against the original system, and the relaxation times",
    add_arguments=timedomain.transient_arguments, command=timedomain.cmd_transient,
    sweep_point=points.transient_point, api=api.transient,
    assertion=testing.assert_relaxation_close)
AVERAGING = WorkflowSpec(
    "averaging", "the averaged models' closed forms only (sweeps; no subcommand: `vifpk solve "
    "--solver averaging` solves one scene)", sweep_point=points.averaging_point)
