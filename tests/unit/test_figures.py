"""The figures and plots drawn from fake runs (no FMU): the paper's layouts, units on every
axis, no overlapping tick labels, titles that show the simulated values, time.png with the
coupled inputs. The ``figures`` command itself: tests/integration/test_figures_command.py."""
from pathlib import Path

import numpy as np
import pytest

from tribofmu import api, figures

from scenes import SCENARIOS
SCENES = SCENARIOS
FIG2 = SCENES / "fig2_dry.toml"


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
    from tribofmu import plots
    monkeypatch.setattr(plots, "save_png", lambda fig, path, dpi=110: keep(fig, path))
    runs = {"friction": [fake_run(r.scene, dict(r.overrides)) for r in figures.FIGURES["friction"]],"fig2": [fake_run("fig2_dry.toml")], "fig3": [fake_run("fig2_dry.toml")],
            "fig4": [fake_run("fig2_dry.toml", {"drive.omega": w}) for w in figures.FIG4_OMEGAS],
            "fig5": [fake_run(r.scene) for r in figures.FIG5_RUNS], "fig6": [fake_run("fig6_boundary.toml")]}
    for name in figures.PAPER_FIGURES:
        figures.DRAW[name](runs[name], Path(f"{name}.png"))
    yield kept
    import matplotlib.pyplot as plt
    plt.close("all")


def all_axes(fig):
    return [a for ax in fig.axes for a in (ax, *ax.child_axes)]


def test_layouts_are_the_papers(drawn):
    panels = {name: fig.axes for name, fig in drawn.items()}
    assert len(panels["fig2"]) == 2 and len(panels["fig3"]) == 2 and len(panels["fig6"]) == 3
    assert [name for name in panels if name.startswith("friction_")] == [
        f"friction_{r.label}" for r in figures.FIGURES["friction"]]
    assert len(panels["friction_fig2_dry"]) == 3 and len(panels["friction_fig6_boundary"]) == 4  # + f(t)
    assert len(panels["fig4"]) == 6
    assert [ax.get_title() for ax in panels["fig4"]] == [
        f"({c}) ω = {w:g} rad/s" for c, w in zip("abcdef", figures.FIG4_OMEGAS)]
    assert len(panels["fig5"]) == 3  # three stacked panels, the inset in the lowest
    assert [len(ax.child_axes) for ax in panels["fig5"]] == [0, 0, 1]
    assert panels["fig5"][2].child_axes[0].get_title() == "v enlarged [mm/s]"
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


def test_one_unit_per_quantity_and_titles_wrapped_between_items(drawn):
    import re
    for name, fig in drawn.items():
        units = {re.search(r"\[(.*)\]", label).group(1) for ax in fig.axes
                 for label in (ax.get_xlabel(), ax.get_ylabel()) if label and not label.startswith(("t ", "f "))}
        positions = {u for u in units if u.endswith("m")}
        velocities = {u for u in units if u.endswith("m/s")}
        assert len(positions) <= 1 and len(velocities) <= 1, (name, units)
        expected = "µ" if name.endswith("fig6") or name.endswith("fig6_boundary") else "m"  # the 1.4 µm boundary scene: µm; else mm
        assert all(u.startswith(expected) for u in positions | velocities), (name, units)
        text = fig._suptitle.get_text()
        assert "e-0" not in text and "0.002 m" not in text, text
        for line in text.split("\n")[:-1]:  # a line ends after an item, never inside "μ = 0.5"
            assert not line.rstrip().endswith("="), text
        for line in text.split("\n")[1:]:
            assert not line.startswith(("=", "0", "1", "2", "3", "4", "5", "6", "7", "8", "9")), text


def test_the_fig5_inset_is_legible(drawn):
    inset = drawn["fig5"].axes[2].child_axes[0]
    sizes = [t.get_fontsize() for axis in (inset.xaxis, inset.yaxis) for t in axis.get_ticklabels()]
    assert sizes and min(sizes) >= 8


def test_titles_wrap_only_between_items():
    from tribofmu.plots import scene_label, wrap_items
    for name in ("fig2_dry", "fig6_boundary", "boundary_heating", "dry_load_oscillation", "fig5_pseudoplastic"):
        label = scene_label(api.load(name, {"drive.omega": 12.345678}))
        for width in range(20, 120, 7):
            lines = wrap_items(label, width).split("\n")
            assert " ".join(lines) == label
            for line in lines[:-1]:
                assert line.endswith((",", ";", ":")) or lines[lines.index(line) + 1].startswith("—"), lines
    assert "L(t): 15–75 N" in scene_label(api.load("dry_load_oscillation"))
    assert "T: 290 K → film heating" in scene_label(api.load("boundary_heating"))
    assert "A = 1.4 µm" in scene_label(api.load("fig6_boundary"))


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


def test_accuracy_chart_labels_neither_overprint_nor_clip(tmp_path, monkeypatch):
    from tribofmu import plots
    from tribofmu.studies.accuracy import plot_accuracy
    kept = {}
    monkeypatch.setattr(plots, "save_png", lambda fig, path, dpi=110: kept.setdefault("fig", fig))
    rows = []
    for step, err, wall in ((1e-3, 0.3, 0.08), (3e-4, 0.14, 0.22), (1e-4, 0.054, 0.65), (3e-5, 0.014, 2.1)):
        for name, w in (("jacobi", wall), ("gauss-seidel", wall * 1.02)):  # the same points, twice
            rows.append(dict(algorithm=name, step=step, tol=None, nrms_v=err, wall_time_s=w))
    for tol, err, wall in ((1e-2, 3.8e-3, 0.23), (1e-3, 7.9e-4, 0.18), (2e-4, 9.9e-5, 0.18), (1e-4, 4.2e-5, 0.19)):
        rows.append(dict(algorithm="adaptive", step=None, tol=tol, nrms_v=err, wall_time_s=wall, default=tol == 2e-4))
    plot_accuracy(rows, {"reference_wall_time_s": 0.03}, "fig2_dry: error vs cost", tmp_path / "a.png")
    fig = kept["fig"]
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    ax = fig.axes[0]
    notes = [t for t in ax.texts]
    assert sorted(t.get_text() for t in notes).count("h=0.0001 s") == 1  # one label for both lines
    boxes = [t.get_window_extent(renderer) for t in notes]
    frame = ax.get_window_extent(renderer)
    (legend,) = fig.legends  # below the axes, whole inside the figure, overlapping no axes
    box, page = legend.get_window_extent(renderer), fig.bbox
    assert page.x0 <= box.x0 and box.x1 <= page.x1 and page.y0 <= box.y0 and box.y1 < frame.y0
    assert {"jacobi", "gauss-seidel", "adaptive"} <= {t.get_text() for t in legend.get_texts()}
    sizes = {line.get_label(): line.get_markersize() for line in ax.get_lines()}
    assert sizes["jacobi"] != sizes["gauss-seidel"]  # the same points: one line's markers ring the other's
    for i, a in enumerate(boxes):
        assert frame.x0 <= a.x0 and a.x1 <= frame.x1, notes[i].get_text()  # not clipped
        for b, other in zip(boxes[i + 1:], notes[i + 1:]):
            assert not a.overlaps(b), (notes[i].get_text(), other.get_text())
    import matplotlib.pyplot as plt
    plt.close(fig)


def test_figs_2_and_4_mark_stick_and_no_legend_covers_a_curve(monkeypatch):
    """Stick shaded in both panels of Fig. 2 and drawn over the portraits of Fig. 4 (as in
    time.png); a legend sits where no curve runs (headroom above the curves, or below the
    panels)."""
    kept = {}
    monkeypatch.setattr(figures, "_save", lambda fig, path: kept.setdefault(Path(path).stem, fig))

    def sticking(scene, overrides=None):
        r = fake_run(scene, overrides)
        r.stuck = (np.abs(r.V - r.v) < 1e-12).astype(float)  # where v follows V (not clipped)
        assert 0 < r.stuck.mean() < 1
        return r
    figures.DRAW["fig2"]([sticking("fig2_dry.toml")], Path("fig2.png"))
    figures.DRAW["fig4"]([sticking("fig2_dry.toml", {"drive.omega": w}) for w in figures.FIG4_OMEGAS],
                         Path("fig4.png"))
    fig2, fig4 = kept["fig2"], kept["fig4"]
    assert all(ax.collections for ax in fig2.axes)  # the stuck intervals, shaded in both panels
    assert "stuck (x follows X)" in [t.get_text() for t in fig2.axes[1].get_legend().get_texts()]
    assert all("stuck" in [line.get_label() for line in ax.get_lines()] for ax in fig4.axes)
    assert [t.get_text() for t in fig4.legends[0].get_texts()] == ["slipping", "stuck"]
    for fig in (fig2, fig4):
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        legends = [ax.get_legend() for ax in fig.axes if ax.get_legend()] + list(fig.legends)
        for legend in legends:
            box = legend.get_window_extent(renderer)
            for ax in fig.axes:
                for line in ax.get_lines():
                    xy = ax.transData.transform(np.column_stack(line.get_data()))
                    xy = xy[np.isfinite(xy).all(axis=1)]
                    inside = (xy[:, 0] > box.x0) & (xy[:,0] < box.x1) & (xy[:, 1] > box.y0) & (xy[:, 1] < box.y1)
                    assert not inside.any(), (line.get_label(), "under the legend")
    import matplotlib.pyplot as plt
    plt.close("all")


def test_plot_titles_show_the_simulated_values():
    from tribofmu.plots import scene_label
    label = scene_label(api.load(FIG2, {"drive.omega": 80.0, "conditions.n": -33.0}))
    assert "ω = 80 rad/s" in label and "L = 33 N" in label and "30" not in label


def test_time_png_draws_the_coupled_inputs(tmp_path):
    import matplotlib.pyplot as plt
    from tribofmu import plots
    drawn = {}
    original = plots.save_png

    def keep(fig, path, dpi=110):
        drawn[Path(path).name] = [ax.get_ylabel() for ax in fig.axes] + [fig._suptitle.get_text() if fig._suptitle else ""]
        plt.close(fig)
        return Path(path)
    plots.save_png = keep
    try:
        for name in ("boundary_heating", "dry_load_oscillation", "fig2_dry"):
            sc = api.load(name)
            t = np.linspace(0, sc.stop_time, 200)
            s = {k: np.sin(t) for k in ("X", "V", "x", "v", "F", "f", "stuck")}
            s.update(time=t, T=290 + 1000 * t / t[-1], n=np.array([sc.normal_stress(x) for x in t]), Q=t)
            plots.plot_signals(s, sc, tmp_path)
            labels = drawn["time.png"]
            assert ("T [K]" in labels) == (name == "boundary_heating"), labels
            assert ("load L [N]" in labels) == (name == "dry_load_oscillation"), labels
            if name == "boundary_heating":
                assert "T: 290 K → 1290 K" in labels[-1]
    finally:
        plots.save_png = original


def _drawn_figures(monkeypatch):
    """Every figure plots.save_png is given, by file name: its axes' labels, titles, legend
    texts and the figure's title."""
    import matplotlib.pyplot as plt
    from tribofmu import plots
    drawn = {}

    def keep(fig, path, dpi=110):
        drawn[Path(path).name] = {
            "ylabels": [ax.get_ylabel() for ax in fig.axes], "xlabels": [ax.get_xlabel() for ax in fig.axes],
            "titles": [ax.get_title() for ax in fig.axes],
            "lines": [line.get_label() for ax in fig.axes for line in ax.get_lines()],
            "suptitle": fig._suptitle.get_text() if fig._suptitle else ""}
        plt.close(fig)
        return Path(path)
    monkeypatch.setattr(plots, "save_png", keep)
    return drawn


def _fake_signals(sc):
    t = np.linspace(0, sc.stop_time, 400)
    s = {k: np.sin(30 * t) * 1e-3 for k in ("X", "V", "x", "v")}
    s.update(F=5 * np.sin(30 * t), f=1 + np.sin(30 * t), stuck=(np.sin(60 * t) > 0.5).astype(float), time=t,
             T=290 + 200 * t / t[-1], n=np.array([sc.normal_stress(x) for x in t]), Q=t)
    return s


@pytest.mark.parametrize("name", sorted(p.stem for p in SCENES.glob("*.toml")))
def test_every_shipped_scene_with_friction_draws_friction_png(name, tmp_path, monkeypatch):
    from tribofmu import plots
    drawn = _drawn_figures(monkeypatch)
    sc = api.load(name, {"drive.omega": 31.5} if "Drive" in api.load(name).fmus else None)
    paths = plots.plot_signals(_fake_signals(sc), sc, tmp_path)
    if "Friction" not in sc.fmus:
        assert "friction.png" not in drawn and len(paths) == 2
        return
    fig = drawn["friction.png"]
    assert tmp_path / "friction.png" in paths
    assert fig["ylabels"][0].startswith("F [") and "t [s]" in fig["xlabels"]
    assert any(x.startswith("dv = V − v [") for x in fig["xlabels"]) and any(x.startswith("X − x (sliding displacement) [") for x in fig["xlabels"])
    assert "friction loop F(dv)" in fig["titles"] and "friction loop F(X − x)" in fig["titles"]
    assert name in fig["suptitle"] and "ω = 31.5 rad/s" in fig["suptitle"].replace("\n", " ")
    law = sc.friction.law()
    assert ("f [1]" in fig["ylabels"]) == (law.melt_threshold() is not None)
    assert ("T [K]" in fig["ylabels"]) == ("Thermal" in sc.fmus)
    curve = [label for label in fig["lines"] if label.startswith("the law's F(dv)")]
    assert bool(curve) == (not law.has_state and "Load" not in sc.fmus), fig["lines"]


def test_the_mixed_laws_curve_is_the_laws_own_stribeck_curve():
    from tribofmu.plots import law_curve
    sc = api.load("mixed_stribeck")
    law = sc.friction.law()
    dv, F = law_curve(sc, -0.1, 0.05)
    L = law.load(sc.conditions.n)
    assert dv.min() == pytest.approx(-0.1) and dv.max() == pytest.approx(0.1)
    # at rest the static limit mu_s L on both sides; far out mu_c L + m dv; in between the law's
    at_rest = F[dv == 0.0]
    assert sorted(at_rest) == pytest.approx([-law.mu_static * L, law.mu_static * L])
    assert F[-1] == pytest.approx(law.mu_friction * L + law.m * 0.1, rel=1e-6)
    i = int(np.argmin(np.abs(dv - law.v_stribeck)))
    assert F[i] == pytest.approx(law.force(float(dv[i]), sc.conditions.n))
    assert law_curve(api.load("fig6_boundary"), -1e-4, 1e-4) is None  # F depends on the film's f


def test_no_shipped_scene_title_states_a_value_an_override_would_falsify():
    """The title travels into stats.json and the scene list: "w = 30 rad/s" stayed there under
    --set drive.omega=80. The values are the figures' (scene_label, from what was simulated)."""
    import re
    for path in sorted(SCENES.glob("*.toml")):
        title = api.load(path).title
        assert title and not re.search(r"=\s*[-+]?\d|\d\s*(rad/s|N|K|Pa)\b", title), (path.name, title)
