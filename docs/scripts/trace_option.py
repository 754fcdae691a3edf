"""Trace one command-line value through vifpk's modules (issue 38 item 5): run a command
in-process under ``sys.setprofile`` and list, in call order, every module of ours whose
function receives the value (as an argument or local, or inside one: a scene's
``montecarlo.dt``, a request's ``threshold``, a dict, a tuple) or returns it.

    python docs/scripts/trace_option.py check --dt 0.00390625 -- tests/data/tiny.toml \
        --set montecarlo.budget=0.001 --out /tmp/trace-check
    python docs/scripts/trace_option.py passage --threshold 0.777777 -- paper-base \
        --paths 64 --horizon 20 --no-fpk --json --out /tmp/trace-passage

It prints the modules in the order the value first reaches them (a module that receives the
whole scene counts, whether it reads the value or not), their number, each call chain from
the command to a solver function that holds the value as a plain number, and every
*return* of the value from a module into another one (the value going back up), with the
function that returned it. The numba kernels run no Python frame: the last module before
them is the one that calls the kernel (they are named by hand in docs/architecture.md).
"""

from __future__ import annotations

import dataclasses
import sys
from typing import Any

SOLVERS = ("vifpk.montecarlo", "vifpk.fpk", "vifpk.averaging")
SEEN_LIMIT = 4  # depth of the search inside a local (scene -> montecarlo -> dt is 2)


def holds(obj: Any, value: float, depth: int = SEEN_LIMIT, seen: set[int] | None = None) -> bool:
    """Whether ``obj`` is ``value`` or holds it a few attributes/items deep."""
    seen = set() if seen is None else seen
    if isinstance(obj, float):
        return obj == value
    if isinstance(obj, str):
        return obj == repr(value) or obj.endswith(f"={value!r}") or obj == f"{value}"
    if depth == 0 or id(obj) in seen or isinstance(obj, (int, bool, bytes, type)) or obj is None:
        return False
    seen.add(id(obj))
    if isinstance(obj, dict):
        items = list(obj.values())[:64]
    elif isinstance(obj, (list, tuple, set, frozenset)):
        items = list(obj)[:64]
    elif dataclasses.is_dataclass(obj):
        items = [getattr(obj, f.name, None) for f in dataclasses.fields(obj)]
    elif hasattr(obj, "__dict__") and type(obj).__module__.startswith("vifpk") or \
            type(obj).__name__ == "Namespace":
        items = list(vars(obj).values())[:64]
    else:
        return False
    return any(holds(x, value, depth - 1, seen) for x in items)


def main(argv: list[str]) -> int:
    command, option, raw = argv[0], argv[1], argv[2]
    rest = argv[argv.index("--") + 1:]
    value = float(raw)
    order: list[str] = []
    returns: list[str] = []
    chains: list[tuple[str, ...]] = []

    def profile(frame: Any, event: str, arg: Any) -> None:
        name = frame.f_globals.get("__name__", "")
        if not name.startswith("vifpk") or event not in ("call", "return"):
            return
        if event == "call":
            if name not in order and any(holds(v, value) for v in frame.f_locals.values()):
                order.append(name)
            if name.startswith(SOLVERS) and any(isinstance(v, float) and v == value
                                                for v in frame.f_locals.values()):
                chain, f = [], frame
                while f is not None:
                    m = f.f_globals.get("__name__", "")
                    if m.startswith("vifpk") and (not chain or chain[-1] != m):
                        chain.append(m)
                    f = f.f_back
                if tuple(reversed(chain)) not in chains:
                    chains.append(tuple(reversed(chain)))
        elif arg is not None and holds(arg, value):
            caller = frame.f_back.f_globals.get("__name__", "") if frame.f_back else ""
            if caller.startswith("vifpk") and caller != name:
                line = f"{name}.{frame.f_code.co_name} -> {caller}"
                if line not in returns:
                    returns.append(line)

    from vifpk.harness.cli.app import main as vifpk

    sys.setprofile(profile)
    try:
        code = vifpk([command, *rest[:1], option, raw, *rest[1:]])
    finally:
        sys.setprofile(None)
    print(f"exit {code}; {option} {raw} reached {len(order)} modules:")
    for i, m in enumerate(order, 1):
        print(f"  {i:2d}. {m}")
    print("call chains down to a solver function holding it as a plain number:")
    for c in chains:
        print(f"  {len(c)} modules ({len(set(c))} distinct): " + " > ".join(
            m.removeprefix("vifpk.") for m in c))
    print(f"returned from one module into another ({len(returns)}):")
    for r in returns:
        print(f"  {r}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
