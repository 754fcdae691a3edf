"""The keys a sweep file may vary or set: each named by its dataclass field (``key_field``), the
coefficients of a polynomial law, a wall table's keys, and the keys no sweep may touch."""

from __future__ import annotations

from dataclasses import fields
from typing import Any

from vifpk.harness.sweeps.errors import SweepError

from vifpk.core.scene import INDEXED, MAX_TERMS, SECTIONS, WALL_TABLES
from vifpk.core.walls import unknown_key, wall_keys

#: keys a sweep may not vary or set: the seed comes from the sweep's seed; a wall-clock
#: budget would make a point depend on the machine's speed
RESERVED = {"montecarlo.seed": "set the sweep's seed with the top-level key `seed`",
            "montecarlo.budget": "sweeps run without a wall-clock budget (a budget makes a "
                                 "point depend on the machine's speed); use montecarlo.floor"}


def key_field(where: str, path: str) -> Any:
    """The dataclass field named by ``section.key``, or a SweepError naming it."""
    import difflib

    from vifpk.harness.sweeps.timesweep import field_of

    if field_of(path) is not None:  # passage.threshold, ...: a workflow's parameter
        return field_of(path)
    section, _, key = path.partition(".")
    if section not in SECTIONS or not key:
        raise SweepError(f"{where} {path!r}: unknown key; use section.key with a section in "
                         f"{sorted(SECTIONS)}")
    known = _known(section)
    table, dot, sub = key.partition(".")
    if section == "system" and dot and table in WALL_TABLES:  # system.lower_wall.r, ...
        keys = wall_keys()
        if sub not in keys:
            hint = unknown_key("", sub, keys).split("; ", 1)[1]
            hint = (hint.replace("'", f"'system.{table}.", 1) if hint.startswith("did")
                    else "allowed: " + ", ".join(f"system.{table}.{k}" for k in keys))
            raise SweepError(f"{where} {path!r}: unknown key; {hint}")
        return WallKey() if sub == "law" else Coefficient()
    if section == "system" and key in WALL_TABLES:  # the table itself: its keys vary
        raise SweepError(f"{where} {path!r}: is a table (keys {', '.join(wall_keys())}), not a "
                         f"value; vary or set one of its keys, e.g. {path}.at")
    m = INDEXED.fullmatch(key) if section == "system" else None
    if m and m.group(1) in known and known[m.group(1)].type.startswith("tuple"):
        if int(m.group(2)) >= MAX_TERMS:
            raise SweepError(f"{where} {path!r}: index out of range; allowed: 0 to "
                             f"{MAX_TERMS - 1}")
        return Coefficient()  # one coefficient of a polynomial law: a number
    if key not in known:
        close = difflib.get_close_matches(key, list(known), n=1, cutoff=0.5)
        hint = f"did you mean '{section}.{close[0]}'?" if close else \
            "allowed: " + ", ".join(f"{section}.{k}" for k in known)
        raise SweepError(f"{where} {path!r}: unknown key; {hint}")
    if path in RESERVED:
        raise SweepError(f"{where} {path!r}: not allowed in a sweep; {RESERVED[path]}")
    return known[key]


def _known(section: str) -> dict[str, Any]:
    """The fields of a section by name; ``noise``: every registered kind's declared
    parameters (and ``kind``), as harness.request.validate.fields_of gives them."""
    if section != "noise":
        return {f.name: f for f in fields(SECTIONS[section])}
    from vifpk.core.sections import noise_fields

    return {"kind": WallKey(), **noise_fields()}


class Coefficient:
    """Stands for the field of one coefficient of a law ("system.restoring[2]")."""

    type = "float"


class WallKey:
    """Stands for a wall's impact law ("system.lower_wall.law"): a name."""

    type = "str"
