"""The public Python API's functions (docs/api.md); ``import vifpk`` exposes them lazily.

Each takes a scene as a :class:`~vifpk.core.scene.Scene`, a path to a scene file or the name of
a shipped scene, and does what the command of the same name does, without the command line:
no cost guard, no output unless asked.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from vifpk.core.defaults import CHECK_MODELS
from vifpk.core.scene import Scene, load_scene


def scene(source: Scene | str | Path, **values: Any) -> Scene:
    """A scene from a Scene, a file or a shipped scene's name, with ``values`` set by their
    dotted names (``scene("paper-base", **{"noise.D": 0.02})``); validated like a file."""
    sc = source if isinstance(source, Scene) else load_scene(source)
    return sc.with_values(values) if values else sc


def solve(source: Scene | str | Path, solver: str = "averaging", *, model: Any = "paper",
          grid: int | None = None, **options: Any) -> Any:
    """One solver on one scene (``vifpk solve``): ``Result(data, info)``.

    ``solver``: "averaging" (the model's closed form, or the FPK direct solve of a model with
    none), "fpk" (``grid`` cells) or "montecarlo" (the original system; ``model`` and
    ``grid`` do not apply). ``model``: a registered name (:func:`model_names`) or an object
    with the averaged-model protocol (docs/testing.md)."""
    from vifpk.harness.run import run_solver

    sc = scene(source)
    if solver == "montecarlo":
        return run_solver(sc, "montecarlo", progress=options.pop("progress", False), **options)
    return run_solver(sc, solver, model=model, grid=grid, **options)


def check(source: Scene | str | Path, *, models: tuple[str, ...] = CHECK_MODELS,
          out: str | Path | None = None, quiet: bool = True) -> Any:
    """The cross-check (``vifpk check``): a ``CheckResult`` with ``metrics``, ``verdicts``,
    ``warnings``; with ``out``, the report folder is written there as well."""
    from vifpk.harness.check import cross_check

    res = cross_check(scene(source), quiet=quiet, models=tuple(models))
    if out is not None:
        from vifpk.harness.report import write_report

        write_report(res, out)
    return res


def sweep(path: str | Path, out: str | Path, *, executor: str = "serial",
          quiet: bool = True) -> Any:
    """A sweep file run into the folder ``out`` (``vifpk sweep``): a ``SweepRun`` naming the
    points computed, skipped and failed and the files written (sweep.nc, maps)."""
    from vifpk.harness.sweep import load_sweep, parse_executor, require_output_libraries, run_sweep

    sw = load_sweep(path)
    require_output_libraries()
    return run_sweep(sw, out, executor=parse_executor(executor), quiet=quiet)
