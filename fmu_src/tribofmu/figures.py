"""``tribofmu figures``: the paper's Figs. 2-6 from the scenes, one PNG per figure.

- Fig. 2 (``fig2_dry``): X, x (upper panel) and V, v (lower panel) over the shown window;
  dashed: the drive, solid: the block.
- Fig. 3: the same run's relative displacement X - x and relative velocity V - v.
- Fig. 4: six phase portraits v(x), (a)-(f) at w = 10, 20, 30, 50, 80, 130 rad/s, the
  parameters of Fig. 2 otherwise (``fig2_dry`` with ``drive.omega`` set; (f) is
  ``fig4_dry_w130``).
- Fig. 5: V and v in three stacked panels, gamma = -2/3, 0, 2/3 (``fig5_pseudoplastic``,
  ``fig5_newtonian``, ``fig5_dilatant``); the lower panel has an inset enlarging v(t).
- Fig. 6 (``fig6_boundary``): X, x and V, v, plus the lubricant's excess volume f(t) with
  the melting point f = mu/mub.
- ``friction``: ``friction_<run>.png`` for each of the paper's scenes (Fig. 2's, Fig. 4's
  130 rad/s run, Fig. 5's three, Fig. 6's): the friction force F(t) with the stick bands, the
  friction loops F(dv) (under it the law's own F(dv) where F is a curve of dv) and F(X − x),
  and f(t) for the boundary lubricant (:func:`tribofmu.plots.draw_friction`, the figure
  ``tribofmu simulate`` writes as friction.png).
- ``tn_map`` (not of the paper, only with ``--only tn_map``; about 10 s, no FMU): the
  boundary film at rest under a slow temperature ramp up and back down at each load: where
  melting and solidification happen at different temperatures (the T x n hysteresis band).

Positions are in mm and velocities in mm/s in every figure (µm, µm/s for the boundary
scenes, whose amplitude is 1.4 µm): :func:`tribofmu.plots.length_scale`.

Each run's signals on the window are saved in ``OUT/data/<run>.npz`` (or ``--data DIR``)
with a key made of the scene file, the overrides, the hash of the sources a result depends
on and the versions of fmpy and pythonfmu: a second call redraws from them when nothing
changed (``--rerun`` simulates again).
"""
from __future__ import annotations

import hashlib
import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

FIG4_OMEGAS = (10.0, 20.0, 30.0, 50.0, 80.0, 130.0)
SIGNALS = ("time", "X", "V", "x", "v", "F", "f", "stuck")


@dataclass(frozen=True)
class Run:
    """One simulation a figure needs: a scene file and its overrides."""

    label: str
    scene: str  # file name in the scenes' folder
    overrides: tuple[tuple[str, str], ...] = ()


def _fig4_runs() -> list[Run]:
    runs = []
    for omega in FIG4_OMEGAS:
        if omega == 130.0:
            runs.append(Run("fig4_w130", "fig4_dry_w130.toml"))
        elif omega == 30.0:
            runs.append(Run("fig2_dry", "fig2_dry.toml"))
        else:
            runs.append(Run(f"fig4_w{omega:g}", "fig2_dry.toml", (("drive.omega", f"{omega:g}"),)))
    return runs


FIG5_RUNS = [Run("fig5_pseudoplastic", "fig5_pseudoplastic.toml"), Run("fig5_newtonian", "fig5_newtonian.toml"),
             Run("fig5_dilatant", "fig5_dilatant.toml")]
FIGURES = {
    "fig2": [Run("fig2_dry", "fig2_dry.toml")],
    "fig3": [Run("fig2_dry", "fig2_dry.toml")],
    "fig4": _fig4_runs(),
    "fig5": FIG5_RUNS,
    "fig6": [Run("fig6_boundary", "fig6_boundary.toml")],
    "friction": [Run("fig2_dry", "fig2_dry.toml"), Run("fig4_w130", "fig4_dry_w130.toml"), *FIG5_RUNS,
                 Run("fig6_boundary", "fig6_boundary.toml")],
    "tn_map": [],  # the friction law alone, no simulation
}
PAPER_FIGURES = ("fig2", "fig3", "fig4", "fig5", "fig6", "friction")  # what a plain 'tribofmu figures' draws


class Signals:
    """A run's signals on its shown window (SI units) and its scenario."""

    def __init__(self, scenario, arrays: dict[str, np.ndarray]):
        self.scenario = scenario
        for name in SIGNALS:
            setattr(self, name, arrays[name])


# The sources a simulated result depends on (not the drawing code): saved results are
# reused only when these are unchanged.
RESULT_SOURCES = ("physics", "fmu", "coupling", "master", "scene", "api.py", "build.py")


def code_hash() -> str:
    """Hash of the sources in :data:`RESULT_SOURCES` and the versions of fmpy and pythonfmu."""
    from .provenance import versions
    package = Path(__file__).resolve().parent
    digest = hashlib.sha256(json.dumps(versions(), sort_keys=True).encode())
    files = []
    for rel in RESULT_SOURCES:
        path = package / rel
        files += sorted(path.rglob("*.py")) if path.is_dir() else [path]
    for path in files:
        digest.update(path.relative_to(package).as_posix().encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


def _key(scene_path: Path, run: Run, code: str) -> str:
    text = json.dumps([scene_path.read_text(), list(run.overrides), code])
    return hashlib.sha256(text.encode()).hexdigest()


def _load_or_simulate(run: Run, scenarios_dir: Path, data_dir: Path, fmu_dir, rerun: bool, quiet: bool,
                      code: str, written: list) -> Signals:
    from . import api
    from .atomic import atomic_write_bytes
    from .progress import RunBar

    path = scenarios_dir / run.scene
    scenario = api.load(path, [f"{k}={v}" for k, v in run.overrides])
    key = _key(path, run, code)
    saved = data_dir / f"{run.label}.npz"
    if saved.is_file() and not rerun:
        with np.load(saved) as data:
            if str(data["key"]) == key:
                return Signals(scenario, {name: data[name] for name in SIGNALS})
    with RunBar(f"{run.label}", scenario.stop_time, enabled=False if quiet else None) as bar:
        result = api.simulate(scenario, fmu_dir=fmu_dir, build=False, progress=bar)
    if not result.ok:
        raise RuntimeError(f"{run.label}: {result.message}")
    m = result.window_mask()
    arrays = {name: np.asarray(getattr(result, name))[m] for name in SIGNALS}
    import io
    buffer = io.BytesIO()
    np.savez_compressed(buffer, key=np.array(key), **arrays)
    atomic_write_bytes(saved, buffer.getvalue())
    written.append(saved)
    if not quiet:
        print(f"{run.label}: {result.stats['communication_steps']} steps, "
              f"{result.stats['wall_time']:.1f} s", file=sys.stderr)
    return Signals(scenario, arrays)


def make_figures(out_dir: str | Path = "out/figures", only: list[str] | None = None,
                 scenarios_dir: str | Path | None = None, fmu_dir: str | Path | None = None,
                 rerun: bool = False, quiet: bool = False, data_dir: str | Path | None = None,
                 written: list | None = None) -> list[Path]:
    """Write ``OUT/fig2.png`` .. ``fig6.png`` and ``friction_<run>.png`` (or the ``only``
    ones); returns their paths.

    data_dir: where the runs' signals are saved and reused (default ``OUT/data``). written:
    a list that gets each file (figure or saved run) as soon as it is complete."""
    written = written if written is not None else []
    from .fmu_cache import find_fmus

    from .scene.library import scenes_dir

    out_dir = Path(out_dir)
    scenarios_dir = Path(scenarios_dir) if scenarios_dir else scenes_dir()
    if not scenarios_dir.is_dir():
        raise FileNotFoundError(f"scenes folder not found: {scenarios_dir} (--scenarios DIR)")
    names = list(only) if only else list(PAPER_FIGURES)
    fmu_dir = find_fmus(("Drive", "BlockSpring", "Friction"), fmu_dir, build=None if fmu_dir is None else False,
                        notice=None if quiet else (lambda text: print(f"tribofmu: {text}", file=sys.stderr)))
    data_dir = Path(data_dir) if data_dir else out_dir / "data"
    code = code_hash()
    results: dict[str, Signals] = {}
    paths = []
    for name in names:
        for run in FIGURES[name]:
            if run.label not in results:
                results[run.label] = _load_or_simulate(run, scenarios_dir, data_dir, fmu_dir, rerun,
                                                       quiet, code, written)
        runs = [results[run.label] for run in FIGURES[name]]
        if name == "tn_map":
            runs = [api_load(scenarios_dir / "fig6_boundary.toml")]
        drawn = DRAW[name](runs, out_dir / f"{name}.png")
        paths += drawn if isinstance(drawn, list) else [drawn]
        written += drawn if isinstance(drawn, list) else [drawn]
    return paths


def output_names(names=PAPER_FIGURES) -> list[str]:
    """The file names :func:`make_figures` writes for these figures (what docs/ may cite)."""
    out = []
    for name in names:
        out += ([f"friction_{run.label}.png" for run in FIGURES[name]] if name == "friction" else [f"{name}.png"])
    return out


def api_load(path: Path):
    from . import api
    return api.load(path)


# -- drawing -------------------------------------------------------------------------------------
def _plt():
    from .plots import pyplot
    return pyplot()


def _save(fig, path: Path) -> Path:
    from .plots import save_png
    return save_png(fig, path, dpi=120)


def _time_pair(axes, r: Signals, first: str, second: str) -> None:
    """Upper: X (dashed), x (solid); lower: V (dashed), v (solid), in the scene's units."""
    from .plots import draw_pair, length_scale
    k, prefix = length_scale(r.scenario)
    draw_pair(axes[0], r.time, r.X, r.x, k, "X (upper block)", "x (lower block)", "C0")
    axes[0].set_ylabel(f"{first} [{prefix}m]")
    draw_pair(axes[1], r.time, r.V, r.v, k, "V (upper block)", "v (lower block)", "C3")
    axes[1].set_ylabel(f"{second} [{prefix}m/s]")


def _time_figure(runs, path: Path, heading: str, draw, rows: int = 2, height: float = 6.0) -> Path:
    """One run on `rows` panels over a shared t axis, filled by draw(axes, run); the title is
    heading followed by the scene's label."""
    from .plots import finish_axes, scene_label, title
    plt = _plt()
    (r,) = runs
    fig, axes = plt.subplots(rows, 1, figsize=(7.5, height), sharex=True)
    draw(axes, r)
    axes[-1].set_xlabel("t [s]")
    finish_axes(axes)
    title(fig, heading + scene_label(r.scenario))
    fig.tight_layout()
    return _save(fig, path)


def draw_fig2(runs, path: Path) -> Path:
    from .plots import shade_stuck

    def draw(axes, r):
        _time_pair(axes, r, "X, x", "V, v")
        shade_stuck(axes[0], r.time, r.stuck, None)  # where the blocks stick, labelled once
        shade_stuck(axes[1], r.time, r.stuck, "stuck (x follows X)")
    return _time_figure(runs, path, "Fig. 2 — ", draw)


def draw_fig3(runs, path: Path) -> Path:
    from .plots import length_scale

    def draw(axes, r):
        k, prefix = length_scale(r.scenario)
        axes[0].plot(r.time, (r.X - r.x) * k, color="C0", label="X − x")
        axes[0].set_ylabel(f"X − x [{prefix}m]")
        axes[1].plot(r.time, (r.V - r.v) * k, color="C3", label="V − v")
        axes[1].set_ylabel(f"V − v [{prefix}m/s]")
        for ax in axes:
            ax.axhline(0.0, color="0.5", lw=0.7)
    return _time_figure(runs, path, "Fig. 3 — relative motion; ", draw)


def draw_fig4(runs, path: Path) -> Path:
    from .plots import length_scale, quantity, title
    plt = _plt()
    fig, axes = plt.subplots(2, 3, figsize=(11, 7))
    k, prefix = length_scale(runs[0].scenario)  # one unit for all six panels
    for ax, r, letter in zip(axes.ravel(), runs, "abcdef"):
        ax.plot(r.x * k, r.v * k, color="C0", lw=1.2, label="slipping")
        stuck = np.asarray(r.stuck) > 0.5
        if stuck.any():  # stuck: the block moves with the drive, drawn over the curve
            ax.plot(np.where(stuck, r.x, np.nan) * k, np.where(stuck, r.v, np.nan) * k, color="C1", lw=3.0,
                    alpha=0.8, solid_capstyle="butt", label="stuck")
        ax.set_title(f"({letter}) ω = {r.scenario.drive.omega:g} rad/s", fontsize=10)
        ax.set_xlabel(f"x [{prefix}m]")
        ax.set_ylabel(f"v [{prefix}m/s]")
        ax.grid(alpha=0.3)
        ax.locator_params(nbins=5)
    sc = runs[0].scenario
    title(fig, f"Fig. 4 — phase portraits v(x), dry friction; A = {quantity(sc.drive.A, 'm')}, "
               f"L = {quantity(sc.load, 'N')}, M = {sc.block.M:g} kg, K = {sc.block.K:g} N/m, "
               f"μ = {sc.friction.mu_friction:g}", 130, 10)
    fig.tight_layout(rect=(0, 0.035, 1, 1))  # a strip below the panels for the legend: it covers no curve
    fig.legend(*axes.ravel()[0].get_legend_handles_labels(), loc="lower center", ncol=2, fontsize=9,
               frameon=False)
    return _save(fig, path)


def draw_fig5(runs, path: Path) -> Path:
    from .plots import draw_pair, finish_axes, length_scale, quantity, title
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 9.5), sharex=True, gridspec_kw={"height_ratios": [1, 1, 1.35]})
    names = ("pseudoplastic", "Newtonian", "dilatant")
    k, prefix = length_scale(runs[0].scenario)
    for ax, r, name in zip(axes, runs, names):
        draw_pair(ax, r.time, r.V, r.v, k, "V (upper block)", "v (lower block)", "C3")
        ax.set_ylabel(f"V, v [{prefix}m/s]")
        ax.set_title(f"{name}, γ = {r.scenario.friction.gamma:.3g}".replace("-", "−"), fontsize=9, loc="left")
    r = runs[-1]
    # in data coordinates, inside the drive's longest positive half-wave and below v: the
    # inset hides no curve, whatever room the legend takes above them
    positive = np.flatnonzero(np.diff(np.concatenate(([0], (r.V > 0).astype(int), [0]))))
    starts, ends = positive[::2], positive[1::2] - 1
    longest = int(np.argmax(ends - starts))
    t0, t1 = r.time[starts[longest]], r.time[ends[longest]]
    v_max = float(np.max(np.abs(r.V))) * k
    inset = axes[-1].inset_axes([t0 + 0.05 * (t1 - t0), -0.97 * v_max, 0.9 * (t1 - t0), 0.62 * v_max],
                                transform=axes[-1].transData)
    inset.plot(r.time, r.v * k, color="C3", lw=1.0)
    inset.set_title(f"v enlarged [{prefix}m/s]", fontsize=8, pad=2)
    inset.tick_params(labelsize=8, pad=1)
    inset.locator_params(nbins=3)
    inset.patch.set_alpha(0.9)
    axes[-1].set_xlabel("t [s]")
    finish_axes(axes)
    sc = runs[0].scenario
    title(fig, f"Fig. 5 — fluid friction; A = {quantity(sc.drive.A, 'm')}, ω = {sc.drive.omega:g} rad/s, "
               f"M = {sc.block.M:g} kg, K = {sc.block.K:g} N/m, m = {sc.friction.m:g}")
    fig.tight_layout()
    return _save(fig, path)


def draw_fig6(runs, path: Path) -> Path:
    def draw(axes, r):
        _time_pair(axes, r, "X, x", "V, v")
        lub = r.scenario.friction.lubricant
        axes[2].plot(r.time, r.f, color="C2", label="f (excess volume)")
        axes[2].axhline(lub.mu_shear / lub.mu_shear_bar, color="0.4", lw=0.9, ls=":", label="melting: f = μ/μ̄")
        axes[2].set_ylabel("f [1]")
    return _time_figure(runs, path, "Fig. 6 — ", draw, rows=3, height=8.5)


def draw_tn_map(runs, path: Path) -> Path:
    """f of the boundary film at rest (dv = 0) under a slow temperature ramp up then down,
    per load (the friction law alone): where the two ramps differ, melting and
    solidification happen at different temperatures."""
    plt = _plt()
    (sc,) = runs
    law = sc.friction.law()
    if law.melt_threshold() is None:
        raise ValueError(f"tn_map needs a lubricant that melts (boundary friction), got {law.label}")
    melt = law.melt_threshold()
    T_up = np.arange(200.0, 1400.0, 2.0)
    # Pa: 40 loads from 1e4 to 3e7 Pa (compression), and the scene's own
    loads = -np.unique(np.append(np.logspace(4, np.log10(3e7), 40), abs(sc.conditions.n)))
    up, down = np.empty((loads.size, T_up.size)), np.empty((loads.size, T_up.size))
    for i, n in enumerate(loads):
        f = 0.0
        for j, T in enumerate(T_up):  # each temperature held 1 s: f settles (rates >= 1e3 1/s)
            f = law.advance_f(f, 0.0, n, T, 1.0)
            up[i, j] = f
        for j in range(T_up.size - 1, -1, -1):
            f = law.advance_f(f, 0.0, n, T_up[j], 1.0)
            down[i, j] = f
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
    mesh = ax[0].pcolormesh(T_up, -loads, down - up, shading="auto", cmap="viridis")
    fig.colorbar(mesh, ax=ax[0], label="f (cooling) − f (heating)")
    molten = [T_up[np.argmax(row > melt)] if np.any(row > melt) else np.nan for row in up]
    ax[0].plot(molten, -loads, "w--", label="f > μ/μ̄ (molten) at rest")
    ax[0].set_yscale("log")
    ax[0].set_xlabel("T [K]")
    ax[0].set_ylabel("−n [Pa]")
    ax[0].set_title("hysteresis band: T × n, film at rest", fontsize=10)
    ax[0].legend(loc="lower right", fontsize=8)
    k = int(np.argmin(np.abs(loads - sc.conditions.n)))
    ax[1].plot(T_up, up[k], label="heating")
    ax[1].plot(T_up, down[k], "--", label="cooling")
    ax[1].axhline(melt, color="gray", ls=":", label="melting: f = μ/μ̄")
    ax[1].set_xlabel("T [K]")
    ax[1].set_ylabel("f at rest [1]")
    from .plots import quantity
    ax[1].set_title(f"n = {quantity(float(loads[k]), 'Pa')} (the scene's load)", fontsize=10)
    ax[1].legend(fontsize=8)
    ax[1].grid(alpha=0.3)
    fig.tight_layout()
    return _save(fig, path)


def draw_friction(runs, path: Path) -> list[Path]:
    """friction_<run>.png beside path, one per run (see :func:`tribofmu.plots.draw_friction`)."""
    from .plots import draw_friction as draw
    return [draw({name: getattr(r, name) for name in SIGNALS}, r.scenario,
                 path.with_name(f"friction_{label}.png")) for r, label in zip(runs, [run.label for run in FIGURES["friction"]])]


DRAW = {"fig2": draw_fig2, "fig3": draw_fig3, "fig4": draw_fig4, "fig5": draw_fig5, "fig6": draw_fig6,
        "friction": draw_friction, "tn_map": draw_tn_map}
