"""The ``vifpk`` command: the parser of every subcommand and ``main``, which maps what a
command raises to an exit code.

Exit codes: 0 success; 1 internal error (a bug: one line, the traceback under ``--debug``);
2 bad input (one line naming the field, no traceback, no output file); 3 a solver could not
produce a result (one line saying why: SolverFailure, mapped at the door only); 130
interrupted.
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from collections.abc import Callable, Sequence
from typing import Any

from vifpk.harness.cli.options import (
    EXIT_BAD_INPUT,
    EXIT_INTERNAL,
    EXIT_SOLVER,
    _Parser,
)
from vifpk.harness.door.solvers import SolverFailure
from vifpk.harness.request import validate

from vifpk.core import registry
from vifpk.core.guard import PluginError, describe, source_of
from vifpk.core.result import BadInput

#: The order ``vifpk --help`` lists vifpk's own subcommands in (the registry gives them by
#: name, the same in every install); any other workflow follows, in registry order.
ORDER = ("solve", "check", "bifurcation", "figures", "workprecision", "sweep", "passage",
         "transient", "models")


def build_parser() -> argparse.ArgumentParser:
    from vifpk.core.provenance import vifpk_version

    p = _Parser(prog="vifpk", description="How wrong is a stochastic-averaging approximation?")
    p.add_argument("--version", action="version", version=f"vifpk {vifpk_version()}",
                   help="print the version and exit")
    p.add_argument("--debug", action="store_true",
                   help="on a failure, print the traceback (a solver's failure with its cause; "
                        "default: one line; also VIFPK_TRACEBACK=1)")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    rank = {name: i for i, name in enumerate(ORDER)}
    listed = sorted(registry.workflows(), key=lambda w: rank.get(w.name, len(ORDER)))
    broken = registry.workflow_failures()
    for w in listed:  # the vifpk.workflows entry points, vifpk's own in ORDER (stable sort)
        if w.command is None:
            continue
        sp = sub.add_parser(w.name, help=w.summary)
        entry = registry.workflow_entry(w.name)
        if entry is None or entry.builtin:
            w.add_arguments(sp)
            sp.set_defaults(func=w.command)
            continue
        label = f"workflow {w.name!r} ({entry.value}, from {entry.distribution})"
        source = source_of(entry.value.partition(":")[0])
        try:  # another distribution's options must not break vifpk's commands (W04, W05)
            w.add_arguments(sp)
        except (KeyboardInterrupt, GeneratorExit):
            raise
        except BaseException as exc:  # noqa: BLE001 - the plugin's, named as such
            broken[w.name] = f"{label}: its add_arguments {describe(exc, source)}"
            continue
        sp.set_defaults(func=_plugin_command(w.command, label, source))
    for name in broken:
        if name not in sub.choices:
            sub.add_parser(name, help="(a plugin that does not load; vifpk NAME says why)")
    p.set_defaults(broken_workflows=broken)
    return p


def _plugin_command(fn: Callable[[Any], Any], label: str, source: str | None
                    ) -> Callable[[Any], int]:
    """Another distribution's workflow command, its failures named as its own (issue 39,
    W06-W09): what it raises (but BadInput, a door's SolverFailure or PluginError, an OSError
    of a write, Ctrl-C) is a PluginError naming it; it must return an exit code, a whole
    number 0-255 (``sys.exit(256)`` would exit 0), or call ``sys.exit`` with one."""

    def run(args: Any) -> int:
        try:
            code = fn(args)
        except (KeyboardInterrupt, GeneratorExit, BadInput, SolverFailure, PluginError,
                MemoryError, OSError):
            raise
        except SystemExit as exc:
            code = 0 if exc.code is None else exc.code
        except BaseException as exc:  # noqa: BLE001 - the plugin's, named as such
            raise PluginError(f"{label}: its command {describe(exc, source)}") from exc
        if isinstance(code, bool) or not isinstance(code, int) or not 0 <= code <= 255:
            raise PluginError(f"{label}: its command returned {code!r}; it must return an "
                              "exit code, a whole number 0-255")
        return code

    return run


def main(argv: Sequence[str] | None = None, *,
         release_guard: Callable[[], None] | None = None) -> int:
    """The ``vifpk`` command. Exit codes: 0, 1 internal error (a bug), 2 bad input, 3 a solver
    could not produce a result (SolverFailure, mapped at the door), 130 Ctrl-C.

    numpy RuntimeWarnings are caught (never printed) and counted (harness/outputs/runwarnings.py,
    handed to the command as ``args.run_warnings``): a run that then fails names the first one
    in its one-line message; a run that writes metrics.json stores them there
    (``runtime_warnings``)."""
    from vifpk.harness.outputs import signals
    from vifpk.harness.outputs.runwarnings import RunWarnings

    from_command_line = argv is None  # the console script: Ctrl-C watchdog (not in-process)
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv == ["--version"]:  # before the parser: it imports every workflow plugin, and one
        from vifpk.core.provenance import vifpk_version  # whose import hangs hung --version

        print(f"vifpk {vifpk_version()}")
        return 0
    try:
        parser = build_parser()
    except PluginError as exc:  # a registered workflow that does not load: one line, exit 3
        print(f"vifpk: {exc}", file=sys.stderr)
        return EXIT_SOLVER
    if not argv:  # `vifpk` alone: the usage and the commands, exit 2
        parser.print_help(sys.stderr)
        return EXIT_BAD_INPUT
    broken = parser.get_default("broken_workflows") or {}
    command = next((a for a in argv if not a.startswith("-")), None)
    if command in broken:  # a plugin workflow that did not load, asked for: one line, exit 3
        print(f"vifpk: {broken[command]}", file=sys.stderr)
        return EXIT_SOLVER
    args = parser.parse_args(argv)
    debug = bool(getattr(args, "debug", False) or os.environ.get("VIFPK_TRACEBACK"))
    args.argv = ["vifpk", *argv]  # argv is the list of arguments by now, never None
    try:
        validate.environment()
    except BadInput as exc:
        print(f"vifpk: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    signals.reset()
    if from_command_line:
        if release_guard is not None:  # the console script's import-time guard ends here
            release_guard()
        signals.install()
    tally = args.run_warnings = RunWarnings()
    try:
        with tally.recording():
            code = int(args.func(args))
            sys.stdout.flush()  # a closed pipe shows here, not at exit
            return code
    except BadInput as exc:  # a scene field, an option, an output folder
        print(f"vifpk: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (SolverFailure, PluginError) as exc:  # PluginError: names the plugin and its file
        if debug:
            traceback.print_exception(exc)
        print(f"vifpk: {exc}{tally.first()}", file=sys.stderr)
        return EXIT_SOLVER
    except MemoryError:
        print("vifpk: out of memory: a grid, histogram or sample size is too large for this "
              "machine; reduce it (e.g. averaging.phase_points, montecarlo.bins, --grid)",
              file=sys.stderr)
        return EXIT_SOLVER
    except KeyboardInterrupt:  # Ctrl-C, or SIGTERM (signals.Terminated)
        signals.announce()
        return signals.exit_code()
    except BrokenPipeError:  # e.g. `vifpk solve ... | head -2`: the reader left
        _silence_stdout()
        return 141
    except OSError as exc:  # a full disk, a read-only or vanished folder, `> /dev/full`
        _silence_stdout()
        where = f" {exc.filename}" if exc.filename else " the standard output"
        print(f"vifpk: cannot write{where} ({exc.strerror or exc}); the run's output is "
              "incomplete", file=sys.stderr)
        return EXIT_SOLVER
    except Exception as exc:  # noqa: BLE001 - a bug: one line, the traceback under --debug
        if not from_command_line and not debug:
            raise  # in-process callers (the Python API, tests) get the exception itself
        if debug:
            traceback.print_exception(exc)
        tb = traceback.extract_tb(exc.__traceback__)[-1]
        where = "/".join(tb.filename.split("/")[-2:])
        text = str(exc).splitlines()[0][:300] if str(exc) else ""
        print(f"vifpk: internal error: {type(exc).__name__}: {text} ({where}:{tb.lineno})"
              f"{tally.first()}; please report it (vifpk --debug ... shows the "
              "traceback)", file=sys.stderr)
        return EXIT_INTERNAL


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush stays quiet."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):
        pass


if __name__ == "__main__":
    sys.exit(main())
