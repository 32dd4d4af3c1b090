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

SCENARIOS_DIR = Path(__file__).resolve().parents[2] / "scenarios"
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
}


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
                      code: str) -> Signals:
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
    if not quiet:
        print(f"{run.label}: {result.stats['communication_steps']} steps, "
              f"{result.stats['wall_time']:.1f} s", file=sys.stderr)
    return Signals(scenario, arrays)


def make_figures(out_dir: str | Path = "out/figures", only: list[str] | None = None,
                 scenarios_dir: str | Path | None = None, fmu_dir: str | Path | None = None,
                 rerun: bool = False, quiet: bool = False, data_dir: str | Path | None = None) -> list[Path]:
    """Write ``OUT/fig2.png`` .. ``fig6.png`` (or the ``only`` ones); returns their paths.

    data_dir: where the runs' signals are saved and reused (default ``OUT/data``)."""
    from .fmu_cache import find_fmus

    out_dir = Path(out_dir)
    scenarios_dir = Path(scenarios_dir) if scenarios_dir else SCENARIOS_DIR
    if not scenarios_dir.is_dir():
        raise FileNotFoundError(f"scenes folder not found: {scenarios_dir} (pass --scenarios DIR, "
                                "the repository's scenarios/)")
    names = list(only) if only else list(FIGURES)
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
                                                       quiet, code)
        runs = [results[run.label] for run in FIGURES[name]]
        paths.append(DRAW[name](runs, out_dir / f"{name}.png"))
    return paths


# -- drawing -------------------------------------------------------------------------------------
def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path: Path) -> Path:
    from .atomic import atomic_write_bytes
    import io
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=120)
    _plt().close(fig)
    atomic_write_bytes(path, buffer.getvalue())
    return path


def _time_pair(axes, r: Signals, first: str, second: str) -> None:
    """Upper: X (dashed), x (solid); lower: V (dashed), v (solid), in readable units."""
    from .plots import draw_pair, unit_scale
    k, unit = unit_scale(np.concatenate([r.X, r.x]), "m")
    draw_pair(axes[0], r.time, r.X, r.x, k, "X (upper block)", "x (lower block)", "C0")
    axes[0].set_ylabel(f"{first} [{unit}]")
    k, unit = unit_scale(np.concatenate([r.V, r.v]), "m/s")
    draw_pair(axes[1], r.time, r.V, r.v, k, "V (upper block)", "v (lower block)", "C3")
    axes[1].set_ylabel(f"{second} [{unit}]")


def draw_fig2(runs, path: Path) -> Path:
    from .plots import finish_axes, scene_label, title
    plt = _plt()
    (r,) = runs
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 6), sharex=True)
    _time_pair(axes, r, "X, x", "V, v")
    axes[-1].set_xlabel("t [s]")
    finish_axes(axes)
    title(fig, "Fig. 2 — " + scene_label(r.scenario))
    fig.tight_layout()
    return _save(fig, path)


def draw_fig3(runs, path: Path) -> Path:
    from .plots import finish_axes, scene_label, title, unit_scale
    plt = _plt()
    (r,) = runs
    fig, axes = plt.subplots(2, 1, figsize=(7.5, 6), sharex=True)
    k, unit = unit_scale(r.X - r.x, "m")
    axes[0].plot(r.time, (r.X - r.x) * k, color="C0", label="X − x")
    axes[0].set_ylabel(f"X − x [{unit}]")
    k, unit = unit_scale(r.V - r.v, "m/s")
    axes[1].plot(r.time, (r.V - r.v) * k, color="C3", label="V − v")
    axes[1].set_ylabel(f"V − v [{unit}]")
    for ax in axes:
        ax.axhline(0.0, color="0.5", lw=0.7)
    axes[-1].set_xlabel("t [s]")
    finish_axes(axes)
    title(fig, "Fig. 3 — relative motion; " + scene_label(r.scenario))
    fig.tight_layout()
    return _save(fig, path)


def draw_fig4(runs, path: Path) -> Path:
    from .plots import title, unit_scale
    plt = _plt()
    fig, axes = plt.subplots(2, 3, figsize=(11, 7))
    for ax, r, letter in zip(axes.ravel(), runs, "abcdef"):
        kx, ux = unit_scale(r.x, "m")
        kv, uv = unit_scale(r.v, "m/s")
        ax.plot(r.x * kx, r.v * kv, color="C0", lw=1.2)
        ax.set_title(f"({letter}) ω = {r.scenario.drive.omega:g} rad/s", fontsize=10)
        ax.set_xlabel(f"x [{ux}]")
        ax.set_ylabel(f"v [{uv}]")
        ax.grid(alpha=0.3)
        ax.locator_params(nbins=5)
    sc = runs[0].scenario
    title(fig, f"Fig. 4 — phase portraits v(x), dry friction: A = {sc.drive.A:g} m, L = {sc.load:g} N, "
               f"M = {sc.block.M:g} kg, K = {sc.block.K:g} N/m, μ = {sc.friction.mu_friction:g}", 130, 10)
    fig.tight_layout()
    return _save(fig, path)


def draw_fig5(runs, path: Path) -> Path:
    from .plots import draw_pair, finish_axes, title, unit_scale
    plt = _plt()
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 8.5), sharex=True)
    names = ("pseudoplastic", "Newtonian", "dilatant")
    for ax, r, name in zip(axes, runs, names):
        k, unit = unit_scale(np.concatenate([r.V, r.v]), "m/s")
        draw_pair(ax, r.time, r.V, r.v, k, "V (upper block)", "v (lower block)", "C3")
        ax.set_ylabel(f"V, v [{unit}]")
        ax.set_title(f"{name}, γ = {r.scenario.friction.gamma:.3g}", fontsize=9, loc="left")
    r = runs[-1]
    k, unit = unit_scale(r.v, "m/s")
    # between the drive's troughs, below v: the inset hides no curve
    inset = axes[-1].inset_axes([0.37, 0.06, 0.27, 0.3])
    inset.plot(r.time, r.v * k, color="C3", lw=1.0)
    inset.set_title(f"v enlarged [{unit}] vs t [s]", fontsize=7, pad=2)
    inset.tick_params(labelsize=6)
    inset.locator_params(nbins=3)
    inset.patch.set_alpha(0.9)
    axes[-1].set_xlabel("t [s]")
    finish_axes(axes)
    sc = runs[0].scenario
    title(fig, f"Fig. 5 — fluid friction: A = {sc.drive.A:g} m, ω = {sc.drive.omega:g} rad/s, "
               f"M = {sc.block.M:g} kg, K = {sc.block.K:g} N/m, m = {sc.friction.m:g}")
    fig.tight_layout()
    return _save(fig, path)


def draw_fig6(runs, path: Path) -> Path:
    from .plots import finish_axes, scene_label, title
    plt = _plt()
    (r,) = runs
    fig, axes = plt.subplots(3, 1, figsize=(7.5, 8.5), sharex=True)
    _time_pair(axes, r, "X, x", "V, v")
    lub = r.scenario.friction.lubricant
    axes[2].plot(r.time, r.f, color="C2", label="f (excess volume)")
    axes[2].axhline(lub.mu_shear / lub.mu_shear_bar, color="0.4", lw=0.9, ls=":", label="melting: f = μ/μ̄")
    axes[2].set_ylabel("f [1]")
    axes[-1].set_xlabel("t [s]")
    finish_axes(axes)
    title(fig, "Fig. 6 — " + scene_label(r.scenario))
    fig.tight_layout()
    return _save(fig, path)


DRAW = {"fig2": draw_fig2, "fig3": draw_fig3, "fig4": draw_fig4, "fig5": draw_fig5, "fig6": draw_fig6}
