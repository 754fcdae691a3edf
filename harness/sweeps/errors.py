"""The errors of a sweep: bad sweep files (``SweepError``, exit 2), lost workers, and a sweep
over its time (``OverTime``; ``check_rate`` projects a run's wall time from its measured rate)."""

from __future__ import annotations

from pathlib import Path

from vifpk.core.scene import SceneError


class SweepError(SceneError):
    """A sweep file or executor that cannot be used; one line naming the key (exit 2)."""


class WorkerLost(RuntimeError):
    """The executor lost points (not a numerical failure): the finished records are kept and
    the same command resumes the sweep."""


class OverTime(SceneError):
    """A sweep whose measured rate puts it over the time allowed without ``--yes`` (exit 2,
    like the estimate's refusal): the finished records are kept, and the same command with
    ``--yes`` computes the rest."""


def check_rate(elapsed: float, computed: int, remaining: int, *, workers: int,
               limit: float | None, out: Path) -> None:
    """Stop a sweep whose measured rate puts it over ``limit`` seconds (OverTime, one line).

    The projection is elapsed + elapsed / computed x remaining: the wall time a point has taken
    in this run, parallelism included, for every point still to compute. It is made once at
    least max(3, workers) points have finished (before, a pool's first completions say little
    about its rate) and at every point after, so a rate that worsens is caught too."""
    if limit is None or computed < max(3, workers) or remaining <= 0:
        return
    projected = elapsed + elapsed / computed * remaining
    if projected > limit:
        raise OverTime(f"this sweep: {computed} points took {_duration(elapsed)}, "
                       f"{_duration(elapsed / computed)} a point, so the {remaining} left "
                       f"would bring it to {_duration(projected)}, over the "
                       f"{_duration(limit)} allowed without --yes (the estimate before the "
                       f"run is a lower bound); the finished points are kept in {out}/points: "
                       "run the same command with --yes to compute the rest")


def _duration(s: float) -> str:
    if s < 90:
        return f"{s:.0f} s"
    if s < 5400:
        return f"{s / 60:.1f} min"
    return f"{s / 3600:.1f} h"
