"""accuracy.png of the accuracy study (:mod:`tribofmu.studies.accuracy`): error against wall
time, one line per algorithm or monolithic solver, each point labelled with its setting."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def plot_accuracy(rows: list[dict], summary: dict, title: str, path: Path) -> None:
    """Error against wall time, one line per algorithm, each point labelled with its step
    [s] or tolerance; the scene's default ringed; the reference solver's time dashed.

    Algorithms whose points coincide (Jacobi and Gauss-Seidel give the same error at the
    same step on a two-FMU loop) are drawn with distinct markers and line styles, and a
    step shared by such points is labelled once, in grey; the monolithic anchors (LSODA,
    Radau, the event-driven dry solve) are dashed squares. Each label takes the first of a
    few places around its point where it overlaps no earlier label; the x range leaves room
    for the labels of the rightmost points."""
    from ..plots import pyplot, save_png, wrap_items
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(7.5, 6.2))
    styles = [("o", "-"), ("s", "--"), ("^", "-."), ("D", ":")]
    labels: list[list] = []  # [t, err, text, color]
    times = []
    for k, name in enumerate(dict.fromkeys(r["algorithm"] for r in rows)):
        # nRMS >= 1 is no solution (a solver that "succeeded" far off): in the CSV, not drawn
        sel = [r for r in rows if r["algorithm"] == name and np.isfinite(r["nrms_v"]) and 0 < r["nrms_v"] < 1]
        if not sel:
            continue
        anchor = sel[0].get("family") == "monolithic"
        sel.sort(key=lambda r: r["step"] or r["tol"])  # the line follows the ladder, not the timings
        marker, line = ("s", "--") if anchor else styles[k % len(styles)]
        # hollow markers grow with each line drawn, so a line drawn later over the same points
        # (Jacobi over Gauss-Seidel: the same error at the same step) rings them, hiding none
        ax.loglog([r["wall_time_s"] for r in sel], [r["nrms_v"] for r in sel], marker=marker, ls=line,
                  color=f"C{k}", label=_legend(name, summary), ms=5 if anchor else min(6 + 1.5 * k, 10) if k % 2 else 4,
                  mfc="none" if k % 2 else f"C{k}", mew=1.2, lw=1.0 if anchor else 1.5, zorder=2 + 0.1 * k)
        for r in sel:
            text = (f"h={r['step']:g} s" if r["step"] else f"rtol={r['tol']:g}" if name in ("LSODA", "Radau")
                    else f"{r['tol']:g} T" if name == "event-driven" else f"tol={r['tol']:g}")
            t, err = r["wall_time_s"], r["nrms_v"]
            times.append(t)
            twin = next((lab for lab in labels if lab[2] == text and abs(math.log10(lab[0] / t)) < 0.15
                         and abs(math.log10(lab[1] / err)) < 0.1), None)
            if twin is not None:  # the same step at the same point: one label, in grey
                twin[3] = "0.3"
            else:
                labels.append([t, err, text, f"C{k}"])
            if r.get("default"):
                ax.plot(t, err, "o", ms=12, mfc="none", mec="k", mew=1.2)
    ax.plot([], [], "o", ms=9, mfc="none", mec="k", label="the scene's default")
    ax.axvline(summary["reference_wall_time_s"], color="k", ls="--", lw=1, label="reference solver")
    if times:  # room for the rightmost labels
        left = min(min(times), summary["reference_wall_time_s"]) / 1.5
        ax.set_xlim(left, max(times) * 3.0)
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    # ticks at 1, 2, 5 x 10^k written plainly; no minor labels (they collide on short ranges)
    ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("wall time of the run [s]")
    ax.set_ylabel("nRMS error of v on the window [1]")
    ax.set_title(wrap_items(title, 95), fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    # below the axes, in a strip of its own (so that it covers no point, no label, and is
    # cut by no edge): the figure grows by the legend's rows
    handles, names = ax.get_legend_handles_labels()
    rows = len(handles)
    width, height = fig.get_size_inches()
    strip = 0.16 * rows + 0.15  # inches
    fig.set_size_inches(width, height + strip)
    fig.legend(handles, names, fontsize=7, loc="lower center", ncol=1, frameon=False,
               bbox_to_anchor=(0.5, 0.01))
    fig.tight_layout(rect=(0.0, (strip + 0.1) / (height + strip), 1.0, 1.0))
    _place_labels(fig, ax, labels, fontsize=7)
    save_png(fig, path, dpi=120)


def _place_labels(fig, ax, labels, fontsize: float) -> None:
    """Annotate each (t, err, text, color) at the first of a few offsets around its point
    where the label's drawn box overlaps no earlier label, no point of the chart and stays in
    the axes (measured with the renderer, not estimated); the first offset if none is free."""
    offsets = [(5, 4), (5, -11), (-5, 4), (-5, -11), (5, 12), (5, -19), (-5, 12), (-5, -19), (0, 14), (0, -22)]
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    inside = ax.get_window_extent(renderer)
    pad = 4.5 * fig.dpi / 72.0  # a marker's half size, in pixels
    points = [ax.transData.transform((t, err)) for t, err, _, _ in labels]
    taken = [(x - pad, y - pad, x + pad, y + pad) for x, y in points]

    def free(box) -> bool:
        return (box[0] >= inside.x0 and box[2] <= inside.x1 and box[1] >= inside.y0 and box[3] <= inside.y1
                and not any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3] for b in taken))

    for t, err, text, color in labels:
        for k, (dx, dy) in enumerate(offsets + [offsets[0]]):
            note = ax.annotate(text, (t, err), fontsize=fontsize, color=color, xytext=(dx, dy),
                               textcoords="offset points",
                               ha="left" if dx > 0 else "right" if dx < 0 else "center")
            extent = note.get_window_extent(renderer)
            box = (extent.x0 - 1, extent.y0 - 1, extent.x1 + 1, extent.y1 + 1)
            if k == len(offsets) or free(box):
                taken.append(box)
                break
            note.remove()


def _legend(name: str, summary: dict) -> str:
    if name in ("LSODA", "Radau"):
        regularised = summary.get("contact") == "sticks"
        return f"{name}, monolithic, same ODEs" + (f" ({summary.get('regularisation', '')})" if regularised else "")
    if name == "event-driven":
        return "exact event-driven stick-slip solve (events to tol x T)"
    return name


