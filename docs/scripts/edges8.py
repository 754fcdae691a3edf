"""Round 8 of docs/edges.md (issue 45 item 7): new cases across the doors -- walls, impact
laws and parametric noise, the time domain, sweeps, plugins and outputs. The runner, the
verdicts and the scene templates are round 7b's (docs/scripts/hostile7.py): each case runs
``vifpk ...`` or a Python snippet in a subprocess, in an empty working folder, with a timeout,
and records the exit code, the first line of stderr, whether anything was written and the
wall time.

    NUMBA_NUM_THREADS=1 python docs/scripts/edges8.py [--only E001,E002] [--md FILE]

``refuse``: exit 2, one line holding the given words, nothing written; ``run``: exit 0 and the
given files written; ``fail``: exit 3 in one line (a numerical failure that is the right
answer), nothing written.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from hostile7 import HEAD, LOW, TWO, Case, run_case  # noqa: E402
from hostile7 import verdict as verdict7  # noqa: E402

BD = "systems/bilateral-duffing"
OP = "systems/offset-parametric"
SOLVE = ("solve", "{S}", "--model", "exact")
NOP = ("--set", "parametric.stiffness=0")
PAS = ("passage", BD, "--paths", "64", "--quiet", "--model", "exact") + NOP
TRA = ("transient", BD, "--paths", "64", "--quiet", "--model", "exact") + NOP
C: list[Case] = []


def verdict(c: Case, r: dict) -> str:
    if c.expect == "fail":
        ok = r["rc"] == 3 and not r["traceback"] and all(
            w.lower() in r["first"].lower() for w in c.words)
        return "handled" if ok else "not"
    return verdict7(c, r)


def scene(sys_: str = "", rest: str = "") -> str:
    return HEAD.format(sys=sys_, rest=rest)


def walls(lo: str | None, hi: str | None) -> str:
    out = ""
    if lo is not None:
        out += "[system.lower_wall]\n" + lo
    if hi is not None:
        out += "[system.upper_wall]\n" + hi
    return scene(out)


SWEEP = ('scene = "{sc}"\nworkflow = "{wf}"\nmodels = ["exact"]\n{extra}\n[vary]\n{v}\n'
         '[set]\n{s}"montecarlo.paths" = 64\n"montecarlo.time" = 100\n')


def sweep(v: str, s: str = "", sc: str = BD, wf: str = "check", extra: str = "") -> str:
    return SWEEP.format(sc=sc, wf=wf, v=v, s=s, extra=extra)


def build() -> list[Case]:  # noqa: PLR0915 (a list of cases)
    n = [0]

    def k() -> str:
        n[0] += 1
        return f"E{n[0]:03d}"

    def add(what: str, argv: tuple = (), **kw) -> None:
        C.append(Case(k(), what, argv, **kw))

    # 1. walls in a scene file
    add("solve S (lower_wall.at = -1e-300)", SOLVE, scene=walls("at = -1e-300\n", None),
        words=("lower_wall.at", "1e-100"))
    add("solve S (lower_wall.at = -1e-320, subnormal)", SOLVE,
        scene=walls("at = -1e-320\n", None), words=("lower_wall.at", "1e-100"))
    add("solve S (upper_wall.at = 5e-324)", SOLVE,
        scene=walls("at = -0.6\n", "at = 5e-324\n"), words=("upper_wall.at",))
    add("solve S (lower_wall.at = -0 and an upper wall)", SOLVE,
        scene=walls("at = -0.0\nr = 0.9\n", "at = 0.6\n"), expect="run")
    add("solve S (walls at -1e-6 and 1e-6)", SOLVE,
        scene=walls("at = -1e-6\n", "at = 1e-6\n"), words=("wall",))
    add("solve S (lower_wall.r = 1.0000001)", SOLVE,
        scene=walls("at = -0.3\nr = 1.0000001\n", None), words=("1.0000001",))
    add("solve S (lower_wall.r = 0.99999999999999999, rounds to 1)", SOLVE,
        scene=walls("at = -0.3\nr = 0.99999999999999999\n", None), expect="run")
    add("solve S (lower_wall: rr = 0.9)", SOLVE, scene=walls("at = -0.3\nrr = 0.9\n", None),
        words=("rr", "did you mean 'r'"))
    add("solve S (lower_wall: AT = -0.3)", SOLVE, scene=walls("AT = -0.3\n", None),
        words=("AT", "did you mean 'at'"))
    add("solve S (lower_wall: Law = \"newton\")", SOLVE,
        scene=walls('at = -0.3\nLaw = "newton"\n', None), words=("Law", "did you mean 'law'"))
    add("solve S (lower_wall: vyield = 0.5)", SOLVE,
        scene=walls('at = -0.3\nlaw = "johnson"\nvyield = 0.5\n', None),
        words=("vyield", "v_yield"))
    add("solve S (lower_wall.law = \"Johnson\")", SOLVE,
        scene=walls('at = -0.3\nlaw = "Johnson"\n', None), words=("law", "johnson"))
    add("solve S (johnson, v_yield = 1e-300)", SOLVE,
        scene=walls('at = -0.3\nlaw = "johnson"\nv_yield = 1e-300\n', None),
        words=("v_yield", "1e-100"))
    add("solve S (inline lower_wall = {at = -0.3})", SOLVE,
        scene=scene("lower_wall = {at = -0.3, r = 0.9}\n"), expect="run")
    add("solve S (inline lower_wall = {})", SOLVE, scene=scene("lower_wall = {}\n"),
        words=("at", "missing"))
    add("solve S (lower_wall.at = -1e99: the energy overflows)", SOLVE,
        scene=walls("at = -1e99\n", None), words=("overflows",))
    add("solve S (two johnson walls of different v_yield)", SOLVE,
        scene=walls('at = -0.5\nlaw = "johnson"\nv_yield = 0.2\n',
                    'at = 0.7\nlaw = "johnson"\nv_yield = 2.0\nr = 0.9\n'), expect="run")
    add("solve S (lower_wall.r = 1e-200)", SOLVE, scene=walls("at = -0.3\nr = 1e-200\n", None),
        expect="run")
    # 2. walls from --set
    add("solve paper-base --set system.lower_wall=-0.2", ("solve", "paper-base", "--model",
        "exact", "--set", "system.lower_wall=-0.2"), words=("lower_wall", "table",
                                                            "system.lower_wall.at"))
    add(f"solve {BD} --set system.upper_wall=0.5", ("solve", BD, "--model", "exact", "--set",
        "system.upper_wall=0.5"), words=("upper_wall", "table"))
    add(f"solve {BD} --set system.lower_wall.at=-0", ("solve", BD, "--model", "exact",
        "--set", "system.lower_wall.at=-0"), expect="run")
    add(f"solve {BD} --set system.lower_wall.at=-1e-200", ("solve", BD, "--model", "exact",
        "--set", "system.lower_wall.at=-1e-200"), words=("lower_wall.at", "1e-100"))
    add(f"solve {BD} --set system.lower_wall.law=johnson (no v_yield)",
        ("solve", BD, "--model", "exact", "--set", "system.lower_wall.law=johnson"),
        words=("v_yield", "missing"))
    add("solve paper-base --set system.upper_wall.at=0.6 (the paper's wall and an upper one)",
        ("solve", "paper-base", "--model", "exact", "--set", "system.upper_wall.at=0.6"),
        expect="run")
    add("solve systems/linear-ou --set system.lower_wall.r=0.5 (r becomes a table)",
        ("solve", "systems/linear-ou", "--model", "exact", "--set",
         "system.lower_wall.r=0.5"), expect="run")
    add(f"solve {BD} --set system.lower_wall.rr=0.5", ("solve", BD, "--model", "exact",
        "--set", "system.lower_wall.rr=0.5"), words=("rr", "did you mean 'r'"))
    add(f"solve {BD} --set system.lower_wall.r=1.0000001", ("solve", BD, "--model", "exact",
        "--set", "system.lower_wall.r=1.0000001"), words=("1.0000001",))
    add(f"solve {BD} --set system.lower_wall.at=0.7 (beyond the upper wall, wrong side)",
        ("solve", BD, "--model", "exact", "--set", "system.lower_wall.at=0.7"),
        words=("lower_wall.at", "<= 0"))
    add(f"solve {BD} --set system.upper_wall.at=-0", ("solve", BD, "--model", "exact",
        "--set", "system.upper_wall.at=-0"), expect="run")
    # 3. parametric noise
    add("solve paper-base --set parametric.stiffness=0.08", ("solve", "paper-base", "--model",
        "exact", "--set", "parametric.stiffness=0.08"), words=("parametric.stiffness",))
    add("solve paper-base --set parametric.stiffness=0.0834", ("solve", "paper-base",
        "--model", "exact", "--set", "parametric.stiffness=0.0834"),
        words=("parametric.stiffness",))
    add("solve paper-base --set parametric.stiffness=0.01", ("solve", "paper-base", "--model",
        "exact", "--set", "parametric.stiffness=0.01"), expect="run")
    add("solve paper-base --set parametric.damping=0.1", ("solve", "paper-base", "--model",
        "exact", "--set", "parametric.damping=0.1"), expect="run")
    add("solve systems/linear-ou --set parametric.damping=100", ("solve", "systems/linear-ou",
        "--model", "exact", "--set", "parametric.damping=100"), words=("parametric.damping",))
    add("solve systems/linear-ou --set parametric.stiffness=0.001", ("solve",
        "systems/linear-ou", "--model", "exact", "--set", "parametric.stiffness=0.001"),
        expect="run")
    add("solve systems/linear-ou --set parametric.stiffness=1", ("solve", "systems/linear-ou",
        "--model", "exact", "--set", "parametric.stiffness=1"),
        words=("parametric.stiffness",))
    add(f"solve {OP} --set parametric.damping=1e6", ("solve", OP, "--model", "exact", "--set",
        "parametric.damping=1e6"), words=("parametric.damping",))
    add(f"solve {OP} --set parametric.stiffness=0.5", ("solve", OP, "--model", "exact",
        "--set", "parametric.stiffness=0.5"), words=("parametric.stiffness",))
    add("solve systems/quintic --set parametric.stiffness=0.01", ("solve", "systems/quintic",
        "--model", "exact", "--set", "parametric.stiffness=0.01"),
        words=("parametric.stiffness",))
    add(f"solve {BD} --set parametric.stiffness=10 (two walls hold x)", ("solve", BD,
        "--model", "exact", "--set", "parametric.stiffness=10"), expect="run")
    add(f"solve {BD} --set parametric.damping=1", ("solve", BD, "--model", "exact", "--set",
        "parametric.damping=1"), expect="run")
    add(f"solve {BD} --set parametric.stiffness=1e-101", ("solve", BD, "--model", "exact",
        "--set", "parametric.stiffness=1e-101"), words=("parametric.stiffness", "1e-100"))
    add(f"solve {BD} --set parametric.stiffness=-0", ("solve", BD, "--model", "exact", "--set",
        "parametric.stiffness=-0"), expect="run")
    add(f"solve {BD} --set parametric.Stiffness=0.1", ("solve", BD, "--model", "exact",
        "--set", "parametric.Stiffness=0.1"), words=("did you mean 'stiffness'",))
    add(f"solve {BD} --set parametric=0.1", ("solve", BD, "--model", "exact", "--set",
        "parametric=0.1"), words=("parametric",))
    add(f"solve {OP} --set noise.kind=ou --set noise.alpha1=2 (parametric under OU)",
        ("solve", OP, "--model", "exact", "--set", "noise.kind=ou", "--set",
         "noise.alpha1=2"), expect="run")
    add(f"solve {BD} --set system.f=0 (parametric noise alone)", ("solve", BD, "--model",
        "exact", "--set", "system.f=0"), words=("f = 0",))
    add("solve S (free Duffing, friction, D_k = 0.01: no wall)", SOLVE,
        scene=scene("", "[parametric]\nstiffness = 0.01\n").replace("mu = 0.0", "mu = 0.05"),
        words=("parametric.stiffness",))
    add("solve S (no wall, damping noise D_c = 0.5)", SOLVE,
        scene=scene("", "[parametric]\ndamping = 0.5\n"), expect="run")
    # 4. the time domain
    add(f"passage {BD} --threshold 1e6", PAS + ("--threshold", "1e6"), words=("threshold",))
    add(f"passage {BD} --threshold 0.5 --start 0.6", PAS + ("--threshold", "0.5", "--start",
        "0.6"), words=("start",))
    add(f"passage {BD} --threshold 0", PAS + ("--threshold", "0"), words=("threshold",))
    add(f"passage {BD} --threshold 0.5 --start nan", PAS + ("--threshold", "0.5", "--start",
        "nan"), words=("start",))
    add(f"passage {BD} --threshold 0.5 --dt 0.5", PAS + ("--threshold", "0.5", "--dt", "0.5"),
        words=("dt",))
    add(f"passage {BD} --threshold 0.5 --dt 0", PAS + ("--threshold", "0.5", "--dt", "0"),
        words=("dt",))
    add(f"passage {BD} --threshold 0.5 --dt -0.01", PAS + ("--threshold", "0.5", "--dt",
        "-0.01"), words=("dt",))
    add(f"passage {BD} --threshold 0.5 --paths 0", PAS[:2] + ("--paths", "0", "--threshold",
        "0.5"), words=("paths",))
    add(f"passage {BD} --threshold 0.5 --method Auto", PAS + ("--threshold", "0.5",
        "--method", "Auto"), words=("method",))
    add(f"passage {BD} --threshold 0.5 --at 0", PAS + ("--threshold", "0.5", "--at", "0"),
        words=("at",))
    add(f"passage {BD} --threshold 0.5 --seed -1", PAS + ("--threshold", "0.5", "--seed",
        "-1"), words=("seed",))
    add(f"passage {BD} --threshold 0.5 --seed 1.5", PAS + ("--threshold", "0.5", "--seed",
        "1.5"), words=("seed",))
    add(f"passage {BD} --threshold 0.5 --model exactt", PAS[:5] + ("exactt", "--threshold",
        "0.5"), words=("exact",))
    add(f"passage {BD} --threshold 0.5 --horizon 0.5 (every path censored)",
        PAS + ("--threshold", "0.5", "--start", "0.1", "--horizon", "0.5", "--out", "{O}"),
        expect="run", makes=("metrics.json",))
    add("passage paper-base --threshold 0.8 --start 1e-300", ("passage", "paper-base",
        "--model", "exact", "--threshold", "0.8", "--start", "1e-300", "--paths", "64",
        "--quiet", "--out", "{O}"), expect="run", makes=("metrics.json",))
    add(f"transient {BD} --start 0.2 --times 1,2,2", TRA + ("--start", "0.2", "--times",
        "1,2,2"), words=("times",))
    add(f"transient {BD} --start 0.2 --times 0,1,2", TRA + ("--start", "0.2", "--times",
        "0,1,2"), words=("times",))
    add(f"transient {BD} --start 0.2 --times 1,2,inf", TRA + ("--start", "0.2", "--times",
        "1,2,inf"), words=("times",))
    add(f"transient {BD} --start 0.2 --times 1e300,2e300,3e300", TRA + ("--start", "0.2",
        "--times", "1e300,2e300,3e300"), words=("times",))
    add(f"transient {BD} --start -0.2 --times 1,2,3", TRA + ("--start", "-0.2", "--times",
        "1,2,3"), words=("start",))
    add("transient paper-base --start 1.0 --times 1..15000", ("transient", "paper-base",
        "--start", "1.0", "--quiet", "--times", ",".join(str(i) for i in range(1, 15001))),
        words=("times",))
    add(f"transient {BD} --start 0.2 --times 1,2,3 --dt 0.5", TRA + ("--start", "0.2",
        "--times", "1,2,3", "--dt", "0.5"), words=("dt",))
    api = [
        ('vifpk.passage("@BD", threshold=0.5, start=0.1, method="auto", paths=64, set=NOP, '
         'models=("exact",))', ()),
        ('vifpk.passage("@BD", threshold=0.5, method="AUTO", set=NOP)', ("method",)),
        ('vifpk.passage("@BD", threshold=True, set=NOP)', ("threshold",)),
        ('vifpk.passage("@BD", threshold=1e6, set=NOP)', ("threshold",)),
        ('vifpk.transient("@BD", start=-1, times=[1, 2, 3], set=NOP)', ("start",)),
        ('vifpk.transient("@BD", start=0.2, times=[1, 2, 3], dt=0.5, set=NOP)', ("dt",)),
        ('vifpk.solve("@BD", model="exact", dt=0.01, time_step=0.01)', ("dt",)),
        ('vifpk.assert_averaging_error("paper-base", model="exact", below=float("nan"))',
         ("below",)),
        ('vifpk.assert_averaging_error("paper-base", model="exact", below=-1)', ("below",)),
        ('vifpk.scene("@BD", **{"system.lower_wall.at": -1e-300})', ("lower_wall.at",)),
        ('vifpk.scene("@BD", **{"system.lower_wall": -0.2})', ("lower_wall", "table")),
        ('vifpk.scene("@BD", **{"system.lower_wall.AT": -0.2})', ("did you mean 'at'",)),
        ('vifpk.solve("@BD", model="exact", set=["parametric.stiffness=1e-300"])',
         ("parametric.stiffness",)),
    ]
    for body, w in api:
        body = body.replace("@BD", BD).replace("@OP", OP).replace(
            "NOP", '["parametric.stiffness=0"]')
        C.append(Case(k(), body.replace("\n", "; "), py=body,
                      expect="run" if not w else "refuse", words=w))
    # 5. sweeps
    sw = ("sweep", "{S}", "--out", "{O}", "--quiet")
    add("sweep ([set] system.mu = -1)", sw, scene=sweep('"system.mu" = [0.0, 0.01]',
        '"system.c2" = 1.0\n' if False else '"system.lower_wall.r" = 2.0\n'),
        words=("[set]", "lower_wall.r"))
    add("sweep ([transient] start = -1)", sw, scene=sweep('"system.mu" = [0.0, 0.01]',
        wf="transient", extra="[transient]\nstart = -1\ntimes = [1, 2, 3]\n"),
        words=("[transient] start",))
    add("sweep ([passage] threshold = 1e6)", sw, scene=sweep('"system.mu" = [0.0, 0.01]',
        wf="passage", extra="[passage]\nthreshold = 1e6\n"), words=("threshold",))
    add('sweep ([vary] "system.lower_wall" = [-0.2, -0.3])', sw,
        scene=sweep('"system.lower_wall" = [-0.2, -0.3]'), words=("lower_wall", "table",
                                                                  "system.lower_wall.at"))
    add('sweep ([vary] "noise.kind" = ["white", "ou"])', sw,
        scene=sweep('"noise.kind" = ["white", "ou"]'), words=("noise.kind",))
    add('sweep ([vary] "system.lower_wall.at" = [-0.3, -1e-300])', sw,
        scene=sweep('"system.lower_wall.at" = [-0.3, -1e-300]'), words=("lower_wall.at",))
    add('sweep on paper-base ([vary] "parametric.stiffness" = [0.01, 0.2])', sw,
        scene=sweep('"parametric.stiffness" = [0.01, 0.2]', sc="paper-base"),
        words=("parametric.stiffness",))
    add("sweep (models = [])", sw, scene=sweep('"system.mu" = [0.0, 0.01]').replace(
        'models = ["exact"]', "models = []"), words=("models",))
    add("sweep ([vary] empty)", sw, scene=sweep(""), words=("vary",))
    add('sweep ([set] "montecarlo.paths" = 0)', sw,
        scene=sweep('"system.mu" = [0.0, 0.01]').replace('"montecarlo.paths" = 64',
                                                         '"montecarlo.paths" = 0'),
        words=("paths",))
    add('sweep (workflow = "nosuch")', sw, scene=sweep('"system.mu" = [0.0, 0.01]',
        wf="nosuch"), words=("workflow",))
    add('sweep (workflow = "bifurcation", find r on a wall-table scene)', sw,
        scene=sweep('"system.mu" = [0.0, 0.01]', wf="bifurcation",
                    extra='[bifurcation]\nfind = "r"\n'), words=("r",))
    add("sweep (a file that is not TOML)", sw, scene="this is = = not toml\n",
        words=("toml",))
    add('sweep (scene = "nosuch.toml")', sw, scene=sweep('"system.mu" = [0.0, 0.01]',
        sc="nosuch.toml"), words=("nosuch",))
    add("sweep --workers 0", sw + ("--workers", "0"),
        scene=sweep('"system.mu" = [0.0, 0.01]'), words=("workers",))
    add("sweep --out onto a file", ("sweep", "{S}", "--out", "{S}", "--quiet"),
        scene=sweep('"system.mu" = [0.0, 0.01]'), words=("--out",))
    add('sweep ([vary] "system.lower_wall.at" and "system.upper_wall.at")', sw,
        scene=sweep('"system.lower_wall.at" = [-0.3, -0.4]\n"system.upper_wall.at" = '
                    '[0.3, 0.4]'), expect="refuse", words=("vary",))
    add('sweep ([vary] "parametric.damping" = [0.0, 1.0], transient)', sw,
        scene=sweep('"parametric.damping" = [0.0, 1.0]', wf="transient",
                    extra="[transient]\nstart = 0.2\ntimes = [1, 2, 3]\n",
                    s='"parametric.stiffness" = 0\n'), expect="run", makes=("sweep.nc",))
    # 6. plugins (Python objects through the API)
    plug = [
        ('vifpk.solve("@BD", model=object())', ("model",)),
        ('vifpk.solve("@BD", model=42)', ("model",)),
        ('vifpk.check("@BD", models=["exact", "exact"])', ("exact",)),
        ('vifpk.solve("@BD", model="paper")', ("paper",)),
        ('vifpk.solve("@OP", model="paper")', ("paper",)),
        ('vifpk.passage("@BD", threshold=0.5, models=[object()], set=NOP)', ("model",)),
    ]
    for body, w in plug:
        body = body.replace("@BD", BD).replace("@OP", OP).replace(
            "NOP", '["parametric.stiffness=0"]')
        C.append(Case(k(), body, py=body, words=w))
    # 7. outputs and commands
    add("solve --json - (the standard output)", ("solve", BD, "--model", "exact", "--json",
        "-"), expect="run")
    add("check --out /dev/null", ("check", BD, "--model", "exact", "--out", "/dev/null"),
        words=("--out",))
    add("solve --json /proc/x.json", ("solve", BD, "--model", "exact", "--json",
        "/proc/x.json"), words=("--json",))
    add("check --out (a 300-character name)", ("check", BD, "--model", "exact", "--out",
        "{O}" + "x" * 300), words=("--out",))
    add("workprecision -h lists only its options", ("workprecision", "-h"), expect="run")
    add("vifpk (no command)", (), words=("command",))
    add("vifpk --version", ("--version",), expect="run")
    add("vifpk models", ("models",), expect="run")
    add(f"check {BD} --model exact --paths 64 --time 100 --out O (report lists D_k)",
        ("check", BD, "--model", "exact", "--paths", "64", "--time", "100", "--quiet",
         "--out", "{O}"), expect="run", makes=("report.md", "report.html", "metrics.json"))
    add(f"check {OP} --dt 0.5 --paths 64", ("check", OP, "--model", "exact", "--paths", "64",
        "--dt", "0.5", "--quiet"), words=("dt",))
    add(f"solve {BD} --solver montecarlo --dt 0.3 --paths 64", ("solve", BD, "--solver",
        "montecarlo", "--paths", "64", "--dt", "0.3"), words=("dt",))
    add(f"solve {BD} --solver fpk --model exact --grid 64 --json O", ("solve", BD, "--solver",
        "fpk", "--model", "exact", "--grid", "64", "--json", "{O}"), expect="run")
    add(f"solve {OP} --model corrected", ("solve", OP, "--model", "corrected"), expect="run")
    add(f"solve {BD} --model corrected", ("solve", BD, "--model", "corrected"), expect="run")
    add("check S (a one-wall scene: at = -0.3, two LOW) --paths 64 --time 100",
        ("check", "{S}", "--model", "exact", "--paths", "64", "--time", "100", "--quiet",
         "--out", "{O}"), scene=scene(LOW), expect="run", makes=("metrics.json",))
    add("solve S (two walls TWO, D_c = 0.1) --solver montecarlo --paths 64 --time 100",
        ("solve", "{S}", "--solver", "montecarlo", "--paths", "64", "--time", "100"),
        scene=scene(TWO, "[parametric]\ndamping = 0.1\n"), expect="run")
    return C


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="")
    ap.add_argument("--md", default="")
    ap.add_argument("--timeout", type=float, default=180.0)
    a = ap.parse_args()
    cases = build()
    if a.only:
        keep = set(a.only.split(","))
        cases = [c for c in cases if c.id in keep]
    rows = []
    with tempfile.TemporaryDirectory(prefix="edges8-") as tmp:
        for c in cases:
            r = run_case(c, Path(tmp), a.timeout)
            v = verdict(c, r)
            rows.append((c, r, v))
            print(f"{c.id} {v:8s} rc={r['rc']} {r['dt']:5.1f}s wrote={r['wrote']} "
                  f"{c.what[:120]} :: {r['first'][:200]}", flush=True)
    counts = {v: sum(1 for _, _, x in rows if x == v) for v in ("handled", "partly", "not")}
    print(counts)
    if a.md:
        with open(a.md, "w") as f:
            for c, r, v in rows:
                first = r["first"].replace("|", "\\|")[:200]
                f.write(f"| {c.id} | `{c.what}` | exit {r['rc']}, {r['dt']:.1f} s"
                        f"{', wrote' if r['wrote'] and c.expect != 'run' else ''}: {first} "
                        f"| {v} |\n")


if __name__ == "__main__":
    main()
