"""Round 7b of docs/edges.md: hostile cases on walls, parametric noise and the typed
time-domain requests (issue 39 item 6). Each case runs the command line (``vifpk ...``) or a
Python snippet in a subprocess, in an empty working folder, with a timeout, and records the
exit code, the first line of stderr, whether anything was written and the wall time.

    NUMBA_NUM_THREADS=1 python docs/scripts/hostile7.py [--only H001,H002] [--md FILE]

Expected behaviour per case: ``refuse`` (exit 2, one line holding the given words, nothing
written, under a few seconds: before any work) or ``run`` (exit 0, and the given files
written). Verdicts: handled (as expected), partly (exit 2 but the line lacks the words, or something
was written, or a traceback; or exit 3 in one line after the work where a refusal was due),
not (anything else).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

VIFPK = str(Path(sys.executable).with_name("vifpk"))

HEAD = """name = "h7"
[system]
restoring = [1.0, 0.5]
damping = [0.01]
mu = 0.0
f = 1.0
{sys}
[noise]
kind = "white"
D = 0.005
{rest}
"""
TWO = "[system.lower_wall]\nat = -0.6\nr = 0.97\n[system.upper_wall]\nat = 0.6\nr = 0.97\n"
LOW = "[system.lower_wall]\nat = -0.3\nr = 0.95\n"


def lower(body: str) -> str:
    """A scene whose lower wall table is ``body``."""
    return HEAD.format(sys="[system.lower_wall]\n" + body, rest="")


def upper(body: str) -> str:
    return HEAD.format(sys="[system.lower_wall]\nat = -0.6\n[system.upper_wall]\n" + body,
                       rest="")


def param(body: str) -> str:
    return HEAD.format(sys=LOW, rest="[parametric]\n" + body)


@dataclass(frozen=True)
class Case:
    id: str
    what: str                       # the command as the table shows it
    argv: tuple[str, ...] = ()      # vifpk's arguments ({S}: the scene, {O}: the out folder)
    scene: str | None = None        # a scene file's text written to {S}
    py: str | None = None           # a Python snippet instead of argv
    files: dict = field(default_factory=dict)  # extra files: name -> text ({S} usable)
    expect: str = "refuse"          # refuse | run
    words: tuple[str, ...] = ()     # words the first stderr line must hold (refuse)
    makes: tuple[str, ...] = ()     # files a run must write under {O}


PY = """
import sys, traceback
try:
    import vifpk
    from vifpk.core.result import BadInput
{body}
except BadInput as e:
    print(str(e).splitlines()[0] if str(e) else type(e).__name__, file=sys.stderr); sys.exit(2)
except SystemExit:
    raise
except BaseException as e:
    print(f"{{type(e).__name__}}: {{e}}".splitlines()[0], file=sys.stderr)
    traceback.print_exc(); sys.exit(1)
"""

BD = "systems/bilateral-duffing"
OP = "systems/offset-parametric"
SOLVE = ("solve", "{S}", "--model", "exact")
NOP = ("--set", "parametric.stiffness=0")  # bilateral-duffing without its parametric noise
PAS = ("passage", BD, "--paths", "64", "--quiet") + NOP
C: list[Case] = []


def add(*cases: Case) -> None:
    C.extend(cases)


def k(n: list[int]) -> str:
    n[0] += 1
    return f"H{n[0]:03d}"


def build() -> list[Case]:
    n = [0]
    # 1. the lower wall's keys in a scene file
    for v, w in [("nan", "finite"), ("inf", "finite"), ("-inf", "finite"), ('"-0.3"', "finite"),
                 ("true", "finite"), ("[-0.3]", "finite"), ("0.2", "<= 0"), ("1e300", "<= 0"),
                 ("-1e300", "energy")]:
        add(Case(k(n), f"solve S (lower_wall.at = {v})", SOLVE, lower(f"at = {v}\n"),
                 expect="refuse", words=("lower_wall.at", w)))
    for v, w in [("0", "0 < r <= 1"), ("-0.5", "0 < r <= 1"), ("1.5", "0 < r <= 1"),
                 ("nan", "finite"), ('"0.9"', "finite"), ("true", "finite")]:
        add(Case(k(n), f"solve S (lower_wall.r = {v})", SOLVE, lower(f"at = -0.3\nr = {v}\n"),
                 words=("lower_wall.r", w)))
    for v in ('"Newton"', '"hertz"', "3", '""', '["newton"]'):
        add(Case(k(n), f"solve S (lower_wall.law = {v})", SOLVE,
                 lower(f"at = -0.3\nlaw = {v}\n"), words=("lower_wall.law", "one of")))
    for v, w in [("0", "> 0"), ("-1", "> 0"), ("inf", "finite"), ("nan", "finite"),
                 ('"1"', "finite"), ("true", "finite"), ("[1]", "finite")]:
        add(Case(k(n), f"solve S (johnson, v_yield = {v})", SOLVE,
                 lower(f'at = -0.3\nlaw = "johnson"\nv_yield = {v}\n'),
                 words=("v_yield", w)))
    add(Case(k(n), "solve S (johnson without v_yield)", SOLVE,
             lower('at = -0.3\nlaw = "johnson"\n'), words=("v_yield", "missing")),
        Case(k(n), "solve S (newton with v_yield = 0.5)", SOLVE,
             lower('at = -0.3\nv_yield = 0.5\n'), words=("v_yield", "johnson")),
        Case(k(n), "solve S (lower_wall.at = -1e-300: the paper's wall, in effect)", SOLVE,
             lower("at = -1e-300\n"), expect="run"),
        Case(k(n), "solve S (lower_wall.r = 1e-300: a plastic wall)", SOLVE,
             lower("at = -0.3\nr = 1e-300\n"), expect="run"),
        Case(k(n), "solve S (johnson, v_yield = 1e300: Newton's limit)", SOLVE,
             lower('at = -0.3\nlaw = "johnson"\nv_yield = 1e300\n'), expect="run"),
        Case(k(n), "solve S (lower_wall with an unknown key rr)", SOLVE,
             lower("at = -0.3\nrr = 0.9\n"), words=("rr", "unknown")),
        Case(k(n), "solve S (lower_wall without at)", SOLVE, lower("r = 0.9\n"),
             words=("at", "missing")),
        Case(k(n), "solve S (system.lower_wall = 3)", SOLVE,
             HEAD.format(sys="lower_wall = 3", rest=""), words=("lower_wall", "table")),
        Case(k(n), "solve S (system.lower_wall = [-0.3, 0.9])", SOLVE,
             HEAD.format(sys="lower_wall = [-0.3, 0.9]", rest=""),
             words=("lower_wall", "table")),
        Case(k(n), "solve S ([system.middle_wall] at = 0)", SOLVE,
             HEAD.format(sys="[system.middle_wall]\nat = 0.0\n", rest=""),
             words=("middle_wall",)),
        Case(k(n), "solve S (an empty [system.lower_wall])", SOLVE, lower(""),
             words=("at", "missing")))
    # 2. the upper wall and the pair
    for v, w in [("-0.2", ">= 0"), ("nan", "finite"), ("-inf", "finite"), ("false", "finite")]:
        add(Case(k(n), f"solve S (upper_wall.at = {v})", SOLVE, upper(f"at = {v}\n"),
                 words=("upper_wall.at", w)))
    add(Case(k(n), "solve S (lower at 0, upper at 0)", SOLVE,
             HEAD.format(sys="[system.lower_wall]\nat = 0.0\n[system.upper_wall]\nat = 0.0\n",
                         rest=""), words=("no room",)),
        Case(k(n), "solve S (lower at -0.0, upper at 0.0)", SOLVE,
             HEAD.format(sys="[system.lower_wall]\nat = -0.0\n[system.upper_wall]\nat = 0.0\n",
                         rest=""), words=("no room",)),
        Case(k(n), "solve S (walls at -1e-12 and 1e-12)", SOLVE,
             HEAD.format(sys="[system.lower_wall]\nat = -1e-12\n[system.upper_wall]\n"
                             "at = 1e-12\n", rest=""), expect="run"),
        Case(k(n), "solve S (upper wall only, at 0.5)", SOLVE,
             HEAD.format(sys="[system.upper_wall]\nat = 0.5\nr = 0.9\n", rest=""),
             expect="run"),
        Case(k(n), "solve S (wall table and r = 0.9)", SOLVE,
             HEAD.format(sys="r = 0.9\n" + LOW, rest=""), words=("both set the walls",)),
        Case(k(n), "solve S (wall table and barrier = true)", SOLVE,
             HEAD.format(sys="barrier = true\n" + LOW, rest=""), words=("both",)),
        Case(k(n), "solve S (upper wall table and barrier = false)", SOLVE,
             HEAD.format(sys="barrier = false\n[system.upper_wall]\nat = 0.5\n", rest=""),
             words=("both",)),
        Case(k(n), "solve S (two walls, johnson both, r = 1)", SOLVE,
             HEAD.format(sys='[system.lower_wall]\nat = -0.6\nlaw = "johnson"\nv_yield = 0.3\n'
                             '[system.upper_wall]\nat = 0.6\nlaw = "johnson"\nv_yield = 0.3\n',
                         rest=""), expect="run"))
    # 3. parametric noise in a scene file
    for v, w in [("nan", ">= 0"), ("inf", ">= 0"), ("-0.1", ">= 0"), ('"0.1"', "number"),
                 ("true", "number"), ("[0.1]", "stiffness")]:
        add(Case(k(n), f"solve S (parametric.stiffness = {v})", SOLVE,
                 param(f"stiffness = {v}\n"), words=("parametric.stiffness", w)))
    for v, w in [("-1", ">= 0"), ("nan", ">= 0"), ("1e300", "damping")]:
        add(Case(k(n), f"solve S (parametric.damping = {v})", SOLVE,
                 param(f"damping = {v}\n"), words=("parametric.damping", w)))
    add(Case(k(n), "solve S (parametric.stiffness = 1e300)", SOLVE, param("stiffness = 1e300\n"),
             words=("parametric.stiffness",)),
        Case(k(n), "solve S ([parametric] foo = 1)", SOLVE, param("foo = 1\n"),
             words=("parametric", "foo")),
        Case(k(n), "solve S (parametric = 0.1, not a table)", SOLVE,
             HEAD.format(sys=LOW, rest="").replace('name = "h7"', 'name = "h7"\nparametric = 0.1'),
             words=("parametric",)),
        Case(k(n), "solve S ([parametric] stiffness = 0, damping = 0: off)", SOLVE,
             param("stiffness = 0\ndamping = 0\n"), expect="run"),
        Case(k(n), "solve paper-base --set parametric.stiffness=0.002 --model paper",
             ("solve", "paper-base", "--model", "paper", "--set", "parametric.stiffness=0.002"),
             words=("paper",)))
    # 4. --set on the command line
    for v, w in [("nan", "finite"), ("inf", "finite"), ("abc", "finite"), ("0.3", "<= 0"),
                 ("true", "finite"), ("[1]", "finite"), ("", "lower_wall.at"),
                 ("-1e100", "energy")]:
        add(Case(k(n), f"solve {BD} --set system.lower_wall.at={v}",
                 ("solve", BD, "--model", "exact", "--set", f"system.lower_wall.at={v}"),
                 words=("lower_wall.at", w)))
    for kv, w in [("system.r=0.9", ("system.r",)), ("system.barrier=false", ("barrier",)),
                  ("system.lower_wall.v_yield=1", ("v_yield", "johnson")),
                  ("system.lower_wall.law=johnson", ("v_yield",)),
                  ("system.lower_wall=3", ("lower_wall",)),
                  ("system.lower_wall.foo=1", ("foo",)),
                  ("system.middle_wall.at=1", ("middle_wall",)),
                  ("system.upper_wall.at=-0.1", ("upper_wall.at", ">= 0")),
                  ("system.upper_wall.r=0", ("upper_wall.r", "0 < r <= 1")),
                  ("parametric.stiffness=-1", ("parametric.stiffness", ">= 0")),
                  ("parametric.stiffness=nan", ("parametric.stiffness",)),
                  ("parametric.stiffness=abc", ("parametric.stiffness",)),
                  ("parametric.foo=1", ("parametric.foo",)),
                  ("parametric=1", ("parametric",))]:
        add(Case(k(n), f"solve {BD} --set {kv}", ("solve", BD, "--model", "exact", "--set", kv),
                 words=w))
    add(Case(k(n), "solve paper-base --set system.upper_wall.at=0.5 (model exact)",
             ("solve", "paper-base", "--model", "exact", "--set", "system.upper_wall.at=0.5"),
             expect="run"),
        Case(k(n), "solve paper-base --set system.lower_wall.at=-0.2 --model paper",
             ("solve", "paper-base", "--model", "paper", "--set", "system.lower_wall.at=-0.2"),
             words=("paper",)),
        Case(k(n), "solve paper-base --set system.lower_wall.r=0.9 (no at: the paper's wall)",
             ("solve", "paper-base", "--model", "exact", "--set", "system.lower_wall.r=0.9"),
             expect="run"),
        Case(k(n), f"solve {BD} --set system.lower_wall.at=0 --set system.upper_wall.at=0",
             ("solve", BD, "--model", "exact", "--set", "system.lower_wall.at=0",
              "--set", "system.upper_wall.at=0"), words=("no room",)),
        Case(k(n), "solve paper-base --set system.r=0.9 --set system.lower_wall.at=-0.1",
             ("solve", "paper-base", "--model", "exact", "--set", "system.r=0.9",
              "--set", "system.lower_wall.at=-0.1"), expect="run"),
        Case(k(n), "solve paper-base --set system.barrier=false --set system.lower_wall.at=-0.1",
             ("solve", "paper-base", "--model", "exact", "--set", "system.barrier=false",
              "--set", "system.lower_wall.at=-0.1"), expect="run"))
    # 5. solvers and models that cannot take the physics
    add(Case(k(n), f"solve {BD} --model paper", ("solve", BD, "--model", "paper"),
             words=("paper",)),
        Case(k(n), f"solve {OP} --solver fpk --model paper",
             ("solve", OP, "--solver", "fpk", "--model", "paper"), words=("paper",)),
        Case(k(n), f"check {BD} --model paper --paths 64 --out O",
             ("check", BD, "--model", "paper", "--paths", "64", "--out", "{O}"),
             words=("paper",)),
        Case(k(n), f"passage {BD} --model paper --threshold 0.5",
             PAS + ("--model", "paper", "--threshold", "0.5"), words=("paper",)),
        Case(k(n), f"transient {OP} --model paper --start 0.2 --times 1,2,3",
             ("transient", OP, "--model", "paper", "--start", "0.2", "--times", "1,2,3", "--set",
              "parametric.stiffness=0", "--set", "parametric.damping=0"),
             words=("paper",)),
        Case(k(n), f"bifurcation {BD} --vary r --no-mc (r is no key of a wall-table scene)",
             ("bifurcation", BD, "--vary", "r", "--no-mc", "--quiet"), words=("--vary r",)),
        Case(k(n), "bifurcation paper-base --set system.barrier=false --vary r --no-mc",
             ("bifurcation", "paper-base", "--set", "system.barrier=false", "--vary", "r",
              "--no-mc", "--quiet"), words=("--vary r",)),
        Case(k(n), f"bifurcation {BD} --vary mu --no-mc --model paper",
             ("bifurcation", BD, "--vary", "mu", "--no-mc", "--model", "paper"),
             words=("paper",)),
        Case(k(n), f"solve {BD} --model corrected", ("solve", BD, "--model", "corrected"),
             expect="run"),
        Case(k(n), f"solve {OP} --model corrected", ("solve", OP, "--model", "corrected"),
             expect="run"))
    # 6. passage and transient on the new physics
    for opt, w in [(("--threshold", "nan"), ("threshold",)),
                   (("--threshold", "-1"), ("threshold",)),
                   (("--threshold", "0"), ("threshold",)),
                   (("--threshold", "inf"), ("threshold",)),
                   (("--threshold", "0.5", "--start", "0.5"), ("start",)),
                   (("--threshold", "0.5", "--start", "nan"), ("start",)),
                   (("--threshold", "0.5", "--start", "-0.1"), ("start",)),
                   (("--threshold", "0.5", "--start", "stationnary"), ("start",)),
                   (("--threshold", "0.5", "--at", "nan"), ("--at",)),
                   (("--threshold", "0.5", "--at", "-1"), ("--at",)),
                   (("--threshold", "0.5", "--at", "0"), ("--at",)),
                   (("--threshold", "0.5", "--at", "inf"), ("--at",)),
                   (("--threshold", "0.5", "--at", "x"), ("--at",)),
                   (("--threshold", "0.5", "--horizon", "100", "--at", "200"), ("--at",)),
                   (("--threshold", "0.5", "--particles", "1", "--method", "splitting"),
                    ("particles",)),
                   (("--threshold", "0.5", "--particles", "2.5", "--method", "splitting"),
                    ("particles",)),
                   (("--threshold", "0.5", "--particles", "1e12", "--method", "splitting"),
                    ("particles",)),
                   (("--threshold", "0.5", "--particles", "200", "--method", "direct"),
                    ("particles",)),
                   (("--threshold", "0.5", "--groups", "1", "--method", "splitting"),
                    ("groups",)),
                   (("--threshold", "0.5", "--groups", "401", "--method", "splitting"),
                    ("groups",)),
                   (("--threshold", "0.5", "--groups", "20", "--method", "direct"), ("groups",)),
                   (("--threshold", "0.5", "--method", "Splitting"), ("method",)),
                   (("--threshold", "0.5", "--horizon", "0"), ("horizon",)),
                   (("--threshold", "0.5", "--horizon", "nan"), ("horizon",)),
                   (("--threshold", "0.5", "--dt", "auto"), ("dt",)),
                   (("--threshold", "0.5", "--paths", "0"), ("paths",)),
                   (("--threshold", "1e200",), ("threshold",)),
                   (("--threshold", "0.5", "--set", "parametric.stiffness=-1"),
                    ("parametric.stiffness",)),
                   (("--threshold", "0.5", "--set", "system.upper_wall.at=-1"),
                    ("upper_wall.at",))]:
        add(Case(k(n), "passage " + BD + " --paths 64 " + " ".join(opt), PAS + opt, words=w))
    add(Case(k(n), f"passage {OP} --threshold 0.6 --method splitting (parametric noise)",
             ("passage", OP, "--threshold", "0.6", "--start", "0.1", "--method", "splitting",
              "--particles", "20", "--groups", "2", "--quiet", "--out", "{O}"),
             words=("parametric",)),
        Case(k(n), f"passage {BD} --threshold 0.5 --method splitting (parametric noise)",
             ("passage", BD, "--threshold", "0.5", "--start", "0.1", "--method", "splitting",
              "--particles", "20", "--groups", "2", "--quiet", "--out", "{O}"),
             words=("parametric",)),
        Case(k(n), f"passage {BD} --threshold 0.5 --start 0.2 --horizon 20 --at 10 "
             "--paths 64 --out O (a cheap run: CSVs)",
             PAS + ("--threshold", "0.5", "--start", "0.2", "--horizon", "20", "--at", "10",
                    "--model", "exact", "--out", "{O}"),
             expect="run", makes=("reliability.csv", "fpt_density.csv", "metrics.json")),
        Case(k(n), f"passage {BD} --threshold 0.9 (beyond the walls: U(0.9) > U(0.6))",
             PAS + ("--threshold", "0.9", "--start", "0.2", "--horizon", "20", "--model",
                    "exact", "--out", "{O}"), expect="run", makes=("metrics.json",)),
        Case(k(n), f"transient {BD} --start 0.2 --times 1,2,3 --paths 64 --out O",
             ("transient", BD, "--start", "0.2", "--times", "1,2,3", "--paths", "64",
              "--model", "exact", "--quiet", "--out", "{O}"), expect="run",
             makes=("metrics.json",)),
        Case(k(n), f"transient {BD} --start nan --times 1,2,3",
             ("transient", BD, "--start", "nan", "--times", "1,2,3"), words=("start",)),
        Case(k(n), f"transient {BD} --start 0.2 --times 3,2,1",
             ("transient", BD, "--start", "0.2", "--times", "3,2,1"), words=("times",)),
        Case(k(n), f"transient {BD} --start 0.2 --times 1,2,3 --at 2",
             ("transient", BD, "--start", "0.2", "--times", "1,2,3", "--at", "2"),
             words=("--at",)),
        Case(k(n), f"transient {BD} --start 0.2 --times 1,2,3 --method splitting",
             ("transient", BD, "--start", "0.2", "--times", "1,2,3", "--method", "splitting"),
             words=("--method",)),
        Case(k(n), f"check {BD} --at 5", ("check", BD, "--at", "5"), words=("--at",)),
        Case(k(n), f"solve {BD} --particles 10", ("solve", BD, "--particles", "10"),
             words=("--particles",)))
    # 7. outputs
    add(Case(k(n), "passage --out onto a file", PAS + ("--threshold", "0.5", "--out", "{S}"),
             scene="x", words=("out",)),
        Case(k(n), "passage --out ''", PAS + ("--threshold", "0.5", "--out", ""), words=("out",)),
        Case(k(n), "passage --out /proc/h7", PAS + ("--threshold", "0.5", "--out", "/proc/h7"),
             words=("out",)),
        Case(k(n), "transient --out onto a file",
             ("transient", BD, "--start", "0.2", "--times", "1,2,3", "--out", "{S}"),
             scene="x", words=("out",)))
    # 8. sweeps over the new keys
    sw = 'scene = "{sc}"\nworkflow = "{wf}"\nmodels = ["exact"]\n{extra}\n[set]\n' \
         '"montecarlo.paths" = 64\n"montecarlo.time" = 100\n'
    for sc, wf, extra, w in [
        (BD, "check", '[vary]\n"system.upper_wall.r" = {start = 0.9, stop = 1.1, num = 3}',
         ("upper_wall.r",)),
        (BD, "check", '[vary]\n"parametric.stiffness" = [-0.1, 0.1]', ("parametric.stiffness",)),
        (BD, "check", '[vary]\n"parametric.stiffness" = {start = 0.0, stop = 0.01, num = 0}',
         ("num",)),
        (BD, "check", '[vary]\n"system.upper_wall.at" = [-0.2, 0.5]', ("upper_wall.at",)),
        (BD, "check", '[vary]\n"system.lower_wall.at" = ["a", "b"]', ("lower_wall.at",)),
        (BD, "check", '[vary]\n"system.lower_wall.law" = ["newton", "johnson"]',
         ("lower_wall.law", "numeric")),
        (BD, "check", '[vary]\n"system.lower_wall" = [1, 2]', ("lower_wall",)),
        (BD, "check", '[vary]\n"system.r" = [0.9, 0.95]', ("system.r",)),
        (BD, "check", '[vary]\n"parametric.foo" = [0.1, 0.2]', ("parametric.foo",)),
        ("paper-base", "check", '[vary]\n"system.upper_wall.at" = [0.5, -1.0]',
         ("upper_wall.at = -1",)),
        (BD, "check", '[vary]\n"parametric.stiffness" = [0.001, 0.002]\n[set]\n'
         '"system.lower_wall.law" = "hertz"', ("law",)),
        (OP, "passage", '[passage]\nmethod = "splitting"\nstart = 0.1\n[vary]\n'
         '"passage.threshold" = [0.5, 0.6]', ("parametric",)),
        (BD, "passage", '[passage]\nstart = 0.1\nparticles = 1\nmethod = "splitting"\n[vary]\n'
         '"passage.threshold" = [0.5, 0.6]', ("particles",)),
        (BD, "passage", '[passage]\nstart = 0.1\nat = -1\n[vary]\n'
         '"passage.threshold" = [0.5, 0.6]', ("at",)),
        (BD, "passage", '[passage]\nstart = 0.1\nfoo = 1\n[vary]\n'
         '"passage.threshold" = [0.5, 0.6]', ("foo",)),
        (BD, "passage", '[passage]\nstart = 0.1\n[vary]\n"passage.threshold" = [0.5, nan]',
         ("threshold",)),
        (BD, "transient", '[transient]\nstart = 0.2\ntimes = [1, 2, 3]\n[vary]\n'
         '"parametric.stiffness" = [0.001, -0.001]', ("parametric.stiffness",)),
        (BD, "check", '[vary]\n"system.upper_wall.v_yield" = [0.5, 1.0]', ("v_yield",)),
    ]:
        body = sw.format(sc=sc, wf=wf, extra=extra)
        if "[set]\n\"system" in extra:
            body = body.replace('\n[set]\n"montecarlo', '\n"montecarlo', 1)
        first = extra.replace("\n", "; ")
        add(Case(k(n), f"sweep ({wf} on {sc}: {first})",
                 ("sweep", "{S}", "--out", "{O}", "--quiet"), scene=body, words=w))
    # 9. the Python API
    api = [
        ('vifpk.scene("@BD", **{"system.lower_wall.at": "x"})', ("lower_wall.at",)),
        ('vifpk.scene("@BD", **{"system.lower_wall.at": None})', ("lower_wall.at",)),
        ('vifpk.scene("@BD", **{"system.lower_wall.at": [0]})', ("lower_wall.at",)),
        ('vifpk.scene("@BD", **{"system.lower_wall.at": True})', ("lower_wall.at",)),
        ('vifpk.scene("@BD", **{"parametric.stiffness": -1.0})', ("parametric.stiffness",)),
        ('vifpk.scene("@BD", **{"parametric.stiffness": "0.1"})', ("parametric.stiffness",)),
        ('vifpk.scene("@BD", **{"system.lower_wall": {"at": 0.5}})', ("lower_wall.at",)),
        ('from vifpk.core.walls import Wall\nvifpk.scene("@BD", **{"system.lower_wall": '
         'Wall(side="upper", at=0.5)})', ("lower",)),
        ('vifpk.scene("@BD", **{"system.r": 0.9})', ("system.r",)),
        ('vifpk.solve("@BD", model="paper")', ("paper",)),
        ('vifpk.solve("@BD", solver="fpk", model="exact", grid=2)', ("grid",)),
        ('vifpk.check("@BD", models=("paper",))', ("paper",)),
        ('vifpk.check("@BD", set="system.lower_wall.at=-0.1")', ("set",)),
        ('vifpk.check("@BD", set=["system.lower_wall.at=1"])', ("lower_wall.at",)),
        ('vifpk.passage("@OP", threshold=0.6, start=0.1, method="splitting", particles=20, '
         'groups=2)', ("parametric",)),
        ('vifpk.passage("@BD", threshold=float("inf"), set=NOP)', ("threshold",)),
        ('vifpk.passage("@BD", threshold=0.5, at=-1.0, set=NOP)', ("at",)),
        ('vifpk.passage("@BD", threshold=0.5, method="splitting", particles="200", set=NOP)',
         ("particles",)),
        ('vifpk.passage("@BD", threshold=0.5, method="splitting", groups=2.0, set=NOP)',
         ("groups",)),
        ('vifpk.passage("@BD", threshold=0.5, models=("paper",), set=NOP)', ("paper",)),
        ('vifpk.passage("@BD", threshold=0.5, set=["parametric.damping=-1"])',
         ("parametric.damping",)),
        ('vifpk.passage("@BD", threshold=0.5, time=100, set=NOP)', ("time",)),
        ('vifpk.transient("@BD", start=0.2, times=(1, 2, 3), at=5)', ("at",)),
        ('vifpk.transient("@BD", start=0.2, times="1,2,3")', ("times",)),
        ('vifpk.passage(3, threshold=0.5)', ("scene",)),
        ('vifpk.solve("@BD", set=["system.upper_wall.law=johnson", '
         '"system.upper_wall.v_yield=0.5"]).data', ()),
    ]
    for body, w in api:
        body = body.replace("@BD", BD).replace("@OP", OP).replace(
            "NOP", '["parametric.stiffness=0"]')
        add(Case(k(n), body.replace("\n", "; "), py=body,
                 expect="run" if not w else "refuse", words=w))
    # 10. names, and cheap real runs of the new physics
    add(Case(k(n), "check bilateral-duffing (the systems/ prefix left out)",
             ("check", "bilateral-duffing"), words=("systems/bilateral-duffing",)),
        Case(k(n), "passage offset-parametric --threshold 0.5 (the prefix left out)",
             ("passage", "offset-parametric", "--threshold", "0.5"),
             words=("systems/offset-parametric",)),
        Case(k(n), f"solve {BD} --solver fpk --model exact --grid 3",
             ("solve", BD, "--solver", "fpk", "--model", "exact", "--grid", "3"),
             words=("--grid",)),
        Case(k(n), f"solve {BD} --solver montecarlo --paths 64 --time 100 --json O",
             ("solve", BD, "--solver", "montecarlo", "--paths", "64", "--time", "100",
              "--json", "{O}"), expect="run"),
        Case(k(n), f"check {OP} --model exact --paths 64 --time 100 --out O",
             ("check", OP, "--model", "exact", "--paths", "64", "--time", "100", "--quiet",
              "--out", "{O}"), expect="run", makes=("metrics.json",)))
    runs = 'scene = "{sc}"\nworkflow = "check"\nmodels = ["exact"]\n[vary]\n{v}\n[set]\n{s}' \
           '"montecarlo.paths" = 64\n"montecarlo.time" = 100\n'
    add(Case(k(n), f"sweep (check on {BD}: [vary] \"system.upper_wall.r\" = [0.9, 0.95])",
             ("sweep", "{S}", "--out", "{O}", "--quiet"), expect="run", makes=("sweep.nc",),
             scene=runs.format(sc=BD, v='"system.upper_wall.r" = [0.9, 0.95]', s="")),
        Case(k(n), "sweep (check on paper-base: [vary] \"system.upper_wall.at\" = [0.8, 1.2]; "
             "[set] a johnson lower wall)", ("sweep", "{S}", "--out", "{O}", "--quiet"),
             expect="run", makes=("sweep.nc",),
             scene=runs.format(sc="paper-base", v='"system.upper_wall.at" = [0.8, 1.2]',
                               s='"system.lower_wall.law" = "johnson"\n'
                                 '"system.lower_wall.v_yield" = 0.5\n')))
    return C


def run_case(c: Case, work: Path, timeout: float) -> dict:
    cwd = work / c.id / "cwd"
    cwd.mkdir(parents=True)
    s = work / c.id / "scene.toml"
    o = work / c.id / "out"
    if c.scene is not None:
        s.write_text(c.scene)
    if c.py is not None:
        body = "\n".join("    " + line for line in c.py.splitlines())
        argv = [sys.executable, "-c", PY.format(body=body)]
    else:
        argv = [VIFPK] + [a.replace("{S}", str(s)).replace("{O}", str(o)) for a in c.argv]
    env = dict(os.environ, NUMBA_NUM_THREADS="1", MPLBACKEND="Agg")
    t0 = time.perf_counter()
    try:
        p = subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=timeout,
                           env=env)
        rc, err = p.returncode, p.stderr
    except subprocess.TimeoutExpired as e:
        rc, err = "timeout", (e.stderr or b"").decode() if isinstance(e.stderr, bytes) else ""
    dt = time.perf_counter() - t0
    lines = [ln for ln in err.splitlines() if ln.strip()]
    first = lines[0] if lines else ""
    wrote = o.exists() or any(cwd.iterdir())
    return {"rc": rc, "first": first, "wrote": wrote, "dt": dt,
            "traceback": "Traceback" in err, "made": [m for m in c.makes if (o / m).exists()]}


def verdict(c: Case, r: dict) -> str:
    if c.expect == "run":
        return "handled" if r["rc"] == 0 and len(r["made"]) == len(c.makes) else "not"
    if r["rc"] == 3 and not r["traceback"] and not r["wrote"]:
        return "partly"  # a one-line failure after the work, where a refusal was due
    if r["rc"] != 2:
        return "not"
    low = r["first"].lower()
    ok = all(w.lower() in low for w in c.words) and not r["wrote"] and not r["traceback"]
    return "handled" if ok else "partly"


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="")
    ap.add_argument("--md", default="")
    ap.add_argument("--timeout", type=float, default=120.0)
    ap.add_argument("--part", default="1/1", help="i/n: every n-th case from the i-th")
    a = ap.parse_args()
    cases = build()
    if a.only:
        keep = set(a.only.split(","))
        cases = [c for c in cases if c.id in keep]
    i, n = (int(x) for x in a.part.split("/"))
    cases = cases[i - 1::n]
    rows = []
    with tempfile.TemporaryDirectory(prefix="hostile7-") as tmp:
        for c in cases:
            r = run_case(c, Path(tmp), a.timeout)
            v = verdict(c, r)
            rows.append((c, r, v))
            print(f"{c.id} {v:8s} rc={r['rc']} {r['dt']:5.1f}s wrote={r['wrote']} "
                  f"{c.what} :: {r['first'][:150]}", flush=True)
    counts = {v: sum(1 for _, _, x in rows if x == v) for v in ("handled", "partly", "not")}
    print(counts)
    if a.md:
        with open(a.md, "w") as f:
            for c, r, v in rows:
                first = r["first"].replace("|", "\\|")[:160]
                f.write(f"| {c.id} | `{c.what}` | exit {r['rc']}, {r['dt']:.1f} s"
                        f"{', wrote' if r['wrote'] and c.expect != 'run' else ''}: {first} "
                        f"| {v} |\n")


if __name__ == "__main__":
    main()
