"""The sweep's pictures: counts (stick episodes, harmonics) drawn as points, never as lines
between points; each portrait's title gives the swept value with its unit."""
from __future__ import annotations

import math

import numpy as np


def test_counts_are_points_and_portraits_name_their_units(tmp_path, monkeypatch):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tribofmu import api
    from tribofmu.metrics import METRICS
    from tribofmu.studies.sweep import plots
    from tribofmu.studies.sweep.worker import STATUS_OK

    figures = []
    monkeypatch.setattr(plt, "close", lambda fig=None: figures.append(fig))
    rows = []
    from tribofmu.studies.sweep import parse_grid
    for k, omega in enumerate(parse_grid(["drive.omega=10,30,130"])["drive.omega"]):  # as a sweep reads them
        row = {"drive.omega": omega, "status": STATUS_OK, "message": ""}
        row.update({m: math.nan for m in METRICS})
        row.update(stick_fraction=0.5 - 0.1 * k, stick_episodes_per_period=6 - 2 * k, harmonics=9 - 4 * k,
                   amplitude_ratio=0.4 + 0.3 * k, dissipated_per_cycle=0.05)
        rows.append(row)
    t = np.linspace(0, 2 * np.pi, 400)
    portraits = {"x": np.array([np.cos(t) * 1e-3] * 3), "v": np.array([np.sin(t) * 1e-2] * 3)}
    paths = plots.plot_sweep(rows, ["drive.omega"], portraits, tmp_path, base=api.load("fig2_dry"))
    assert [p.name for p in paths] == ["sweep.png", "portraits.png"]
    sweep_fig, portraits_fig = figures
    styles = {ax.get_ylabel(): ax.get_lines()[0].get_linestyle() for ax in sweep_fig.axes if ax.get_lines()}
    assert styles["stick episodes / period"] == styles["harmonics of x"] == "None"
    assert styles["stick fraction"] == styles["max|x| / A"] == "-"
    titles = [ax.get_title() for ax in portraits_fig.axes if ax.get_title()]
    assert titles == ["omega = 10 rad/s", "omega = 30 rad/s", "omega = 130 rad/s"]
    monkeypatch.undo()
    for fig in figures:
        plt.close(fig)


def test_a_regime_map_over_the_normal_stress_of_dry_friction_reads_the_load_in_newtons(tmp_path, monkeypatch):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from tribofmu import api
    from tribofmu.metrics import METRICS
    from tribofmu.studies.sweep import parse_grid, plots
    from tribofmu.studies.sweep.worker import STATUS_OK

    figures = []
    monkeypatch.setattr(plt, "close", lambda fig=None: figures.append(fig))
    grid = parse_grid(["drive.omega=30,80", "conditions.n=-10,-20,-40"])
    rows = []
    for omega in grid["drive.omega"]:
        for n in grid["conditions.n"]:
            row = {"drive.omega": omega, "conditions.n": n, "status": STATUS_OK, "message": ""}
            row.update({m: math.nan for m in METRICS})
            row["stick_fraction"] = -n / 100.0
            rows.append(row)
    t = np.linspace(0, 2 * np.pi, 400)
    portraits = {"x": np.array([np.cos(t) * 1e-3] * 6), "v": np.array([np.sin(t) * 1e-2] * 6)}
    base = api.load("fig2_dry", {"friction.S": 2.0})  # L = -n S: 20, 40, 80 N
    plots.plot_sweep(rows, ["drive.omega", "conditions.n"], portraits, tmp_path, base=base)
    stick_map, portraits_fig = figures
    ax = stick_map.axes[0]
    assert ax.get_ylabel() == "load L = −n S [N]"
    assert [t.get_text() for t in ax.get_yticklabels()] == ["20", "40", "80"]
    titles = [a.get_title() for a in portraits_fig.axes if a.get_title()]
    assert "omega = 30 rad/s, L = 40.0 N" in titles, titles
    monkeypatch.undo()
    for fig in figures:
        plt.close(fig)
