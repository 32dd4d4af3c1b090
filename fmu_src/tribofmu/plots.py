"""Figures of one run: ``time.png`` (X, x; V, v; and whatever else the scene couples: f(t)
for boundary friction, T(t) with a Thermal FMU, the load with a Load FMU), ``phase.png``
(the phase portrait v(x)) and ``friction.png`` (:func:`draw_friction`: the friction force
F(t) with the stick bands, the friction loops F(dv) and F(X − x) over the window's periods, the
law's own force curve under the loop where it has one, and the lubricant's f(t) and T(t)).

Titles are made from the values actually simulated (:func:`scene_label`), never from the
scene file's title text, so a run with ``--set drive.omega=80`` says 80 rad/s; an input
that a program drives is shown as the program ("T: 290 K → film heating", "L(t): 15–75 N"),
and titles wrap only between items, never inside "μ = 0.5".

Units: one per quantity in every figure, chosen from the scene's drive amplitude (not from
each panel's data): positions in mm and velocities in mm/s, or µm and µm/s for scenes whose
amplitude is below 0.1 mm (the boundary-lubricated scenes, A = 1.4 µm).

matplotlib is imported by the drawing functions only, so importing this module is cheap.
"""
from __future__ import annotations

import io
import math
import re
from pathlib import Path

import numpy as np

_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"))
# parameter units printed with an SI prefix (others: plain numbers)
_PREFIXED = {"m", "Pa", "N", "J", "W", "m/s"}


def pyplot():
    """matplotlib.pyplot on the file-only Agg backend (imported on first use)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def unit_scale(values, unit: str) -> tuple[float, str]:
    """``(factor, label)``: values * factor read in ``label`` (e.g. 1e3, "mm" for metres ~1e-3)."""
    top = float(np.nanmax(np.abs(values))) if np.size(values) else 0.0
    for size, prefix in _PREFIXES[3:]:
        if top >= size * 0.999 or size == _PREFIXES[-1][0]:
            return 1.0 / size, prefix + unit
    return 1.0, unit  # pragma: no cover


def length_scale(sc) -> tuple[float, str]:
    """``(factor, prefix)`` for every position and velocity of this scene's figures: mm
    (1e3, "m"), or µm (1e6, "µ") when the drive amplitude is below 0.1 mm."""
    from .scene.scenario import scales
    size = abs(sc.drive.A) if "Drive" in sc.fmus else scales(sc)[0]
    return (1e3, "m") if size >= 1e-4 else (1e6, "µ")


def _fmt(value: float) -> str:
    return f"{value:.4g}".replace("-", "−")


def _prefix(value: float, unit: str) -> tuple[float, str]:
    """``(size, prefixed unit)`` to print value as ``value / size`` in ``prefixed unit``."""
    if unit not in _PREFIXED or value == 0 or not math.isfinite(value):
        return 1.0, unit
    for size, prefix in _PREFIXES:
        if abs(value) >= size * 0.9995:
            return size, prefix + unit
    return _PREFIXES[-1][0], _PREFIXES[-1][1] + unit


def quantity(value: float, unit: str) -> str:
    """``2 mm``, ``1.4 µm``, ``−1 MPa``, ``30 rad/s``: a value with an SI prefix where the unit
    takes one, never e-notation for those."""
    size, label = _prefix(value, unit)
    return _fmt(value / size) if unit == "1" else f"{_fmt(value / size)} {label}"


def has_drive(sc) -> bool:
    return "Drive" in sc.fmus


def has_friction(sc) -> bool:
    return "Friction" in sc.fmus


def load_range(sc) -> tuple[float, float]:
    """Smallest and largest normal stress n [Pa] over the run."""
    if "Load" in sc.fmus:
        return sc.load_program.program_().extremes(0.0, sc.stop_time)
    return sc.conditions.n, sc.conditions.n


def _range(low: float, high: float, unit: str) -> str:
    """``15–75 N``: both ends in the prefix of the larger one."""
    if math.isclose(low, high, rel_tol=1e-9, abs_tol=0.0):
        return quantity(low, unit)
    size, label = _prefix(max(abs(low), abs(high)), unit)
    return f"{_fmt(low / size)}–{_fmt(high / size)} {label}"


def scene_items(sc, signals: dict | None = None) -> list[str]:
    """The parameters that shape the run's figures, one item each (see :func:`scene_label`).

    signals: the run's signals (``T`` with a Thermal FMU), to print the temperature reached."""
    items = []
    if has_drive(sc):
        items += [f"A = {quantity(sc.drive.A, 'm')}", f"ω = {_fmt(sc.drive.omega)} rad/s"]
    items += [f"M = {_fmt(sc.block.M)} kg", f"K = {_fmt(sc.block.K)} N/m"]
    if not has_friction(sc):
        if sc.block.x0 or sc.block.v0:
            items += [f"x0 = {quantity(sc.block.x0, 'm')}", f"v0 = {quantity(sc.block.v0, 'm/s')}"]
        return items
    fr = sc.friction
    law = fr.law()
    low, high = load_range(sc)
    items += law.plot_items(_fmt)
    if law.load_shown_as == "L":
        loads = (-high * fr.S, -low * fr.S)
        items.append(f"L(t): {_range(*loads, 'N')}" if "Load" in sc.fmus else f"L = {quantity(loads[0], 'N')}")
    elif law.load_shown_as == "n":
        items.append(f"n(t): {_range(low, high, 'Pa')}" if "Load" in sc.fmus else f"n = {quantity(low, 'Pa')}")
    if law.reads_temperature:
        if "Thermal" in sc.fmus:
            T = None if signals is None else signals.get("T")
            if T is not None and np.size(T) and np.all(np.isfinite(T)):
                items.append(f"T: {_fmt(sc.conditions.T)} K → {_fmt(float(T[-1]))} K (film heating)")
            else:
                items.append(f"T: {_fmt(sc.conditions.T)} K → film heating")
        else:
            items.append(f"T = {_fmt(sc.conditions.T)} K")
    return items


def regime_name(sc) -> str:
    return sc.friction.law().label if has_friction(sc) else "no friction"


def scene_label(sc, signals: dict | None = None) -> str:
    """One line naming the regime and the simulated parameters that shape the figure."""
    return f"{sc.name}: {regime_name(sc)}; " + ", ".join(scene_items(sc, signals))


_BREAKS = re.compile(r"(?<=[,;]) |(?<=:) (?=\S+ friction)| (?=— )")


def wrap_items(text: str, width: int) -> str:
    """Wrap text to lines of at most ``width`` characters, breaking only after ``, `` or ``; ``
    (between items), never inside an item such as ``μ = 0.5``."""
    lines, line = [], ""
    for piece in _BREAKS.split(text):
        if line and len(line) + 1 + len(piece) > width:
            lines.append(line)
            line = piece
        else:
            line = f"{line} {piece}" if line else piece
    lines.append(line)
    return "\n".join(lines)


def title(fig, text: str, width: int = 90, fontsize: float = 9) -> int:
    """A figure title wrapped between items to the figure's width (nothing is cut); returns
    its number of lines."""
    wrapped = wrap_items(text, width)
    fig.suptitle(wrapped, fontsize=fontsize)
    return wrapped.count("\n") + 1


def draw_pair(ax, t, drive, block, factor: float, drive_label: str, block_label: str, color: str,
              show_drive: bool = True) -> None:
    """The drive's signal dashed (only when there is a drive) and the block's solid."""
    if show_drive:
        ax.plot(t, drive * factor, "--", color="0.35", lw=1.2, label=drive_label)
    ax.plot(t, block * factor, "-", color=color, lw=1.4, label=block_label)


def finish_axes(axes) -> None:
    """Grid, and each panel's legend in one row in a strip of headroom above its curves (so
    that it covers none of them, wherever they run)."""
    for ax in np.ravel(axes):
        ax.grid(alpha=0.3)
        handles = ax.get_legend_handles_labels()[0]
        if handles:
            low, high = ax.get_ylim()
            ax.set_ylim(low, high + 0.3 * (high - low))
            ax.legend(loc="upper left", ncol=len(handles), fontsize=8, framealpha=0.85, handlelength=1.8,
                      columnspacing=1.2, borderaxespad=0.3)


def shade_stuck(ax, t, stuck, label: str | None = "stuck") -> None:
    """Shade the intervals where the coupling held the blocks together (``stuck`` > 0.5)."""
    stuck = np.asarray(stuck) > 0.5
    if stuck.any() and not stuck.all():
        ax.fill_between(t, 0, 1, where=stuck, transform=ax.get_xaxis_transform(), color="C1", alpha=0.15,
                        lw=0, label=label)


def fixed_layout(fig, title_lines: int = 0, left: float = 0.95, right: float = 0.2, bottom: float = 0.55,
                 top: float = 0.2, hspace: float = 0.12) -> None:
    """Margins in inches instead of tight_layout, which draws the whole figure once more
    just to measure it (a third of the drawing time of a run's plots)."""
    width, height = fig.get_size_inches()
    top += 0.2 * title_lines + (0.1 if title_lines else 0.0)
    fig.subplots_adjust(left=left / width, right=1 - right / width, bottom=bottom / height,
                        top=1 - top / height, hspace=hspace)


def save_png(fig, path: Path, dpi: int = 110) -> Path:
    """Render the figure, then write the file whole (renamed into place) and close the figure."""
    from .atomic import atomic_write_bytes
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=dpi, pil_kwargs={"compress_level": 3})
    pyplot().close(fig)
    atomic_write_bytes(Path(path), buffer.getvalue())
    return Path(path)


def window(signals: dict, sc) -> dict:
    """The signals on the scene's shown window."""
    start, end = sc.window
    t = signals["time"]
    m = (t >= start - 1e-12) & (t <= end + 1e-12)
    return {k: np.asarray(v)[m] for k, v in signals.items()}


def plot_result(result, out_dir: Path) -> list[Path]:
    """time.png, phase.png and friction.png of a :class:`tribofmu.api.SimulationResult`; returns their paths."""
    from .columns import result_signals
    return plot_signals(result_signals(result), result.scenario, out_dir)


def plot_signals(signals: dict, sc, out_dir: Path) -> list[Path]:
    """time.png, phase.png and friction.png (with friction) from a run's signals (``{name: array}`` with ``time``, as in
    result.csv) and its scenario; returns their paths."""
    plt = pyplot()
    out_dir = Path(out_dir)
    s = window(signals, sc)
    t = s["time"]
    drive = has_drive(sc)
    k, prefix = length_scale(sc)
    law = sc.friction.law() if has_friction(sc) else None
    melts = law is not None and law.melt_threshold() is not None
    extra = [name for name, present in (("f", melts), ("T", "T" in s and "Thermal" in sc.fmus),
                                        ("n", "n" in s and "Load" in sc.fmus)) if present]
    rows = 2 + len(extra)
    fig, axes = plt.subplots(rows, 1, figsize=(7.5, 2.3 * rows + 0.9), sharex=True)
    draw_pair(axes[0], t, s["X"], s["x"], k, "X (drive)", "x (block)", "C0", drive)
    axes[0].set_ylabel(f"position [{prefix}m]")
    draw_pair(axes[1], t, s["V"], s["v"], k, "V (drive)", "v (block)", "C3", drive)
    axes[1].set_ylabel(f"velocity [{prefix}m/s]")
    stuck = s.get("stuck", np.zeros(len(t)))
    shade_stuck(axes[0], t, stuck, None)  # the same intervals above, labelled once
    shade_stuck(axes[1], t, stuck)
    for ax, name in zip(axes[2:], extra):
        if name in ("f", "T"):
            draw_film(ax, name, t, s, law)
        elif law is not None and law.load_shown_as == "L":
            ax.plot(t, -s["n"] * sc.friction.S, color="C4", label="L = −n S (Load FMU)")
            ax.set_ylabel("load L [N]")
        else:
            kn, un = unit_scale(s["n"], "Pa")
            ax.plot(t, s["n"] * kn, color="C4", label="n (Load FMU)")
            ax.set_ylabel(f"n [{un}]")
    finish_axes(axes)
    axes[-1].set_xlabel("t [s]")
    fixed_layout(fig, title(fig, scene_label(sc, s)))
    paths = [save_png(fig, out_dir / "time.png")]

    fig, ax = plt.subplots(figsize=(5, 4.4))
    ax.plot(s["x"] * k, s["v"] * k, color="C0")
    ax.set_xlabel(f"x [{prefix}m]")
    ax.set_ylabel(f"v [{prefix}m/s]")
    label = f"phase portrait v(x), ω = {_fmt(sc.drive.omega)} rad/s" if drive else "phase portrait v(x)"
    ax.set_title(label, fontsize=10)
    ax.grid(alpha=0.3)
    fixed_layout(fig, top=0.35)
    paths.append(save_png(fig, out_dir / "phase.png"))
    if has_friction(sc) and "F" in s:
        paths.append(draw_friction(s, sc, out_dir / "friction.png"))
    return paths


def draw_film(ax, name: str, t, s: dict, law) -> None:
    """A panel of the lubricant film: its excess volume f with the melting line (``"f"``) or its
    temperature T from the Thermal FMU (``"T"``)."""
    if name == "f":
        ax.plot(t, s["f"], color="C2", label="f (excess volume)")
        ax.axhline(law.melt_threshold(), color="0.5", lw=0.8, ls=":", label="melting: f = μ/μ̄")
        ax.set_ylabel("f [1]")
    else:
        ax.plot(t, s["T"], color="C1", label="T (film, Thermal FMU)")
        ax.set_ylabel("T [K]")


def law_curve(sc, dv_low: float, dv_high: float, points: int = 401):
    """``(dv, F)`` of the force the scene's friction law defines against dv [m/s] over
    [dv_low, dv_high] (asked of the law object: its slip branches, with the static limit's
    vertical segment at dv = 0 for a law that sticks), or None where the force is not one
    curve of dv: a law with a state (boundary friction: F depends on f) or a load that moves."""
    law = sc.friction.law()
    if law.has_state or "Load" in sc.fmus:
        return None
    n = sc.conditions.n
    span = max(abs(dv_low), abs(dv_high))
    dv = np.linspace(-span, span, points)
    dv = dv[dv != 0.0]
    force = np.array([law.force(float(d), n) for d in dv])
    if law.sticks:  # the set-valued force at rest: the static limit on both sides
        limit = law.static_limit(n)
        negative, positive = dv < 0, dv > 0
        dv = np.concatenate([dv[negative], [0.0, 0.0], dv[positive]])
        force = np.concatenate([force[negative], [-limit, limit], force[positive]])
    return dv, force


def draw_friction(s: dict, sc, path: Path) -> Path:
    """friction.png of a run's signals on the shown window ``s`` (``time, x, F, stuck`` and
    ``V, v`` or ``dv``; ``f`` and ``T`` where the scene has them): F(t) with the stick bands
    shaded, f(t) for a lubricant that melts, T(t) with a Thermal FMU; below, the friction
    loops F(dv) (the law's force curve under it, :func:`law_curve`) and F(X − x)."""
    plt = pyplot()
    t = np.asarray(s["time"])
    F = np.asarray(s["F"])
    dv = np.asarray(s["dv"]) if "dv" in s else np.asarray(s["V"]) - np.asarray(s["v"])
    k, prefix = length_scale(sc)
    law = sc.friction.law()
    kF, uF = unit_scale(F, "N")
    extra = []
    if law.melt_threshold() is not None and "f" in s:
        extra.append("f")
    if "T" in s and "Thermal" in sc.fmus:
        extra.append("T")
    rows = 1 + len(extra)
    fig = plt.figure(figsize=(8.0, 2.1 * rows + 3.6))
    outer = fig.add_gridspec(2, 1, height_ratios=[rows, 1.7], hspace=0.42 / rows + 0.1)
    grid, below = outer[0].subgridspec(rows, 1, hspace=0.12), outer[1].subgridspec(1, 2, wspace=0.3)
    top = fig.add_subplot(grid[0])
    top.plot(t, F * kF, color="C2", lw=1.2, label="F (friction on the block)")
    top.axhline(0.0, color="0.5", lw=0.6)
    shade_stuck(top, t, s.get("stuck", np.zeros(len(t))), "stuck")
    top.set_ylabel(f"F [{uF}]")
    panels = [top]
    for row, name in enumerate(extra, start=1):
        ax = fig.add_subplot(grid[row], sharex=top)
        draw_film(ax, name, t, s, law)
        panels.append(ax)
    for ax in panels[:-1]:
        ax.tick_params(labelbottom=False)
    panels[-1].set_xlabel("t [s]")
    loop, against_x = fig.add_subplot(below[0]), fig.add_subplot(below[1])
    curve = law_curve(sc, float(np.min(dv)) if dv.size else 0.0, float(np.max(dv)) if dv.size else 0.0)
    if curve is not None:
        loop.plot(curve[0] * k, curve[1] * kF, "--", color="0.15", lw=1.0, zorder=3,
                  label=f"the law's F(dv) at L = {quantity(law.load(sc.conditions.n), 'N')}"
                  if law.load_shown_as == "L" else "the law's F(dv)")
    loop.plot(dv * k, F * kF, color="C2", lw=2.0, alpha=0.8, label="run")
    loop.set_xlabel(f"dv = V − v [{prefix}m/s]")
    loop.set_ylabel(f"F [{uF}]")
    loop.set_title("friction loop F(dv)", fontsize=9)
    # against the sliding displacement X - x: the loop's area is the work friction dissipates
    # (against the block's own x a periodic motion draws a line, F = (2K - M w^2) x)
    slid = np.asarray(s["X"]) - np.asarray(s["x"])
    against_x.plot(slid * k, F * kF, color="C0", lw=1.0, label="run (area: energy dissipated)")
    against_x.set_xlabel(f"X − x (sliding displacement) [{prefix}m]")
    against_x.set_ylabel(f"F [{uF}]")
    against_x.set_title("friction loop F(X − x)", fontsize=9)
    finish_axes(panels + [loop, against_x])
    start, end = sc.window
    periods = (end - start) * sc.drive.omega / (2 * math.pi) if has_drive(sc) else None
    span = f"; window {_fmt(start)}–{_fmt(end)} s" + (f" ({_fmt(periods)} periods)" if periods else "")
    lines = title(fig, "friction: " + scene_label(sc, s) + span)
    fixed_layout(fig, lines, left=0.9, bottom=0.55)
    return save_png(fig, path)
