"""Accuracy study: every coupling algorithm over a ladder of steps / tolerances, against the
monolithic reference solution, with the monolithic solvers a user would run instead drawn on
the same accuracy-time front (the anchors, :mod:`tribofmu.studies.reference.monolithic`):
scipy's LSODA and Radau on the same equations (x, v[, f][, T]; dry friction regularised as
mu L tanh(dv/eps), eps = 100 rtol A omega) over a ladder of rtol, and for dry friction the
exact event-driven solve with its events located to a ladder of tolerances. All runs are
interleaved in one process; a run under 0.5 s is repeated and its median time kept.

    from tribofmu.studies.accuracy import accuracy_study
    rows, summary = accuracy_study(scenario, out_dir)

Per run: nRMS error of v on the shown window (:func:`tribofmu.studies.reference.nrms`), the largest
|v - v_ref| on the window over max |v_ref| (same normalisation), wall time of the whole
``simulate`` call [s], communication steps, FMU calls, rollbacks (rejected steps). For the
adaptive algorithm also how its reported (checked) error tracks the true one. Writes
accuracy.csv, accuracy.png and summary.json (the default's place on the front and its time
against each anchor at matched accuracy) whole or not at all.
"""
from __future__ import annotations

import csv
import io
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..coupling.interpolation import NS
from ..errors import NumericalError
from ..scene.scenario import Scenario
from .accuracy_plot import plot_accuracy
from .reference import converged_reference, looser_rtol, nrms
from .reference.monolithic import REGULARISATION, solve_event_driven, solve_monolithic

__all__ = ["accuracy_study", "write_study", "plot_accuracy", "rows_csv", "dominating",
           "matched_anchors", "ACCURACY_CSV_COLUMNS", "COLUMN_MEANINGS", "LEGEND"]

ACCURACY_CSV_COLUMNS = ("algorithm", "family", "step", "tol", "default", "reported_nrms_v", "nrms_v", "max_err_v",
           "wall_time_s", "steps", "fmu_calls", "rhs_evals", "rollbacks", "ok", "reported_over_true")

# (algorithm, step [s] or None, tol or None): the whole fig2_dry ladder takes about 1 min
LADDER = ([("jacobi", h, None) for h in (1e-3, 3e-4, 1e-4, 3e-5)]
          + [("gauss-seidel", h, None) for h in (1e-3, 3e-4, 1e-4, 3e-5)]
          + [("implicit", h, None) for h in (1e-3, 3e-4, 1e-4, 3e-5)]
          + [("adaptive", None, tol) for tol in (1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5)])
QUICK_LADDER = ([("jacobi", h, None) for h in (1e-3, 1e-4)]
                + [("gauss-seidel", h, None) for h in (1e-3, 1e-4)]
                + [("implicit", h, None) for h in (1e-3, 1e-4)]
                + [("adaptive", None, tol) for tol in (1e-2, 1e-3, 1e-4)])

# The anchors: (solver, None, tolerance), for laws that stick (dry, mixed) and smooth ones.
# LSODA/Radau: rtol (a sticking law's regularisation width is 100 rtol A omega, so its ladder
# sits lower); event-driven: event location / drive period.
ANCHORS = {"smooth": [(m, None, tol) for m in ("LSODA", "Radau") for tol in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)],
           "sticks": ([(m, None, tol) for m in ("LSODA", "Radau") for tol in (1e-5, 1e-6, 1e-7, 1e-8)]
                   + [("event-driven", None, tol) for tol in (1e-2, 1e-3, 1e-4, 1e-6)])}
QUICK_ANCHORS = {"smooth": [(m, None, tol) for m in ("LSODA", "Radau") for tol in (1e-3, 1e-5)],
                 "sticks": ([(m, None, tol) for m in ("LSODA", "Radau") for tol in (1e-5, 1e-7)]
                         + [("event-driven", None, tol) for tol in (1e-3, 1e-5)])}
MONOLITHIC = ("LSODA", "Radau", "event-driven")
# What each column of accuracy.csv means (also in summary.json, "columns")
COLUMN_MEANINGS = {
    "algorithm": "coupling algorithm, or the monolithic solver (LSODA, Radau, event-driven)",
    "family": "coupling (co-simulation) or monolithic (an anchor)",
    "step": "fixed communication step [s] (fixed-step algorithms)",
    "tol": "adaptive: the error asked (--tol: the nRMS(v) the run must meet, checked); LSODA/Radau: rtol; "
           "event-driven: event location / drive period",
    "reported_nrms_v": "adaptive: the error the run reported (stats.json estimated_error.nrms_v, its checked "
                       "nRMS(v)); compare with nrms_v, the true error",
    "default": "the scene's default setting",
    "nrms_v": "the run's error: RMS of v - v_ref on the shown window over max |v_ref| (v_ref: the reference)",
    "max_err_v": "the largest |v - v_ref| on the window over max |v_ref|",
    "wall_time_s": "wall time of the whole run [s] (median of 3 under 0.5 s)",
    "steps": "communication steps (monolithic: event-driven segments)",
    "fmu_calls": "FMU calls", "rhs_evals": "right-hand-side evaluations of a monolithic solver",
    "rollbacks": "rejected (rolled back) steps",
    "ok": "the run completed (adaptive: and met its tol, checked)",
    "reported_over_true": "adaptive: reported_nrms_v / nrms_v, how the run's own (checked) error tracks the true "
                          "one (1 exact, < 1 underestimated; the study's tests hold it within [0.5, 10] where "
                          "both exceed tol/10)",
}
# What the study's log lines say (printed once, before the runs)
LEGEND = (
    "columns: adaptive: tol = the error asked (the nRMS(v) the run must meet), reported = the error",
    "           the run reported (its checked nRMS(v)), nRMS(v) = the true error, as below",
    "         nRMS(v) = the run's error: RMS of v - v_ref on the shown window over max |v_ref|",
    "           (v_ref: the reference solver); max = the largest |v - v_ref| there, same scale",
    "         s = wall time of the whole run (median of 3 under 0.5 s); steps, calls = communication",
    "           steps and FMU calls; rhs evaluations = a monolithic solver's right-hand-side calls,",
    "           segments = the event-driven solve's closed-form pieces between events (no rhs)",
    "         reported/true (adaptive only) = reported over nRMS(v): 1 exact, < 1 underestimated",
)
REPEAT_BELOW_S = 0.5  # runs shorter than this are timed 3 times (median): timer and scheduler noise


def anchors_for(scenario: Scenario, quick: bool = False) -> list[tuple]:
    """The monolithic rungs that apply to ``scenario`` (none without a Drive and a Friction FMU)."""
    if "Friction" not in scenario.fmus or "Drive" not in scenario.fmus:
        return []
    table = QUICK_ANCHORS if quick else ANCHORS
    return list(table["sticks" if scenario.friction.law().sticks else "smooth"])


def interleave(first: list, second: list) -> list:
    """first and second merged evenly (so both are measured under the same machine load)."""
    if not second:
        return list(first)
    out, every = [], max(1, len(first) // len(second))
    rest = list(second)
    for k, item in enumerate(first):
        out.append(item)
        if rest and (k + 1) % every == 0:
            out.append(rest.pop(0))
    return out + rest


def timed(run, repeat_below_s: float = REPEAT_BELOW_S):
    """(result, wall time [s]) of run(); a run under repeat_below_s is run twice more and the
    median time kept (with the last result)."""
    t0 = time.perf_counter()
    result = run()
    walls = [time.perf_counter() - t0]
    if walls[0] < repeat_below_s:
        for _ in range(2):
            t0 = time.perf_counter()
            result = run()
            walls.append(time.perf_counter() - t0)
    return result, float(np.median(walls))


def accuracy_study(scenario: Scenario, fmu_dir: str | Path | None = None, quick: bool = False,
                   ladder=None, max_run_s: float = 60.0, log=print, progress=None,
                   anchors: bool = True) -> tuple[list[dict], dict]:
    """Run the ladder and, with ``anchors``, the monolithic solvers (:func:`anchors_for`)
    interleaved with it; returns (rows, summary). A rung whose finer neighbour would exceed
    max_run_s (estimated from the last run of the same algorithm) is skipped and logged.

    The scene's own default setting is always one of the rungs (``default`` is True on its
    row); the summary says whether it is on the accuracy-time front: ``dominated_by`` lists
    the rungs at least 2x faster and more accurate than it (none: on the front), and
    ``anchors`` the default's wall time over each monolithic solver's at matched accuracy
    (its fastest run at least as accurate as the default). ``beaten_by_anchors`` lists the
    monolithic runs at least 2x faster and more accurate than the default; ``on_front`` is
    True only when neither list has an entry (a run an anchor beats is never called on the
    front). progress: passed to every simulate call."""
    from ..api import DEFAULT_TOL
    from ..coupling.algorithms import make_algorithm

    ladder = list(ladder if ladder is not None else (QUICK_LADDER if quick else LADDER))
    sim = scenario.simulation
    default_algorithm = make_algorithm(sim.algorithm, sim.step, sim.tol)
    default = (sim.algorithm, None, sim.tol or DEFAULT_TOL) if sim.algorithm == "adaptive" else (
        sim.algorithm, default_algorithm.step_ns / NS, None)
    if default not in ladder:
        ladder.append(default)
        ladder.sort(key=lambda rung: (rung[0], -(rung[1] or rung[2])))
    begin = time.perf_counter()
    ref = converged_reference(scenario)
    ref_wall = time.perf_counter() - begin
    ref_rtol = ref.stats["rtol"]
    if not ref.ok:
        raise NumericalError(f"reference solution failed at rtol {ref_rtol:g}: {ref.message}")
    log(f"reference: {ref_wall:.2f} s ({looser_rtol(ref) or f'rtol {ref_rtol:g}'}; {ref.message or 'ok'})")
    for line in LEGEND:
        log(line)
    window = scenario.window
    inside = (ref.time >= window[0] - 1e-12) & (ref.time <= window[1] + 1e-12)
    v_scale = float(np.max(np.abs(ref.v[inside])))
    rows: list[dict] = []
    last: dict[str, tuple[float, float]] = {}  # algorithm -> (setting, wall time)
    rungs = interleave(ladder, anchors_for(scenario, quick) if anchors else [])
    for algorithm, step, tol in rungs:
        setting = step if step is not None else tol
        if algorithm in last:  # cost grows like 1/step (fixed) or tol^-1/2 (adaptive, anchors)
            prev_setting, prev_wall = last[algorithm]
            power = 1.0 if step is not None else 0.5
            if prev_wall * (prev_setting / setting) ** power > max_run_s:
                log(f"{algorithm} {setting:g}: skipped (estimated > {max_run_s:g} s)")
                continue
        if algorithm in MONOLITHIC:
            row = _anchor_row(scenario, algorithm, tol, ref, window, inside, v_scale, max_run_s)
        else:
            row = _coupling_row(scenario, algorithm, step, tol, default, fmu_dir, progress, ref, window,
                                inside, v_scale)
        last[algorithm] = (setting, row["wall_time_s"])
        rows.append(row)
        label = f"h={step:g}" if step else (f"rtol={tol:g}" if algorithm in ("LSODA", "Radau") else f"tol={tol:g}")
        reported = row.get("reported_nrms_v")
        log(f"{algorithm:12s} {label:12s} "
            + (f"reported={reported:.3g} " if reported is not None else "")
            + f"nRMS(v)={row['nrms_v']:.3g} max={row['max_err_v']:.3g} "
            f"{row['wall_time_s']:6.2f} s"
            + (f" {row['steps']:7d} steps {row['fmu_calls']:8d} calls" if row["family"] == "coupling" else
               f" {row['steps'] or 0:8d} segments" if algorithm == "event-driven" else
               f" {row['rhs_evals'] or 0:8d} rhs evaluations")
            + (f"  reported/true {row['reported_over_true']:.3g}" if row.get("reported_over_true") else ""))
    summary = {"reference_wall_time_s": ref_wall, "reference_rtol": ref_rtol,
               "total_wall_time_s": time.perf_counter() - begin,
               "columns": COLUMN_MEANINGS}
    chosen = next((r for r in rows if r["default"]), None)
    if chosen is not None:
        better, beaten = dominating(rows, chosen)
        keys = ("algorithm", "step", "tol", "nrms_v", "wall_time_s")
        summary["default"] = {k: chosen[k] for k in keys}
        summary["dominated_by"] = [{k: r[k] for k in keys} for r in better]  # co-simulation settings
        summary["beaten_by_anchors"] = [{k: r[k] for k in keys} for r in beaten]  # monolithic solvers
        summary["on_front"] = not better and not beaten
        name = f"default ({chosen['algorithm']} {'h=%g' % chosen['step'] if chosen['step'] else 'tol=%g' % chosen['tol']})"
        log(f"{name} among the co-simulation settings: " + (
            "none is at least 2x faster and more accurate" if not better else
            f"{len(better)} setting(s) at least 2x faster and more accurate"))
        if beaten:
            best = min(beaten, key=lambda r: r["wall_time_s"])
            log(f"{name} is NOT on the accuracy-time front: {len(beaten)} monolithic run(s) at least 2x faster "
                f"and more accurate, e.g. {best['algorithm']} at tol {best['tol']:g}: nRMS(v) {best['nrms_v']:.3g} "
                f"in {best['wall_time_s']:.3g} s, {chosen['wall_time_s'] / best['wall_time_s']:.3g}x faster "
                "(a co-simulation pays for swappable FMUs)")
        else:
            log(f"{name}: " + ("on the accuracy-time front (nothing in the study, co-simulation or monolithic, "
                               "is at least 2x faster and more accurate)" if not better else
                               "NOT on the accuracy-time front"))
        summary["anchors"] = matched_anchors(rows, chosen)
        for name, anchor in summary["anchors"].items():
            log(f"default vs {name}: " + (
                f"the default takes {anchor['ratio']:.3g}x the time of {name}'s fastest run at least as "
                f"accurate (tol {anchor['tol']:g}: nRMS(v) {anchor['nrms_v']:.3g})" if anchor["tol"] is not None
                else f"no run of {name} in the study is as accurate as the default"))
    summary["regularisation"] = REGULARISATION
    summary["contact"] = "sticks" if "Friction" in scenario.fmus and scenario.friction.law().sticks else "smooth"
    return rows, summary


def dominating(rows: list[dict], chosen: dict) -> tuple[list[dict], list[dict]]:
    """The runs at least 2x faster than ``chosen`` and more accurate: (co-simulation settings,
    monolithic anchors). ``chosen`` is on the accuracy-time front only when both are empty."""
    def beats(r):
        return (r is not chosen and r["ok"] and np.isfinite(r["nrms_v"]) and r["nrms_v"] < chosen["nrms_v"]
                and 2.0 * r["wall_time_s"] <= chosen["wall_time_s"])
    return ([r for r in rows if r["family"] == "coupling" and beats(r)],
            [r for r in rows if r["family"] == "monolithic" and beats(r)])


def matched_anchors(rows: list[dict], chosen: dict) -> dict:
    """Per monolithic solver, its fastest ok run at least as accurate as ``chosen``, and the
    ratio chosen's wall time / its wall time (tol None: no run that accurate)."""
    out = {}
    for name in dict.fromkeys(r["algorithm"] for r in rows if r["family"] == "monolithic"):
        good = [r for r in rows if r["algorithm"] == name and r["ok"] and np.isfinite(r["nrms_v"])
                and r["nrms_v"] <= chosen["nrms_v"]]
        best = min(good, key=lambda r: r["wall_time_s"], default=None)
        out[name] = {"tol": None, "nrms_v": None, "wall_time_s": None, "ratio": None} if best is None else {
            "tol": best["tol"], "nrms_v": best["nrms_v"], "wall_time_s": best["wall_time_s"],
            "ratio": chosen["wall_time_s"] / best["wall_time_s"]}
    return out


def _errors(time_, v, ref, window, inside, v_scale) -> tuple[float, float]:
    """(nRMS(v), max |v - v_ref| / max |v_ref|) on the window; NaN when the run stopped early."""
    try:
        value = nrms(time_, v, ref.time, ref.v, window)
        v_on_ref = np.interp(ref.time[inside], time_, v)
        return value, float(np.max(np.abs(v_on_ref - ref.v[inside])) / v_scale)
    except ValueError:
        return math.nan, math.nan


def _coupling_row(scenario, algorithm, step, tol, default, fmu_dir, progress, ref, window, inside,
                  v_scale) -> dict:
    from ..api import simulate
    result, wall = timed(lambda: simulate(scenario, algorithm=algorithm, step=step, tol=tol, fmu_dir=fmu_dir,
                                          build=False, progress=progress))
    row: dict[str, Any] = dict(algorithm=algorithm, family="coupling", step=step, tol=tol, wall_time_s=wall,
                               default=(algorithm, step, tol) == default,
                               steps=result.stats["communication_steps"],
                               fmu_calls=result.stats["fmu_calls_total"], rhs_evals=None,
                               rollbacks=result.stats["rejected_steps"], ok=result.ok,
                               reported_nrms_v=result.stats["estimated_error"]["nrms_v"])
    row["nrms_v"], row["max_err_v"] = _errors(result.time, result.v, ref, window, inside, v_scale)
    reported = row["reported_nrms_v"]
    if reported is not None and math.isfinite(row["nrms_v"]) and row["nrms_v"] > 0:
        row["reported_over_true"] = reported / row["nrms_v"]
    return row


def _anchor_row(scenario, solver, tol, ref, window, inside, v_scale, max_run_s) -> dict:
    """One monolithic run on the reference's own grid."""
    import warnings
    with warnings.catch_warnings():  # LSODA warns on its way to a failure we report anyway
        warnings.simplefilter("ignore")
        if solver == "event-driven":
            result, wall = timed(lambda: solve_event_driven(scenario, tol, t_eval=ref.time))
        else:
            result, wall = timed(lambda: solve_monolithic(scenario, solver, tol, t_eval=ref.time,
                                                          max_wall=max_run_s))
    row: dict[str, Any] = dict(algorithm=solver, family="monolithic", step=None, tol=tol, wall_time_s=wall,
                               default=False, steps=result.stats.get("n_segments"), fmu_calls=None,
                               # the event-driven solve is closed-form between events: no rhs to count
                               rhs_evals=None if solver == "event-driven" else result.stats.get("n_rhs"),
                               rollbacks=None, ok=result.ok)
    row["nrms_v"], row["max_err_v"] = _errors(result.time, result.v, ref, window, inside, v_scale) \
        if result.ok else (math.nan, math.nan)
    return row


# -- output -------------------------------------------------------------------------------------
def rows_csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=ACCURACY_CSV_COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if row.get(k) is None else row.get(k, "")) for k in ACCURACY_CSV_COLUMNS})
    return buf.getvalue()


def write_study(rows: list[dict], summary: dict, scenario: Scenario, out: Path) -> None:
    import json

    from ..atomic import ACCURACY_NAMES, result_set
    from ..plots import scene_label
    with result_set(Path(out), ACCURACY_NAMES) as tmp:
        plot_accuracy(rows, summary, f"{scene_label(scenario)}: error vs cost", tmp / "accuracy.png")
        (tmp / "accuracy.csv").write_text(rows_csv(rows))
        (tmp / "summary.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
