"""Dotted field paths ("system.restoring[2]", "system.c2"): which law and coefficient a key
sets, and which two keys reach the same coefficient (the one rule for --set and sweeps)."""

from __future__ import annotations

import re
from collections.abc import Sequence

from .system import ALIASES

INDEXED = re.compile(r"(\w+)\[(\d+)\]")


def _field_of(path: str) -> str:
    """"section.key" of a dotted path, without a law index ("system.restoring[2]" ->
    "system.restoring")."""
    section, _, key = path.partition(".")
    m = INDEXED.fullmatch(key)
    return f"{section}.{m.group(1) if m else key}"


def law_term(key: str) -> tuple[str, int | None] | None:
    """The law and coefficient that ``system.NAME`` sets: ("damping", 1) for ``system.c2``
    and ``system.damping[1]``, ("restoring", None) for the whole ``system.restoring``; None
    for a key that sets no law."""
    section, _, name = key.strip().partition(".")
    if section != "system":
        return None
    m = INDEXED.fullmatch(name)
    if name in ALIASES:
        return ALIASES[name][0], ALIASES[name][1]
    if m:
        return m.group(1), int(m.group(2))
    laws = {law for law, _, _ in ALIASES.values()} | {"velocity_damping"}
    return (name, None) if name in laws else None


def shared_term(keys: Sequence[str]) -> tuple[str, str, str] | None:
    """The first two of ``keys`` that reach one coefficient of a law under different
    spellings (``system.c2`` and ``system.damping[1]``; a whole law and any of its terms):
    (the earlier key, the later key, the law), or None. The one rule for ``--set`` and for
    a sweep's [vary] and [set] (a scene file refuses both spellings the same way)."""
    reach: dict[tuple[str, int | None], str] = {}
    for key in keys:
        target = law_term(key)
        if target is None:
            continue
        law, index = target
        for (lw, ix), earlier in reach.items():
            if lw == law and (ix is None or index is None or ix == index):
                return earlier, key, law
        reach[target] = key
    return None
