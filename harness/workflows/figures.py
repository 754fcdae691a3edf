"""The paper's Figures 2-6, redrawn from the figure scenes: the averaged models against the
Monte Carlo of the original system.

Figures 2-4: p(A), p(x1), p(x2) for each value of the varied parameter (lines: models;
markers with 2 s.e. bars: Monte Carlo). Figures 5-6: the joint PDF p(x1, x2) of each model and
of the Monte Carlo for each value, and the section at x1 = 0. The Monte Carlo section is
the first x1 column of its joint histogram, a direct measurement that does not assume the
density depends on energy alone. ``figures.json`` / ``figures.md`` hold the L1 distances.
"""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from vifpk.harness.door.solvers import closed_form, montecarlo_solution
from vifpk.harness.workflows.check import models_of
from vifpk.harness.workflows.compare import compare

from vifpk.core.io import atomic_path, write_atomic, write_json
from vifpk.core.protocols import Ref, WorkflowSpec
from vifpk.core.scene import Scene, Sweep, load_scene

FIGURES = {2: "paper-fig2", 3: "paper-fig3", 4: "paper-fig4", 5: "paper-fig5", 6: "paper-fig6"}
JOINT = {5, 6}
COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple")
AXIS = {"A": "amplitude A (dimensionless)", "x1": "displacement x1 (dimensionless)",
        "x2": "velocity x2 (dimensionless)"}


#: the averaged models the figures draw, where each applies (models_of): the paper's, the
#: exact-orbit one and the corrected one, the model `check` most often recommends (issue 28:
#: the figures compared paper and exact only)
FIGURE_MODELS = ("paper", "exact", "corrected")
#: their line styles in the PDF figures, in that order
LINE_STYLES = (":", "--", "-")


def figure_models(scene: Scene) -> tuple[str, ...]:
    """The averaged models drawn: those of FIGURE_MODELS that apply to the scene (outside the
    paper's family, e.g. a --set of system.restoring[2], the exact and the corrected one)."""
    models, _ = models_of(scene, FIGURE_MODELS)
    return tuple(m for m in FIGURE_MODELS if m in models)


def _run_variant(scene: Scene, joint: bool) -> dict[str, Any]:
    closed = {m: closed_form(scene, model=m) for m in figure_models(scene)}
    obs = replace(scene.observables, joint=joint, events=True)
    # the simulation's own ranges (its scale pilot), as in a check: not the models' supports
    mc = montecarlo_solution(replace(scene, observables=obs), progress=False)
    l1 = {m: {o: compare(closed[m].data[o], mc.data[o]) for o in ("A", "x1", "x2")}
          for m in closed}
    return {"closed": closed, "mc": mc, "metrics": l1}


def _plot_pdfs(fig_no: int, scene: Scene, runs: list[dict[str, Any]], path: Path) -> None:
    from vifpk.core.io import figures

    plt = figures()

    sw = scene.sweep
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.6))
    for k, (val, run) in enumerate(zip(sw.values, runs, strict=True)):
        col = COLORS[k % len(COLORS)]
        for ax, o in zip(axes, ("A", "x1", "x2"), strict=True):
            for m, ls in zip(run["closed"], LINE_STYLES[-len(run["closed"]):], strict=True):
                d = run["closed"][m].data[o]
                ax.plot(d["x"], d["p"], ls, color=col, lw=1.3,
                        label=f"{sw.key} = {val:g}, {m}" if o == "A" else None)
            d = run["mc"].data[o]
            ax.errorbar(d["x"][::2], d["p"][::2], yerr=2 * d["err"][::2], fmt="o", ms=2.2,
                        color=col, elinewidth=0.6, label=f"{sw.key} = {val:g}, MC"
                        if o == "A" else None)
    for ax, o in zip(axes, ("A", "x1", "x2"), strict=True):
        ax.set_xlabel(AXIS[o])
        ax.set_ylabel(f"density p({o}) (dimensionless)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(runs), fontsize=7, frameon=False)
    names = {":": "dotted", "--": "dashed", "-": "solid"}
    styles = ", ".join(f"{names[ls]} = {m} model" for m, ls in zip(
        runs[0]["closed"], LINE_STYLES[-len(runs[0]["closed"]):], strict=True))
    fig.suptitle(f"{_title(fig_no, scene)}: {styles}, markers = Monte Carlo of the original "
                 "system (±2 s.e.)", fontsize=9)
    fig.tight_layout(rect=(0, 0.16, 1, 1))
    try:
        fig.savefig(path, dpi=110)
    finally:
        plt.close(fig)


def _plot_joint(fig_no: int, scene: Scene, runs: list[dict[str, Any]], path: Path) -> None:
    from vifpk.core.io import figures

    plt = figures()

    sw = scene.sweep
    n = len(runs)
    cols = len(runs[0]["closed"]) + 2  # each model, the Monte Carlo, the section x1 = 0
    fig, axes = plt.subplots(n, cols, figsize=(4 * cols, 3.4 * n), squeeze=False,
                             layout="constrained")
    for i, (val, run) in enumerate(zip(sw.values, runs, strict=True)):
        panels = [(f"{m} model", r.data["joint"]) for m, r in run["closed"].items()]
        panels.append(("Monte Carlo", run["mc"].data["joint"]))
        top = max(float(np.max(p["p"])) for _, p in panels)
        xl = (0.0, max(float(np.max(d["x1"])) for _, d in panels))
        vl = max(float(np.max(np.abs(d["x2"]))) for _, d in panels)
        for j, (title, d) in enumerate(panels):
            ax = axes[i, j]
            ax.set_xlim(*xl)
            ax.set_ylim(-vl, vl)
            ax.set_facecolor(plt.get_cmap("viridis")(0.0))  # beyond a grid the density is 0
            mesh = ax.pcolormesh(d["x1"], d["x2"], np.asarray(d["p"]).T, shading="auto",
                                 vmin=0, vmax=top, cmap="viridis")
            ax.set_title(f"{title}, {sw.key} = {val:g}", fontsize=8)
            ax.set_xlabel(AXIS["x1"], fontsize=8)
            ax.set_ylabel(AXIS["x2"], fontsize=8)
        # one colour scale per row (the three panels share vmin, vmax)
        fig.colorbar(mesh, ax=axes[i, :cols - 1], label="p(x1, x2)", shrink=0.9, pad=0.01)
        ax = axes[i, cols - 1]
        k = len(panels) - 1
        for (title, d), ls, col in zip(panels[:k], LINE_STYLES[-k:],
                                       ("tab:red", "tab:blue", "tab:green")[-k:], strict=True):
            ax.plot(d["x2"], np.asarray(d["p"])[0], ls, color=col, label=title)
        mc = run["mc"].data["joint"]
        ax.errorbar(mc["x2"], np.asarray(mc["p"])[0], yerr=2 * np.asarray(mc["err"])[0], fmt="o",
                    ms=2, color="k", elinewidth=0.5, label="Monte Carlo (first x1 bin)")
        ax.set_title(f"section x1 = 0, {sw.key} = {val:g}", fontsize=8)
        ax.set_xlabel(AXIS["x2"], fontsize=8)
        ax.set_ylabel("p(0, x2)", fontsize=8)
    handles, labels = axes[0, cols - 1].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle(f"{_title(fig_no, scene)}: joint PDF p(x1, x2) and its section at x1 = 0",
                 fontsize=10)
    try:
        fig.savefig(path, dpi=100)
    finally:
        plt.close(fig)


def _title(fig_no: int, scene: Scene) -> str:
    return f"Figure {fig_no} redrawn" if fig_no else scene.name


def as_sweep(scene: Scene) -> Scene:
    """A scene with one varied parameter as it is; a concrete scene as a 'sweep' of one
    value of its friction mu (the figures are drawn a row per value; mu is a key of every
    scene, while r is not one of a scene with wall tables: setting it refused a two-wall
    scene, round 8)."""
    if scene.sweep is not None:
        return scene
    return replace(scene, sweep=Sweep(section="system", key="mu", values=(scene.system.mu,)))


def _table_entry(scene: Scene, runs: list[dict[str, Any]]) -> dict[str, Any]:
    """One figure's row of figures.json: per value of the varied parameter, each model's L1
    of p(A), p(x1), p(x2) against the Monte Carlo, the Monte Carlo's floors and stuck
    fraction."""
    return {
        "varied": scene.sweep.path, "values": list(scene.sweep.values),
        "models": list(runs[0]["closed"]),
        "L1": [{m: {o: r["metrics"][m][o]["L1"] for o in ("A", "x1", "x2")}
                for m in r["closed"]} for r in runs],
        "L1_floor": [{o: r["metrics"]["exact"][o]["L1_floor"] for o in ("A", "x1", "x2")}
                     for r in runs],
        "stuck_fraction": [r["mc"].info["events"]["stuck_fraction"]["value"] for r in runs]}


def draw_scene_figures(out_dir: str | Path, scene: Scene, *, quiet: bool = False,
                       prov: dict[str, Any] | None = None) -> dict[str, Any]:
    """The figures of Figures 2-6 for any scene (issue 21: your own oscillator): the PDFs of
    A, x1, x2 (NAME-pdfs.png) and the joint PDF p(x1, x2) with its section at x1 = 0
    (NAME-joint.png), the averaged models (figure_models) against the Monte Carlo, a row per
    value of the scene's varied parameter; figures.json/.md hold the L1 distances."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sw = as_sweep(scene)
    runs = []
    for v in sw.variants():
        if not quiet:
            print(f"{sw.name}: {v.name} ...", file=sys.stderr, flush=True)
        runs.append(_run_variant(v, True))
    with atomic_path(out / f"{scene.name}-joint.png") as tmp:
        _plot_joint(0, sw, runs, tmp)
    with atomic_path(out / f"{scene.name}-pdfs.png") as tmp:
        _plot_pdfs(0, sw, runs, tmp)
    table = {f"figure-{scene.name}": _table_entry(sw, runs)}
    if prov is None:
        from vifpk.core.provenance import collect

        prov = collect()
    write_json(out / "figures.json", dict(table, provenance=prov))
    write_atomic(out / "figures.md", render_table(table))
    return table


def draw_figures(out_dir: str | Path, *, numbers: tuple[int, ...] = tuple(FIGURES),
                 overrides: dict[str, Any] | None = None, quiet: bool = False,
                 prov: dict[str, Any] | None = None) -> dict[str, Any]:
    """Draw the figures into out_dir; return (and write) the table of L1 distances.
    figures.json holds the table and, under ``provenance``, the run's provenance block."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    table: dict[str, Any] = {}
    for no in numbers:
        scene = load_scene(FIGURES[no])  # a shipped scene (package data)
        if overrides:
            scene = scene.with_values(overrides)
        runs = []
        for v in scene.variants():
            if not quiet:
                print(f"figure {no}: {v.name} ...", file=sys.stderr, flush=True)
            runs.append(_run_variant(v, no in JOINT))
        with atomic_path(out / f"paper-fig{no}.png") as tmp:
            (_plot_joint if no in JOINT else _plot_pdfs)(no, scene, runs, tmp)
        table[f"figure{no}"] = _table_entry(scene, runs)
    if prov is None:
        from vifpk.core.provenance import collect

        prov = collect()
    write_json(out / "figures.json", dict(table, provenance=prov))
    write_atomic(out / "figures.md", render_table(table))
    return table


def render_table(table: dict[str, Any]) -> str:
    """One markdown table; a new header wherever the models drawn change (outside the
    paper's family they are exact and corrected)."""
    lines: list[str] = []
    head = None
    for name, t in table.items():
        ms = tuple(t.get("models", ("paper", "exact")))
        if ms != head:
            cols = [f"L1({o}) {m}" for o in ("A", "x1", "x2") for m in ms]
            lines += ([""] if lines else []) + [
                "| figure | value | " + " | ".join(cols) + " | MC floor (A) |",
                "|" + "---|" * (len(cols) + 3)]
            head = ms
        for v, l1, fl in zip(t["values"], t["L1"], t["L1_floor"], strict=True):
            vals = " | ".join(f"{l1[m][o]:.3f}" for o in ("A", "x1", "x2") for m in ms)
            lines.append(f"| {name[6:].lstrip('-')} | {t['varied'].split('.')[1]} = {v:g} | "
                         f"{vals} | {fl['A']:.3f} |")
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------ the workflow's record
#: ``vifpk figures`` (vifpk.core.protocols.Workflow), registered in pyproject.toml's
#: ``vifpk.workflows``. Its command line (harness/cli) is named by Ref, imported when
#: used: the registry does not depend on the layers above this one.
SPEC = WorkflowSpec(
    "figures", "redraw the paper's Figures 2-6: two averaged models "
    "(the paper's and the exact one) against the Monte "
    "Carlo of the original system",
    add_arguments=Ref("vifpk.harness.cli.arguments:figures_arguments"),
    command=Ref("vifpk.harness.cli.commands:cmd_figures"))
