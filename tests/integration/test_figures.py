"""tribofmu figures: the paper's figures, units on every axis, no overlapping tick labels, saved
runs reused, a cheap subset from the command line (never the full Fig. 6 here)."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tribofmu import api, figures

from scenes import ROOT
SCENES = ROOT / "scenarios"


def fake_run(scene: str, overrides=None) -> figures.Signals:
    """Signals with the shape of a real run (no simulation): a slipping, clipped response."""
    sc = api.load(SCENES / scene, overrides)
    t = np.linspace(*sc.window, 1501)
    w, A = sc.drive.omega, sc.drive.A
    X, V = A * np.cos(w * t), -A * w * np.sin(w * t)
    x, v = 0.6 * A * np.cos(w * t - 0.7), np.clip(V, -0.5 * A * w, 0.5 * A * w)
    f = 1.0 + 5.0 * np.abs(np.sin(w * t))
    return figures.Signals(sc, dict(time=t, X=X, V=V, x=x, v=v, F=0 * t, f=f, stuck=0 * t))


@pytest.fixture
def drawn(monkeypatch):
    """Every figure drawn from fake runs; the matplotlib figures kept for inspection."""
    kept = {}

    def keep(fig, path):
        kept[Path(path).stem] = fig
        return path
    monkeypatch.setattr(figures, "_save", keep)
    runs = {"fig2": [fake_run("fig2_dry.toml")], "fig3": [fake_run("fig2_dry.toml")],
            "fig4": [fake_run("fig2_dry.toml", {"drive.omega": w}) for w in figures.FIG4_OMEGAS],
            "fig5": [fake_run(r.scene) for r in figures.FIG5_RUNS], "fig6": [fake_run("fig6_boundary.toml")]}
    for name, draw in figures.DRAW.items():
        draw(runs[name], Path(f"{name}.png"))
    yield kept
    import matplotlib.pyplot as plt
    plt.close("all")


def all_axes(fig):
    return [a for ax in fig.axes for a in (ax, *ax.child_axes)]


def test_layouts_are_the_papers(drawn):
    panels = {name: fig.axes for name, fig in drawn.items()}
    assert len(panels["fig2"]) == 2 and len(panels["fig3"]) == 2 and len(panels["fig6"]) == 3
    assert len(panels["fig4"]) == 6
    assert [ax.get_title() for ax in panels["fig4"]] == [
        f"({c}) ω = {w:g} rad/s" for c, w in zip("abcdef", figures.FIG4_OMEGAS)]
    assert len(panels["fig5"]) == 3  # three stacked panels, the inset in the lowest
    assert [len(ax.child_axes) for ax in panels["fig5"]] == [0, 0, 1]
    assert panels["fig5"][2].child_axes[0].get_title() == "v enlarged [mm/s] vs t [s]"
    assert panels["fig3"][0].get_ylabel() == "X − x [mm]" and panels["fig6"][2].get_ylabel() == "f [1]"


def test_every_axis_has_units_and_no_tick_labels_overlap(drawn):
    for name, fig in drawn.items():
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        for ax in fig.axes:
            assert "[" in ax.get_ylabel() and ax.get_ylabel().endswith("]"), (name, ax.get_ylabel())
            assert not ax.get_xlabel() or ax.get_xlabel().endswith("]"), (name, ax.get_xlabel())
        assert all(ax.get_xlabel() for ax in fig.axes[-3:] if name == "fig4")
        assert fig.axes[-1].get_xlabel().endswith("]"), name
        for ax in all_axes(fig):
            for axis in (ax.xaxis, ax.yaxis):
                boxes = [t.get_window_extent(renderer) for t in axis.get_ticklabels()
                         if t.get_visible() and t.get_text()]
                for a, b in zip(boxes, boxes[1:]):
                    assert not a.overlaps(b), (name, [t.get_text() for t in axis.get_ticklabels()])


def test_a_free_oscillator_draws_no_drive(tmp_path):
    from tribofmu.plots import plot_result
    from tribofmu.api import SimulationResult
    sc = api.load(SCENES / "free_oscillator.toml")
    t = np.linspace(0, sc.stop_time, 301)
    x = sc.block.x0 * np.cos(np.sqrt(2 * sc.block.K / sc.block.M) * t)
    zero = 0 * t
    result = SimulationResult(sc, t, zero, zero, x, zero, zero, zero, zero, True, "completed")
    import matplotlib.pyplot as plt
    shown = []
    original = plt.Figure.savefig

    def spy(fig, path, **kw):
        shown.append([line.get_label() for ax in fig.axes for line in ax.get_lines()])
        return original(fig, path, **kw)
    plt.Figure.savefig = spy
    try:
        plot_result(result, tmp_path)
    finally:
        plt.Figure.savefig = original
    assert shown[0] == ["x (block)", "v (block)"]  # time.png: no drive lines


@pytest.mark.integration
def test_figures_command_subset_reuses_its_runs(tmp_path):
    env = dict(os.environ, TRIBOFMU_CACHE=str(tmp_path / "cache"), PYTHONDONTWRITEBYTECODE="1")
    out = tmp_path / "figs"
    cmd = [sys.executable, "-m", "tribofmu", "figures", "--only", "fig2,fig3", "--out", str(out)]
    first = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert first.returncode == 0, first.stderr
    assert sorted(p.name for p in out.glob("*.png")) == ["fig2.png", "fig3.png"]
    assert "fig2_dry:" in first.stderr  # one simulation, shared by both figures
    assert first.stderr.count("steps,") == 1
    saved = out / "data" / "fig2_dry.npz"
    stamp = saved.stat().st_mtime_ns
    second = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert second.returncode == 0 and "steps," not in second.stderr
    assert saved.stat().st_mtime_ns == stamp
    bad = subprocess.run([*cmd[:4], "--only", "fig9"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert bad.returncode == 2
    assert bad.stderr.strip().splitlines() == [
        "tribofmu: --only fig9: unknown figure 'fig9' (known: fig2, fig3, fig4, fig5, fig6)"]
