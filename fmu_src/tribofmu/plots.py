"""Figures of one run: X, x and V, v over the shown window; the phase portrait v(x).

Titles are made from the values actually simulated (:func:`scene_label`), never from the
scene file's title text, so a run with ``--set drive.omega=80`` says 80 rad/s. Axes carry
units, scaled to a readable prefix (mm, um, ...) instead of matplotlib's offset text.
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no screen needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

_PREFIXES = ((1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"))


def unit_scale(values, unit: str) -> tuple[float, str]:
    """``(factor, label)``: values * factor read in ``label`` (e.g. 1e3, "mm" for metres ~1e-3)."""
    top = float(np.nanmax(np.abs(values))) if np.size(values) else 0.0
    for size, prefix in _PREFIXES:
        if top >= size * 0.999 or size == _PREFIXES[-1][0]:
            return 1.0 / size, prefix + unit
    return 1.0, unit  # pragma: no cover


def _fmt(value: float) -> str:
    return f"{value:.4g}"


def has_drive(sc) -> bool:
    return "Drive" in sc.fmus


def has_friction(sc) -> bool:
    return "Friction" in sc.fmus


def scene_label(sc) -> str:
    """One line naming the regime and the simulated parameters that shape the figure."""
    parts = []
    if has_drive(sc):
        parts.append(f"A = {_fmt(sc.drive.A)} m, ω = {_fmt(sc.drive.omega)} rad/s")
    parts.append(f"M = {_fmt(sc.block.M)} kg, K = {_fmt(sc.block.K)} N/m")
    if not has_friction(sc):
        regime = "no friction"
        if sc.block.x0 or sc.block.v0:
            parts.append(f"x0 = {_fmt(sc.block.x0)} m, v0 = {_fmt(sc.block.v0)} m/s")
    else:
        fr = sc.friction
        regime = f"{fr.regime} friction"
        if fr.regime == "dry":
            parts.append(f"μ = {_fmt(fr.mu_friction)}, L = {_fmt(sc.load)} N")
        elif fr.regime == "fluid":
            parts.append(f"m = {_fmt(fr.m)}, γ = {_fmt(fr.gamma)}")
        else:
            parts.append(f"m = {_fmt(fr.m)}, γ = {_fmt(fr.gamma)}, n = {_fmt(sc.conditions.n)} Pa, "
                         f"T = {_fmt(sc.conditions.T)} K")
    return f"{sc.name}: {regime}; " + ", ".join(parts)


def draw_pair(ax, t, drive, block, factor: float, drive_label: str, block_label: str, color: str,
              show_drive: bool = True) -> None:
    """The drive's signal dashed (only when there is a drive) and the block's solid."""
    if show_drive:
        ax.plot(t, drive * factor, "--", color="0.35", lw=1.2, label=drive_label)
    ax.plot(t, block * factor, "-", color=color, lw=1.4, label=block_label)


def finish_axes(axes) -> None:
    for ax in np.ravel(axes):
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="best", fontsize=8, framealpha=0.85)


def title(fig, text: str, width: int = 90, fontsize: float = 9) -> None:
    """A figure title wrapped to the figure's width (long parameter lists must not be cut)."""
    import textwrap
    fig.suptitle(textwrap.fill(text, width), fontsize=fontsize)


def plot_result(result, out_dir: Path) -> list[Path]:
    """Write time.png (with f(t) for boundary friction) and phase.png; returns their paths."""
    out_dir = Path(out_dir)
    sc = result.scenario
    m = result.window_mask()
    t = result.time[m]
    paths = []
    drive = has_drive(sc)
    boundary = sc.friction.regime == "boundary" and has_friction(sc)
    rows = 3 if boundary else 2
    fig, axes = plt.subplots(rows, 1, figsize=(7.5, 2.5 * rows + 0.6), sharex=True)
    k, unit = unit_scale(np.concatenate([result.x[m], result.X[m] if drive else []]), "m")
    draw_pair(axes[0], t, result.X[m], result.x[m], k, "X (drive)", "x (block)", "C0", drive)
    axes[0].set_ylabel(f"position [{unit}]")
    k, unit = unit_scale(np.concatenate([result.v[m], result.V[m] if drive else []]), "m/s")
    draw_pair(axes[1], t, result.V[m], result.v[m], k, "V (drive)", "v (block)", "C3", drive)
    axes[1].set_ylabel(f"velocity [{unit}]")
    if boundary:
        lub = sc.friction.lubricant
        axes[2].plot(t, result.f[m], color="C2", label="f (excess volume)")
        axes[2].axhline(lub.mu_shear / lub.mu_shear_bar, color="0.5", lw=0.8, ls=":",
                        label="melting: f = μ/μ̄")
        axes[2].set_ylabel("f [1]")
    finish_axes(axes)
    axes[-1].set_xlabel("t [s]")
    title(fig, scene_label(sc))
    fig.tight_layout()
    paths.append(out_dir / "time.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(5, 4.4))
    kx, ux = unit_scale(result.x[m], "m")
    kv, uv = unit_scale(result.v[m], "m/s")
    ax.plot(result.x[m] * kx, result.v[m] * kv, color="C0")
    ax.set_xlabel(f"x [{ux}]")
    ax.set_ylabel(f"v [{uv}]")
    label = f"phase portrait v(x), ω = {_fmt(sc.drive.omega)} rad/s" if drive else "phase portrait v(x)"
    ax.set_title(label, fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    paths.append(out_dir / "phase.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    return paths

