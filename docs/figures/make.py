"""Regenerate every figure in docs/figures and the numbers of docs/studies.md this script owns.

    python docs/figures/make.py                 # everything (about 10 min on one core)
    python docs/figures/make.py --only w130     # some parts (names: python docs/figures/make.py --list)

Run from the repository's root with the package importable (installed, or PYTHONPATH=fmu_src).
Each part writes its files into docs/figures; a part that owns numbers rewrites its block in
docs/studies.md, between ``<!-- make.py:NAME -->`` and ``<!-- /make.py:NAME -->``, with the
date it was measured. The runs' data are kept in out/docs-figures (reused by ``tribofmu
figures`` when nothing changed). tests/unit/test_docs_figures.py fails when docs/ or the README
cites a file under docs/figures that :data:`OUTPUTS` does not list, or a block no part writes.
"""
from __future__ import annotations

import argparse
import datetime as dt
import math
import re
import shutil
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FIGURES = ROOT / "docs" / "figures"
STUDIES = ROOT / "docs" / "studies.md"
WORK = ROOT / "out" / "docs-figures"

PAPER = ("fig2", "fig3", "fig4", "fig5", "fig6", "friction", "tn_map")
SCENES = ("boundary_heating", "dry_load_oscillation", "mixed_stribeck")  # their run's own plots
FIG4_GRID = {"drive.omega": [10.0, 20.0, 30.0, 50.0, 80.0, 130.0]}
MAP_GRID = {"drive.omega": [10.0, 20.0, 30.0, 50.0, 80.0, 130.0], "conditions.n": [-10.0, -20.0, -40.0]}


def grid_args(grid: dict) -> str:
    return " ".join(f"--grid {key}={','.join(f'{v:g}' for v in values)}" for key, values in grid.items())


def _paper_outputs() -> list[str]:
    from tribofmu.figures import output_names
    return output_names(PAPER)


# part -> the files it writes under docs/figures
OUTPUTS = {
    "paper": _paper_outputs,
    "scenes": lambda: [f"{scene}/{name}.png" for scene in SCENES for name in ("time", "phase", "friction")],
    "regime_map": lambda: ["regime_map_dry_stick_fraction.png"],
    "accuracy": lambda: ["accuracy_fig2_dry.png"],
    "fig4_table": lambda: [],
    "w130": lambda: [],
    "heating": lambda: [],
}
# part -> the block of docs/studies.md it writes
BLOCKS = {"fig4_table": "fig4_table", "regime_map": "regime_map", "w130": "w130", "heating": "heating"}


def outputs() -> list[str]:
    """Every file under docs/figures this script makes, relative to it."""
    return [name for part in OUTPUTS.values() for name in part()]


def num(value: float, spec: str = ".2f") -> str:
    """A number as the docs write it: a true minus sign."""
    return format(value, spec).replace("-", "−")


def today() -> str:
    return dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d")


def write_block(name: str, text: str) -> None:
    """Replace docs/studies.md's block ``name`` with text (dated by the caller)."""
    doc = STUDIES.read_text(encoding="utf-8")
    pattern = re.compile(rf"(<!-- make.py:{name} -->\n).*?(<!-- /make.py:{name} -->)", re.S)
    if not pattern.search(doc):
        raise SystemExit(f"{STUDIES}: no block <!-- make.py:{name} --> ... <!-- /make.py:{name} -->")
    STUDIES.write_text(pattern.sub(lambda m: m.group(1) + text.rstrip("\n") + "\n" + m.group(2), doc),
                       encoding="utf-8")


# -- the parts ---------------------------------------------------------------------------------
def paper() -> None:
    from tribofmu.figures import make_figures
    make_figures(FIGURES, only=list(PAPER), data_dir=WORK / "data", quiet=False)


def scenes() -> None:
    from tribofmu import api
    for scene in SCENES:
        with tempfile.TemporaryDirectory() as tmp:
            api.simulate_and_save(scene, Path(tmp) / scene)
            for name in ("time", "phase", "friction"):
                (FIGURES / scene).mkdir(exist_ok=True)
                shutil.copyfile(Path(tmp) / scene / f"{name}.png", FIGURES / scene / f"{name}.png")


def _sweep(grid: dict, folder: str):
    from tribofmu.scene.library import resolve_scene
    from tribofmu.studies.sweep import sweep
    return sweep(resolve_scene("fig2_dry"), grid, WORK / folder, workers=0, progress=False, recompute=True)


def regime_map() -> None:
    rows = _sweep(MAP_GRID, "map")
    shutil.copyfile(WORK / "map" / "map_stick_fraction.png", FIGURES / "regime_map_dry_stick_fraction.png")
    light = [r for r in rows if r["conditions.n"] == -10.0]
    heavy = [r for r in rows if r["conditions.n"] == -40.0]
    write_block("regime_map", (
        f"A 2-D regime map, dry friction, frequency × load (`tribofmu sweep fig2_dry {grid_args(MAP_GRID)} "
        f"--workers 0`, {len(rows)} points, {today()}): the share of time stuck, against the load "
        "L = −n S [N] (S = 1 m²). Heavier load sticks more: at L = 40 N from "
        f"{min(r['stick_fraction'] for r in heavy):.2f} to {max(r['stick_fraction'] for r in heavy):.2f}, "
        f"at L = 10 N from {min(r['stick_fraction'] for r in light):.2f} to "
        f"{max(r['stick_fraction'] for r in light):.2f}.\n\n"
        "![regime map](figures/regime_map_dry_stick_fraction.png)\n\n"
        "(`map_stick_fraction.png` of that sweep, copied to `docs/figures/` by `docs/figures/make.py`.)"))


def fig4_table() -> None:
    rows = _sweep(FIG4_GRID, "fig4")
    lines = [f"Fig. 4 as numbers (`sweep.csv` of `tribofmu sweep fig2_dry {grid_args(FIG4_GRID)} --workers 0`, "
             f"{today()}; the metrics on the shown window, from the run's output grid):", "",
             "| ω [rad/s] | stick_fraction | episodes/period | harmonics | amplitude_ratio | dissipated/cycle [J] |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['drive.omega']:g} | {r['stick_fraction']:.3f} | {r['stick_episodes_per_period']:g} | "
                     f"{r['harmonics']:g} | {r['amplitude_ratio']:.3f} | {r['dissipated_per_cycle']:.3g} |")
    write_block("fig4_table", "\n".join(lines))


def accuracy() -> None:
    from tribofmu import api
    from tribofmu.studies.accuracy import accuracy_study, write_study
    scenario = api.load("fig2_dry")
    rows, summary = accuracy_study(scenario, quick=True, log=lambda line: print(line, file=sys.stderr))
    write_study(rows, summary, scenario, WORK / "accuracy")
    shutil.copyfile(WORK / "accuracy" / "accuracy.png", FIGURES / "accuracy_fig2_dry.png")


def w130() -> None:
    """Why the blocks at 130 rad/s slip at all, from the run's own numbers: stuck, the force
    the contact must carry is F = (2K − M ω²) X + 2K c, c the stuck offset x − X."""
    import numpy as np
    from tribofmu import api
    sc = api.load("fig4_dry_w130")
    with tempfile.TemporaryDirectory() as tmp:
        result = api.simulate_and_save(sc, Path(tmp) / "w130", plots=False)
        from tribofmu.columns import read_result_csv
        s = read_result_csv(Path(tmp) / "w130" / "result.csv")
    M, K, A, w = sc.block.M, sc.block.K, sc.drive.A, sc.drive.omega
    limit = sc.friction.law().static_limit(sc.conditions.n)
    start, end = sc.window
    shown = (s["time"] >= start) & (s["time"] <= end)
    stuck = shown & (s["stuck"] > 0.5)
    offset = float(np.mean((s["x"] - s["X"])[stuck]))
    period = 2 * math.pi / w
    second = (s["time"] >= period) & (s["time"] < 2 * period) & (s["stuck"] > 0.5)
    swing = (2 * K - M * w * w) * A
    write_block("w130", (
        f"At 130 rad/s the blocks are stuck {float(np.mean(s['stuck'][shown] > 0.5)):.0%} of the window. Stuck, "
        f"the contact must carry F = (2K − Mω²)·X + 2K·c (c = x − X, the offset the block stuck at): "
        f"(2K − Mω²)·A = {num(swing)} N either way about the springs' pull 2K·c = {num(2 * K * offset)} N "
        f"(c = {num(offset * 1e3, '.3f')} mm), so {num(swing + 2 * K * offset, '+.2f')} N at X = +A and "
        f"{num(-swing + 2 * K * offset, '+.2f')} N at X = −A, past μL = {limit:g} N: a short slip at that "
        f"turning point each period, which moves c toward 0 (c = "
        f"{num(float(np.mean((s['x'] - s['X'])[second])) * 1e3, '.3f')} mm in the second period). Inertia "
        f"alone, M·A·ω² = {num(M * A * w * w, '.1f')} N, is not the force the contact carries: the springs "
        f"pull the other way. Measured in the window of `tribofmu simulate fig4_dry_w130` "
        f"({result.stats['communication_steps']} steps) by `docs/figures/make.py`, {today()}; the stuck "
        f"force there runs from {num(float(s['F'][stuck].min()))} to {num(float(s['F'][stuck].max()))} N."))


def heating() -> None:
    import numpy as np
    from tribofmu import api
    sc = api.load("boundary_heating")
    result = api.simulate(sc)
    T, f, t = result.inputs["T"], result.f, result.time
    melt = sc.friction.law().melt_threshold()
    period = sc.drive.period
    later = t >= period
    write_block("heating", (
        f"Measured by `docs/figures/make.py` ({today()}, `tribofmu simulate boundary_heating`): the film "
        f"peaks at {float(T.max()):.0f} K in the first period and ends at {float(T[-1]):.0f} K; from the "
        f"second period on it is molten {float(np.mean(f[later] > melt)):.0%} of the time "
        f"(f > μ/μ̄ = {melt:.3g}), between {float(T[later].min()):.0f} and {float(T[later].max()):.0f} K."))


PARTS = {"paper": paper, "scenes": scenes, "regime_map": regime_map, "fig4_table": fig4_table,
         "accuracy": accuracy, "w130": w130, "heating": heating}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", default=None, help="comma-separated parts (default: all)")
    parser.add_argument("--list", action="store_true", help="list the parts and the files each writes")
    args = parser.parse_args(argv)
    if args.list:
        for name in PARTS:
            print(f"{name}: {', '.join(OUTPUTS[name]()) or '(numbers in docs/studies.md)'}")
        return 0
    names = args.only.split(",") if args.only else list(PARTS)
    unknown = [n for n in names if n not in PARTS]
    if unknown:
        parser.error(f"unknown part {unknown[0]!r} (known: {', '.join(PARTS)})")
    for name in names:
        print(f"make.py: {name}", file=sys.stderr)
        PARTS[name]()
    return 0


if __name__ == "__main__":
    sys.exit(main())
