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
adaptive algorithm also how well its own error estimate tracks the true local error
(:func:`estimate_tracking`). Writes accuracy.csv, accuracy.png and summary.json (the default's
place on the front and its time against each anchor at matched accuracy) whole or not at all.
"""
from __future__ import annotations

import csv
import io
import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import NumericalError
from ..coupling.interpolation import NS
from ..coupling.contact import slip_mode
from ..physics.block import BlockState, advance_block
from ..physics.drive import drive
from ..scene.scenario import Scenario, scales
from .reference import nrms, reference_solution
from .reference.monolithic import REGULARISATION, solve_event_driven, solve_monolithic

ACCURACY_CSV_COLUMNS = ("algorithm", "family", "step", "tol", "default", "reported_nrms_v", "nrms_v", "max_err_v",
           "wall_time_s", "steps", "fmu_calls", "rhs_evals", "rollbacks", "ok", "est_true_ratio_median", "est_true_ratio_p10",
           "est_true_ratio_p90", "est_underestimated_frac")

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
    "est_true_ratio_median": "adaptive: median over accepted step pairs of the step's local error estimate over "
                             "its true local error (per step; not the run's nRMS estimate)",
    "est_true_ratio_p10": "adaptive: 10th percentile of that ratio",
    "est_true_ratio_p90": "adaptive: 90th percentile of that ratio",
    "est_underestimated_frac": "adaptive: share of step pairs whose estimate is below the true local error",
}
# What the study's log lines say (printed once, before the runs)
LEGEND = (
    "columns: adaptive: tol = the error asked (the nRMS(v) the run must meet), reported = the error",
    "           the run reported (its checked nRMS(v)), nRMS(v) = the true error, as below",
    "         nRMS(v) = the run's error: RMS of v - v_ref on the shown window over max |v_ref|",
    "           (v_ref: the reference solver); max = the largest |v - v_ref| there, same scale",
    "         s = wall time of the whole run (median of 3 under 0.5 s); steps, calls = communication",
    "           steps and FMU calls; rhs evaluations = a monolithic solver's right-hand-side calls",
    "         step est/true (adaptive only) = median, over the accepted step pairs, of each step's",
    "           own local error estimate over its true local error (1 exact, < 1 underestimated):",
    "           not the run's estimate of its nRMS(v) (stats.json estimated_error), not a ratio of nRMS",
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
    ref = reference_solution(scenario)
    ref_wall = time.perf_counter() - begin
    if not ref.ok:
        raise NumericalError(f"reference solution failed: {ref.message}")
    log(f"reference: {ref_wall:.2f} s ({ref.message or 'ok'})")
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
               f" {row['rhs_evals'] or 0:8d} rhs evaluations")
            + (f"  step est/true {row.get('est_true_ratio_median', math.nan):.3g}"
               if algorithm == "adaptive" else ""))
    summary = {"reference_wall_time_s": ref_wall, "total_wall_time_s": time.perf_counter() - begin,
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
                                          build=False, keep_points=algorithm == "adaptive", progress=progress))
    row: dict[str, Any] = dict(algorithm=algorithm, family="coupling", step=step, tol=tol, wall_time_s=wall,
                               default=(algorithm, step, tol) == default,
                               steps=result.stats["communication_steps"],
                               fmu_calls=result.stats["fmu_calls_total"], rhs_evals=None,
                               rollbacks=result.stats["rejected_steps"], ok=result.ok,
                               reported_nrms_v=result.stats["estimated_error"]["nrms_v"])
    row["nrms_v"], row["max_err_v"] = _errors(result.time, result.v, ref, window, inside, v_scale)
    if algorithm == "adaptive":
        track = estimate_tracking(result.points, scenario)
        row.update({f"est_true_ratio_{k}": track[k] for k in ("median", "p10", "p90")})
        row["est_underestimated_frac"] = track["underestimated_frac"]
        row["est_pairs"] = track["pairs"]
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
                               rhs_evals=result.stats.get("n_rhs"), rollbacks=None, ok=result.ok)
    row["nrms_v"], row["max_err_v"] = _errors(result.time, result.v, ref, window, inside, v_scale) \
        if result.ok else (math.nan, math.nan)
    return row


# -- the adaptive's error estimate against the true local error ---------------------------------
def estimate_tracking(points, scenario: Scenario, window_only: bool = True) -> dict:
    """Per accepted step pair of the adaptive algorithm, its estimate against the truth.

    The adaptive accepts two half steps (mid, end) at a time and stores on both its estimate
    of the pair's error in v, ``est_error`` [m/s] (one step against the two halves). The true
    local error is |v_end - v(t_end)| where v(t) starts from the co-simulation's own state
    at the pair's start and follows the exact dynamics (dry: closed-form slip while the
    contact keeps slipping the same way; fluid: DOP853 at rtol 1e-12). Stuck pairs, pairs
    with a stick/slip transition (dry) or a sign change of dv (fluid), and the boundary
    regime are skipped. Returns ratio est/true quantiles and the fraction of pairs whose
    estimate is below the true error (underestimated).
    """
    from scipy.integrate import solve_ivp

    sc = scenario
    law = sc.friction.law()
    if "Friction" not in sc.fmus or law.has_state or "Drive" not in sc.fmus:
        return {"pairs": 0, "median": math.nan, "p10": math.nan, "p90": math.nan,
                "underestimated_frac": math.nan, "skipped": 0}
    M, K, n = sc.block.M, sc.block.K, sc.conditions.n
    A, omega = sc.drive.A, sc.drive.omega
    _, v_scale, _ = scales(sc)
    t_lo, t_hi = sc.window if window_only else (0.0, math.inf)
    ratios, under, skipped = [], 0, 0
    i = 1
    while i + 1 < len(points):
        start, mid, end = points[i - 1], points[i], points[i + 1]
        if not (mid.est_error > 0 and end.est_error == mid.est_error and
                end.t_ns - mid.t_ns == mid.t_ns - start.t_ns):
            i += 1
            continue
        i += 2
        t0, t1 = start.t_ns / NS, end.t_ns / NS
        if t0 < t_lo or t1 > t_hi:
            continue
        s = start.mode
        if not s.slipping or mid.mode != s or end.mode != s:
            skipped += 1
            continue
        h = t1 - t0
        if law.constant_slip_force:
            exact = advance_block(BlockState(start.x, start.v), law.slip_force(0.0, n, s.direction), 0.0, h, M, K)
            v_true = exact.v
        else:
            def rhs(t, y):
                dv = drive(t, A, omega)[1] - y[1]
                return (y[1], (law.force(dv, n) - 2.0 * K * y[0]) / M)
            sol = solve_ivp(rhs, (t0, t1), (start.x, start.v), method="DOP853", rtol=1e-12,
                            atol=(1e-15 * A, 1e-15 * v_scale))
            v_true = float(sol.y[1, -1])
        dv_true = drive(t1, A, omega)[1] - v_true
        if slip_mode(dv_true, 0.0) != s:  # the true motion sticks or reverses inside
            skipped += 1
            continue
        true_err = abs(end.v - v_true)
        est = end.est_error
        true_err = max(true_err, 1e-15 * v_scale)
        ratios.append(est / true_err)
        under += est < true_err
    if not ratios:
        return {"pairs": 0, "median": math.nan, "p10": math.nan, "p90": math.nan,
                "underestimated_frac": math.nan, "skipped": skipped}
    r = np.array(ratios)
    return {"pairs": int(r.size), "median": float(np.median(r)), "p10": float(np.percentile(r, 10)),
            "p90": float(np.percentile(r, 90)), "underestimated_frac": under / r.size, "skipped": skipped}


# -- output -------------------------------------------------------------------------------------
def rows_csv(rows: list[dict]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=ACCURACY_CSV_COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if row.get(k) is None else row.get(k, "")) for k in ACCURACY_CSV_COLUMNS})
    return buf.getvalue()


def plot_accuracy(rows: list[dict], summary: dict, title: str, path: Path) -> None:
    """Error against wall time, one line per algorithm, each point labelled with its step
    [s] or tolerance; the scene's default ringed; the reference solver's time dashed.

    Algorithms whose points coincide (Jacobi and Gauss-Seidel give the same error at the
    same step on a two-FMU loop) are drawn with distinct markers and line styles, and a
    step shared by such points is labelled once, in grey; the monolithic anchors (LSODA,
    Radau, the event-driven dry solve) are dashed squares. Each label takes the first of a
    few places around its point where it overlaps no earlier label; the x range leaves room
    for the labels of the rightmost points."""
    from ..plots import pyplot, save_png, wrap_items
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(7.5, 6.2))
    styles = [("o", "-"), ("s", "--"), ("^", "-."), ("D", ":")]
    labels: list[list] = []  # [t, err, text, color]
    times = []
    for k, name in enumerate(dict.fromkeys(r["algorithm"] for r in rows)):
        # nRMS >= 1 is no solution (a solver that "succeeded" far off): in the CSV, not drawn
        sel = [r for r in rows if r["algorithm"] == name and np.isfinite(r["nrms_v"]) and 0 < r["nrms_v"] < 1]
        if not sel:
            continue
        anchor = sel[0].get("family") == "monolithic"
        sel.sort(key=lambda r: r["step"] or r["tol"])  # the line follows the ladder, not the timings
        marker, line = ("s", "--") if anchor else styles[k % len(styles)]
        ax.loglog([r["wall_time_s"] for r in sel], [r["nrms_v"] for r in sel], marker=marker, ls=line,
                  color=f"C{k}", label=_legend(name, summary), ms=5 if k % 2 else 4,
                  mfc="none" if k % 2 else f"C{k}", lw=1.0 if anchor else 1.5)
        for r in sel:
            text = (f"h={r['step']:g} s" if r["step"] else f"rtol={r['tol']:g}" if name in ("LSODA", "Radau")
                    else f"{r['tol']:g} T" if name == "event-driven" else f"tol={r['tol']:g}")
            t, err = r["wall_time_s"], r["nrms_v"]
            times.append(t)
            twin = next((lab for lab in labels if lab[2] == text and abs(math.log10(lab[0] / t)) < 0.15
                         and abs(math.log10(lab[1] / err)) < 0.1), None)
            if twin is not None:  # the same step at the same point: one label, in grey
                twin[3] = "0.3"
            else:
                labels.append([t, err, text, f"C{k}"])
            if r.get("default"):
                ax.plot(t, err, "o", ms=12, mfc="none", mec="k", mew=1.2)
    ax.plot([], [], "o", ms=9, mfc="none", mec="k", label="the scene's default")
    ax.axvline(summary["reference_wall_time_s"], color="k", ls="--", lw=1, label="reference solver")
    if times:  # room for the rightmost labels
        left = min(min(times), summary["reference_wall_time_s"]) / 1.5
        ax.set_xlim(left, max(times) * 3.0)
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    # ticks at 1, 2, 5 x 10^k written plainly; no minor labels (they collide on short ranges)
    ax.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("wall time of the run [s]")
    ax.set_ylabel("nRMS error of v on the window [1]")
    ax.set_title(wrap_items(title, 95), fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    # below the axes, so that it covers no point and no label
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.11), ncol=2, frameon=False)
    fig.tight_layout()
    _place_labels(fig, ax, labels, fontsize=7)
    save_png(fig, path, dpi=120)


def _place_labels(fig, ax, labels, fontsize: float) -> None:
    """Annotate each (t, err, text, color) at the first of a few offsets around its point
    where the label's drawn box overlaps no earlier label, no point of the chart and stays in
    the axes (measured with the renderer, not estimated); the first offset if none is free."""
    offsets = [(5, 4), (5, -11), (-5, 4), (-5, -11), (5, 12), (5, -19), (-5, 12), (-5, -19), (0, 14), (0, -22)]
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    inside = ax.get_window_extent(renderer)
    pad = 4.5 * fig.dpi / 72.0  # a marker's half size, in pixels
    points = [ax.transData.transform((t, err)) for t, err, _, _ in labels]
    taken = [(x - pad, y - pad, x + pad, y + pad) for x, y in points]

    def free(box) -> bool:
        return (box[0] >= inside.x0 and box[2] <= inside.x1 and box[1] >= inside.y0 and box[3] <= inside.y1
                and not any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3] for b in taken))

    for t, err, text, color in labels:
        for k, (dx, dy) in enumerate(offsets + [offsets[0]]):
            note = ax.annotate(text, (t, err), fontsize=fontsize, color=color, xytext=(dx, dy),
                               textcoords="offset points",
                               ha="left" if dx > 0 else "right" if dx < 0 else "center")
            extent = note.get_window_extent(renderer)
            box = (extent.x0 - 1, extent.y0 - 1, extent.x1 + 1, extent.y1 + 1)
            if k == len(offsets) or free(box):
                taken.append(box)
                break
            note.remove()


def _legend(name: str, summary: dict) -> str:
    if name in ("LSODA", "Radau"):
        regularised = summary.get("contact") == "sticks"
        return f"{name}, monolithic, same ODEs" + (f" ({summary.get('regularisation', '')})" if regularised else "")
    if name == "event-driven":
        return "exact event-driven stick-slip solve (events to tol x T)"
    return name


def write_study(rows: list[dict], summary: dict, scenario: Scenario, out: Path) -> None:
    import json

    from ..atomic import ACCURACY_NAMES, result_set
    from ..plots import scene_label
    with result_set(Path(out), ACCURACY_NAMES) as tmp:
        plot_accuracy(rows, summary, f"{scene_label(scenario)}: error vs cost", tmp / "accuracy.png")
        (tmp / "accuracy.csv").write_text(rows_csv(rows))
        (tmp / "summary.json").write_text(json.dumps(summary, indent=2, default=float) + "\n")
