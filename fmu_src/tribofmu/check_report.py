"""What a checked call's stats say of its check: how the reported error was made, and the
advice where tol was not met (tribofmu/checked.py makes the decisions)."""
from __future__ import annotations

from .coupling.settings import CHECK_SETTINGS

CHECK_RATIO = CHECK_SETTINGS.check_ratio
MIN_ORDER = CHECK_SETTINGS.min_order
ESTIMATE_SAFETY = CHECK_SETTINGS.estimate_safety


def method_text(checked: bool, sequence, stats: dict) -> str:
    """How the reported error was made, for stats.json (sequence: checked.CheckSequence; stats:
    the reported run's), and where the run tightened its per-step tolerance for its window."""
    asked, window = stats.get("step_tol"), stats.get("window_step_tol")
    periods = (stats.get("lead_in") or {}).get("periods_before_window") or 1.0
    when = "a drive period" if periods == 1.0 else f"{periods:.0f} drive periods"
    tightened = (f"; its per-step tolerance tightened from {asked:.2g} to {window:.2g} {when} before "
                 "the window, as its own carried error asked (coupling/lead_in.py)"
                 if asked is not None and window is not None and window < asked else "")
    return _method(checked, sequence) + tightened


def _method(checked: bool, sequence) -> str:
    if checked and sequence.own:
        runs = len(sequence.records)
        before = ("" if runs == 1 else f"; it is run {runs} of {runs}, each after the first planned from the "
                  "estimate of the one before, which had missed tol or, meeting it, was to be verified by "
                  "the next")
        return (f"own: the run's carried estimate of its error (coupling/estimate.py) times {ESTIMATE_SAFETY:g}; "
                "it vouches for the run here (its derivation holds: the friction a function of dv alone "
                "whose slope is bounded, a shear-thinning fluid's, or a lubricant's whose state's error the "
                f"law's slopes carry), so the run was not repeated{before}")
    if not checked:
        return f"not checked: {sequence.limit} before the run could be repeated at a tighter tolerance"
    order = sequence.order
    how = (f"p = {MIN_ORDER:g}, the slowest convergence allowed for" if order is None else
           f"p = {order:.2g}, the order this run and the two looser ones before it showed, times "
           f"{ESTIMATE_SAFETY:g}, and at most the estimate at p = {MIN_ORDER:g}")
    return ("checked: the run was repeated at a per-step tolerance "
            f"{CHECK_RATIO:g}x tighter and the two compared on the window (Shampine's rule); the "
            f"tighter run is reported, with their difference over {CHECK_RATIO:g}^p - 1 as its error ({how})")


def advice(difference: float | None, tol: float, records: list, limit: str, kind: str) -> str:
    """The warning of a call short of tol (records: checked.RunRecord, every run)."""
    spent = sum(r.wall_time for r in records)
    last = min(records[-1].step_tol, records[-1].window_step_tol or records[-1].step_tol)
    if difference is None:
        return (f"tolerance {tol:g} not checked: {limit} after {len(records)} run(s) ({spent:.0f} s); "
                f"loosen --tol{', or raise --max-wall' if 'budget' in limit else ''}")
    return (f"tolerance {tol:g} not met: the {kind} nRMS(v) is {difference:.2g} after {len(records)} "
            f"runs ({spent:.0f} s, per-step tolerance down to {last:.2g}; {limit}); "
            f"loosen --tol{', or raise --max-wall' if 'budget' in limit else ''}")
