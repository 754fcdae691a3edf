"""Run the solvers a scene asks for. The only place that knows every solver package."""

from __future__ import annotations

from typing import Any

SOLVERS = ("averaging",)


class SolverFailure(RuntimeError):
    """A solver could not produce a trustworthy result; the message says why (one line)."""


def run_solver(scene: Any, solver: str, *, model: str = "paper", **options: Any) -> Any:
    """Run one solver on a concrete scene and return its Result(data, info)."""
    import averaging

    if solver == "averaging":
        try:
            return averaging.solve(scene, model=model, **options)
        except averaging.NoStationaryDensity as exc:
            raise SolverFailure(str(exc)) from None
    raise ValueError(f"solver must be one of {SOLVERS}, not {solver!r}")


def solution_record(scene: Any, solver: str, model: str | None, result: Any, *,
                    joint: bool = False) -> dict[str, Any]:
    """The public JSON contract of ``vifpk solve``::

        {"scene": {...}, "solver": ..., "model": ..., "pdf": {"A": {"x", "p"[, "edges", "err"]},
         "x1": {...}, "x2": {...}[, "E", "joint"]}, "info": {...}}
    """
    pdf = {k: v for k, v in result.data.items() if joint or k != "joint"}
    rec: dict[str, Any] = {"scene": scene.to_dict(), "solver": solver}
    if model is not None:
        rec["model"] = model
    rec["pdf"] = pdf
    rec["info"] = result.info
    return rec
