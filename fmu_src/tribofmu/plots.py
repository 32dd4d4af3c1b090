"""Figures like the paper's: X, x and V, v over the shown window; the phase portrait v(x)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no screen needed
import matplotlib.pyplot as plt  # noqa: E402


def plot_result(result, out_dir: Path) -> list[Path]:
    """Write time.png (and kinetics.png for boundary friction) and phase.png; returns paths."""
    out_dir = Path(out_dir)
    sc = result.scenario
    m = result.window_mask()
    t = result.time[m]
    paths = []

    boundary = sc.friction.regime == "boundary" and "Friction" in sc.fmus
    rows = 3 if boundary else 2
    fig, axes = plt.subplots(rows, 1, figsize=(7, 2.4 * rows), sharex=True)
    axes[0].plot(t, result.X[m], "--", color="0.4", label="X (drive)")
    axes[0].plot(t, result.x[m], "-", color="C0", label="x (block)")
    axes[0].set_ylabel("position [m]")
    axes[1].plot(t, result.V[m], "--", color="0.4", label="V (drive)")
    axes[1].plot(t, result.v[m], "-", color="C3", label="v (block)")
    axes[1].set_ylabel("velocity [m/s]")
    if boundary:
        mu_melt = sc.friction.lubricant.mu_shear / sc.friction.lubricant.mu_shear_bar
        axes[2].plot(t, result.f[m], color="C2", label="f (excess volume)")
        axes[2].axhline(mu_melt, color="0.6", lw=0.8, ls=":", label="melting: f = mu/mub")
        axes[2].set_ylabel("f [1]")
    for ax in axes:
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(sc.title or sc.name, fontsize=10)
    fig.tight_layout()
    paths.append(out_dir / "time.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(4.5, 4))
    ax.plot(result.x[m], result.v[m], color="C0")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("v [m/s]")
    ax.set_title(f"phase portrait, w = {sc.drive.omega:g} rad/s", fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    paths.append(out_dir / "phase.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    return paths
