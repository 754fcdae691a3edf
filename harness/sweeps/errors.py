"""The errors of a sweep: bad sweep files (``SweepError``, exit 2) and lost workers."""

from __future__ import annotations

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
