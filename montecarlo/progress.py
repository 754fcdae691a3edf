"""The Monte Carlo's progress bar: a tqdm bar in path-steps on stderr, quiet for short runs,
one plain line at a time when stderr is not a terminal (a log file, a pipe)."""

from __future__ import annotations

import sys
from typing import Any

#: seconds between two progress lines when stderr is not a terminal
PLAIN_PROGRESS_EVERY = 30.0


class Lines:
    """A stream for a progress bar that is not drawn on a terminal (a log file, a pipe): each
    redraw becomes one plain line, never a run of carriage returns; the bar's erasures (blank
    redraws) are dropped."""

    def __init__(self, stream: Any) -> None:
        self.stream = stream

    def write(self, text: str) -> None:
        for part in text.split("\r"):
            part = part.strip()
            if part:
                self.stream.write(part + "\n")

    def flush(self) -> None:
        self.stream.flush()


def progress_bar(enabled: bool, *, total: float = 1, desc: str = "monte carlo: pilot",
                 unit: str = " steps") -> Any:
    """A tqdm bar in path-steps (it shows the ETA); quiet for runs under 3 s. (tqdm's
    ``reset`` draws the bar at once, delay or not: a caller that knows its total gives it
    here.) On a terminal it redraws in place; elsewhere it writes a plain line every
    PLAIN_PROGRESS_EVERY seconds."""
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None
    try:
        tty = sys.stderr.isatty()
    except (AttributeError, ValueError):
        tty = False
    if tty:
        return tqdm(total=total, desc=desc, unit=unit, unit_scale=True, delay=3.0,
                    file=sys.stderr, leave=False)
    return tqdm(total=total, desc=desc, unit=unit, unit_scale=True, delay=3.0,
                file=Lines(sys.stderr), leave=False, ascii=True, ncols=100,
                mininterval=PLAIN_PROGRESS_EVERY)


def label(bar: Any, text: str) -> None:
    """Set the bar's description (no redraw); nothing without a bar."""
    if bar is not None:
        bar.set_description_str(text, refresh=False)
