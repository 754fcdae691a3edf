"""The two figures of a check report (harness/outputs/report.py): the densities and the error
decomposition, drawn on their own Agg canvases (vifpk.core.io.figures) at 110 dpi.

Their layout is explicit (:func:`place`: margins and gaps in inches), not
``Figure.tight_layout``: tight_layout measures every tick label's extent before the figure is
drawn, so each figure's text was laid out twice; it was 1.9 s of the report's 6.7 s under the
profiler (issue 44, the main job). The margins are the ones tight_layout chose for the paper's
base scene, rounded up, and hold the labels these figures can have: y tick labels of at most
five characters (matplotlib moves larger scales into an offset text above the axis) or the
log axis's powers of ten, one line of axis label, the legends below the axes (at most three
rows on the densities, two on the decomposition).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from vifpk.harness.workflows.check import OBSERVABLES, CheckResult

from vifpk.core.io import png_bytes

LABELS = {"A": "amplitude A (dimensionless)", "x1": "displacement x1 (dimensionless)",
          "x2": "velocity x2 (dimensionless)"}
KINDS = ("discretisation_error", "sampling_error", "averaging_error")
KIND_TEXT = {"discretisation_error": "discretisation (FPK vs closed form)",
             "sampling_error": "sampling (MC of the averaged SDE vs closed form)",
             "averaging_error": "averaging (MC of the original system vs closed form)"}

MODEL_COLORS = ("tab:red", "tab:blue", "tab:green", "tab:purple", "tab:orange")

#: dots per inch of both figures (the HTML report shows them at up to 1200 px wide)
DPI = 110


def place(fig: Any, *, left: float, right: float, bottom: float, top: float,
          gap: float) -> None:
    """Lay a figure's row of axes out with margins ``left``, ``right``, ``bottom``, ``top``
    and a ``gap`` between neighbouring axes, all in inches (matplotlib's subplot parameters
    are fractions of the figure, and wspace a fraction of the mean axes width)."""
    w, h = fig.get_size_inches()
    n = len(fig.axes)
    width = (w - left - right - (n - 1) * gap) / n
    fig.subplots_adjust(left=left / w, right=1.0 - right / w, bottom=bottom / h,
                        top=1.0 - top / h, wspace=gap / width if n > 1 else 0.0)


def figure_densities(res: CheckResult, text: dict[str, str] | None = None) -> bytes:
    """Every density of the check, each kind drawn its own way so none hides another:
    closed form (solid line), its FPK (open circles), the Monte Carlo of its averaged SDE
    (dashed steps), in one colour per model; the Monte Carlo of the original system in black
    with +/- 2 s.e. bars. One legend for all panels."""
    from vifpk.core.io import figures

    plt = figures()

    sol = res.solutions
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.4))
    for ax, o in zip(axes, OBSERVABLES, strict=True):
        for k, m in enumerate(res.metrics["models"]):
            col = MODEL_COLORS[k % len(MODEL_COLORS)]
            closed = sol[f"closed:{m}"]
            d = closed.data[o]
            ax.plot(d["x"], d["p"], color=col, lw=1.6,
                    label=f"{m} model: " + ("closed form" if closed.info.get("closed_form", True)
                                            else "FPK direct (no closed form)"))
            if f"fpk:{m}" in sol:
                f = sol[f"fpk:{m}"].data[o]
                every = max(len(f["x"]) // 25, 1)
                ax.plot(f["x"], f["p"], ls="none", marker="o", mfc="none", ms=5, mew=0.9,
                        color=col, markevery=(k * every // 2, every),
                        label=f"{m} model: FPK ({sol[f'fpk:{m}'].info['grid']['cells']} cells)")
            if f"mc:{m}" in sol and o in sol[f"mc:{m}"].data:
                s = sol[f"mc:{m}"].data[o]
                ax.plot(s["x"], s["p"], ls="--", lw=1.0, drawstyle="steps-mid", color=col,
                        alpha=0.8, label=f"{m} model: MC of its averaged SDE")
        mc = sol["mc:original"].data[o]
        ax.errorbar(mc["x"], mc["p"], yerr=2 * mc["err"], fmt="s", ms=2.5, color="k",
                    elinewidth=0.8, capsize=1.5, label="original system: MC (±2 s.e.)",
                    zorder=3)
        ax.set_xlabel(LABELS[o])
        ax.set_ylabel(f"density p({o}) (dimensionless)")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(res.metrics["models"]) + 1,
               fontsize=8,
               frameon=False)
    fig.suptitle(f"{res.scene.name}: stationary densities of the averaged models against "
                 "the original system")
    place(fig, left=0.8, right=0.15, bottom=1.2, top=0.5, gap=0.7)
    return _png(fig, text)


def figure_decomposition(res: CheckResult, text: dict[str, str] | None = None) -> bytes:
    """Bars: the L1 distance of each part of the decomposition, with +/- 1 s.e. error bars
    (black, capped). Grey hatched boxes: the Monte Carlo noise floor, from the bottom of the
    axis up to the floor (a bar inside its box is noise)."""
    from vifpk.core.io import figures

    plt = figures()
    from matplotlib.patches import Rectangle
    from matplotlib.ticker import NullLocator

    models = tuple(res.metrics["models"])
    fig, axes = plt.subplots(1, len(models), figsize=(3.7 * len(models), 4.2), sharey=True)
    width = 0.25
    smallest = min(max(res.metrics["models"][m][k][o]["L1"], 1e-12)
                   for m in models for k in KINDS for o in OBSERVABLES
                   if k in res.metrics["models"][m])
    bottom = 10.0 ** (np.floor(np.log10(smallest)) - 1)
    colors = ("tab:gray", "tab:cyan", "tab:olive")
    for ax, m in zip(np.atleast_1d(axes), models, strict=True):
        entry = res.metrics["models"][m]
        for k, kind in enumerate(KINDS):
            if kind not in entry:  # no closed form: no discretisation error
                continue
            vals = [max(entry[kind][o]["L1"], bottom) for o in OBSERVABLES]
            errs = [entry[kind][o].get("L1_err", 0.0) for o in OBSERVABLES]
            xs = np.arange(3) + (k - 1) * width
            ax.bar(xs, vals, width * 0.9, yerr=errs if any(errs) else None, color=colors[k],
                   capsize=3,
                   error_kw={"elinewidth": 1, "ecolor": "k"}, label=KIND_TEXT[kind])
            for x, o in zip(xs, OBSERVABLES, strict=True):
                fl = entry[kind][o].get("L1_floor", 0.0)
                if fl > 0:  # the FPK comparison has no noise floor
                    ax.add_patch(Rectangle((x - width / 2, bottom), width, fl - bottom,
                                           facecolor="none", edgecolor="0.35", hatch="////",
                                           lw=0.6, zorder=4))
        ax.set_yscale("log")
        # the decades alone: the log axis's minor ticks (8 a decade, unlabelled over the 5-12
        # decades these axes span) were half of the figure's drawing time, each a Tick of
        # lines and text made and drawn on every panel (issue 44, the main job)
        ax.yaxis.set_minor_locator(NullLocator())
        ax.set_ylim(bottom, 2.5)
        ax.axhline(2.0, color="k", lw=0.6, ls=":")
        ax.set_xticks(range(3), [f"p({o})" for o in OBSERVABLES])
        cls = entry.get("verdict_class")
        # y given: the title stands where matplotlib's automatic placement puts it (above
        # the axes: no x tick labels or offset text on top), without measuring every tick
        # label of the shared log axis once per title to find that out
        ax.set_title(f"{m} model" + (f" (verdict: {cls})" if cls else ""), y=1.0)
    np.atleast_1d(axes)[0].set_ylabel("L1 distance (0 to 2; dotted: 2)")
    handles, labels = np.atleast_1d(axes)[0].get_legend_handles_labels()
    handles.append(Rectangle((0, 0), 1, 1, facecolor="none", edgecolor="0.35", hatch="////"))
    labels.append("MC noise floor (hatched: below it, noise)")
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=8, frameon=False)
    place(fig, left=0.8, right=0.15, bottom=0.95, top=0.4, gap=0.2)
    return _png(fig, text)


def prepare() -> None:
    """What the figures draw with, made ready: matplotlib's figure, Agg canvas, patches and
    ticker imported, and one 1 x 1 inch figure drawn with a log axis (its fonts loaded,
    mathtext's parser built for the powers of ten). ``vifpk check`` runs it in a thread while
    the averaged SDEs' kernels run (harness/workflows/check.py ``warm``), 0.7-1 s of the
    report's time on paper-base; the figures drawn after it are the same."""
    from matplotlib.patches import Rectangle  # noqa: F401 - imported here, used by the figures
    from matplotlib.ticker import NullLocator  # noqa: F401

    from vifpk.core.io import figures

    fig, ax = figures().subplots(1, 1, figsize=(1, 1))
    ax.set_yscale("log")
    ax.set_ylim(1e-3, 2.0)
    ax.set_title("x")
    png_bytes(fig, dpi=20)


def _png(fig: Any, text: dict[str, str] | None) -> bytes:
    return png_bytes(fig, text=text, dpi=DPI)
