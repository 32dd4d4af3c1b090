"""The sweep's pictures: a 1-D sweep's metrics against the swept value (``sweep.png``), a 2-D
sweep's regime maps (``map_<metric>.png``, one heat map per metric), and the phase portraits
v(x) of every point (``portraits.png``, up to :data:`MAX_PORTRAIT_PANELS` points)."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ...scene.scenario import UNITS, Scenario, key_label
from ...metrics import METRICS
from .grid import format_value, is_numeric, same_setting
from .worker import STATUS_OK

MAX_PORTRAIT_PANELS = 100
METRIC_LABELS = {"stick_fraction": "stick fraction", "stick_episodes_per_period": "stick episodes / period",
                 "creep_fraction": "creep fraction", "creep_episodes_per_period": "creep episodes / period",
                 "harmonics": "harmonics of x", "amplitude_ratio": "max|x| / A",
                 "dissipated_per_cycle": "dissipated per cycle [J]", "melt_fraction": "melt fraction"}
# Metrics that count (whole numbers): points only, no line between them, integer ticks
INTEGER_METRICS = frozenset({"stick_episodes_per_period", "creep_episodes_per_period", "harmonics"})


def shown_as(key: str, base: Scenario | None):
    """How a swept key is shown on an axis: ``(label, value -> shown value, name, unit)``. The
    normal stress ``conditions.n`` [Pa] of a law that states its load in newtons (dry, mixed)
    is shown as the load ``L = -n S`` [N], what an engineer reads; every other key as it is."""
    if key == "conditions.n" and base is not None and "Friction" in base.fmus:
        law = base.friction.law()
        if law.load_shown_as == "L":
            return "load L = −n S [N]", law.load, "L", "N"
    return key_label(key), (lambda value: value), key.split(".")[-1], UNITS.get(key)


def _tick(value, convert) -> str:
    return f"{convert(value):.4g}" if is_numeric([value]) else format_value(value)


def plot_sweep(rows: list[dict[str, Any]], keys: list[str], portraits: dict[str, np.ndarray], out_dir: Path,
               base: Scenario | None = None) -> list[Path]:
    """sweep.png + portraits.png (1-D) or map_<metric>.png + portraits.png (2-D); returns paths."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    paths: list[Path] = []
    title = base.name if base is not None else ""  # its title names the values being swept
    metrics = [m for m in METRICS if any(np.isfinite(r[m]) for r in rows)]
    if len(keys) == 1:
        key = keys[0]
        values = [r[key] for r in rows]
        numeric = is_numeric(values)
        label, convert, _, _ = shown_as(key, base)
        pos = np.array([convert(v) for v in values], dtype=float) if numeric else np.arange(len(values), dtype=float)
        ncols = 3
        nrows = max(1, math.ceil(len(metrics) / ncols))
        fig, axes = plt.subplots(nrows, ncols, figsize=(4 * ncols, 2.8 * nrows), squeeze=False)
        failed = np.array([r["status"] != STATUS_OK for r in rows])
        for ax, m in zip(axes.flat, metrics):
            y = np.array([r[m] for r in rows], dtype=float)
            if m in INTEGER_METRICS:  # a count has no value between two points
                from matplotlib.ticker import MaxNLocator
                ax.plot(pos, y, "o", color="C0")
                ax.yaxis.set_major_locator(MaxNLocator(integer=True))
            else:
                ax.plot(pos, y, "o-", color="C0")
            for p in pos[failed]:
                ax.axvline(p, color="C3", ls=":", lw=1)
            ax.set_ylabel(METRIC_LABELS.get(m, m))
            ax.set_xlabel(label)
            if numeric and len(pos) > 2 and pos.min() > 0 and pos.max() / pos.min() >= 20:
                ax.set_xscale("log")
            if not numeric:
                ax.set_xticks(pos, [format_value(v) for v in values], rotation=30)
            ax.grid(alpha=0.3)
        for ax in list(axes.flat)[len(metrics):]:
            ax.axis("off")
        fig.suptitle(f"{title}: sweep over {label}" + (" (dotted: failed)" if failed.any() else ""), fontsize=10)
        fig.tight_layout()
        paths.append(out_dir / "sweep.png")
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
        shape = (1, len(rows))
    elif len(keys) == 2:
        n0, n1 = len({same_setting(r[keys[0]]) for r in rows}), len({same_setting(r[keys[1]]) for r in rows})
        shape = (n0, n1)
        v0 = [rows[i * n1][keys[0]] for i in range(n0)]
        v1 = [rows[j][keys[1]] for j in range(n1)]
        for m in metrics:
            z = np.array([r[m] for r in rows], dtype=float).reshape(n0, n1).T  # y: key 1, x: key 0
            fig, ax = plt.subplots(figsize=(1.0 + 0.75 * max(n0, 4), 1.0 + 0.6 * max(n1, 4)))
            cmap = plt.get_cmap("viridis").with_extremes(bad="0.85")
            im = ax.imshow(np.ma.masked_invalid(z), origin="lower", aspect="auto", cmap=cmap)
            (label0, convert0, _, _), (label1, convert1, _, _) = shown_as(keys[0], base), shown_as(keys[1], base)
            ax.set_xticks(range(n0), [_tick(v, convert0) for v in v0], rotation=30)
            ax.set_yticks(range(n1), [_tick(v, convert1) for v in v1])
            ax.set_xlabel(label0)
            ax.set_ylabel(label1)
            if n0 * n1 <= 225:
                finite = z[np.isfinite(z)]
                mid = (finite.min() + finite.max()) / 2 if finite.size else 0
                for j in range(n1):
                    for i in range(n0):
                        text = "failed" if not np.isfinite(z[j, i]) else format(z[j, i], ".3g")
                        ax.text(i, j, text, ha="center", va="center", fontsize=7,
                                color="black" if not np.isfinite(z[j, i]) or z[j, i] > mid else "white")
            fig.colorbar(im, ax=ax, label=METRIC_LABELS.get(m, m))
            ax.set_title(f"{title}\n{METRIC_LABELS.get(m, m)}", fontsize=9)
            fig.tight_layout()
            paths.append(out_dir / f"map_{m}.png")
            fig.savefig(paths[-1], dpi=110)
            plt.close(fig)
    else:
        return paths
    if len(rows) <= MAX_PORTRAIT_PANELS:
        paths.append(_plot_portraits(rows, keys, portraits, shape, out_dir / "portraits.png", title, plt, base))
    return paths


def panel_label(name: str, value, unit: str | None) -> str:
    """``omega = 20 rad/s``: a swept value with its unit (none for a dimensionless or
    non-numeric value)."""
    text = f"{name} = {format_value(value)}"
    return f"{text} {unit}" if unit and unit != "1" and is_numeric([value]) else text


def _plot_portraits(rows, keys, portraits, shape, path: Path, title: str, plt, base=None) -> Path:
    n0, n1 = shape
    if len(keys) == 1:  # one row of panels, wrapped at 6
        ncols = min(6, len(rows))
        nrows = math.ceil(len(rows) / ncols)
        cells = [(i // ncols, i % ncols) for i in range(len(rows))]
    else:  # a grid: columns key 0, rows key 1 (top row: its largest value)
        ncols, nrows = n0, n1
        cells = [(n1 - 1 - (k % n1), k // n1) for k in range(len(rows))]
    fig, axes = plt.subplots(nrows, ncols, figsize=(2.5 * ncols, 2.4 * nrows + 0.6), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    shown = {k: shown_as(k, base) for k in keys}
    # one unit for every panel, as in every other figure: mm and mm/s (µm for a base scene
    # whose amplitude is under 0.1 mm)
    from ...plots import length_scale
    scale, prefix = length_scale(base) if base is not None else (1e3, "m")
    for k, (row, (r, c)) in enumerate(zip(rows, cells)):
        ax = axes[r, c]
        ax.axis("on")
        label = ", ".join(panel_label(shown[key][2], shown[key][1](row[key]) if is_numeric([row[key]]) else row[key],
                                      shown[key][3]) for key in keys)
        x, v = portraits["x"][k], portraits["v"][k]
        if row["status"] == STATUS_OK and np.isfinite(x).all():
            ax.plot(x * scale, v * scale, lw=0.9, color="C0")
        else:
            ax.text(0.5, 0.5, "failed", ha="center", va="center", color="C3", transform=ax.transAxes)
        ax.set_title(label, fontsize=8)
        ax.tick_params(labelsize=6)
        ax.grid(alpha=0.3)
    fig.supxlabel(f"x [{prefix}m]", fontsize=8)
    fig.supylabel(f"v [{prefix}m/s]", fontsize=8)
    fig.suptitle(f"{title}: phase portraits v(x) on the window", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
