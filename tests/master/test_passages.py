"""coupling/passages.py: a passage near a melt that the run did not take, measured against
the run's own error in f; the loop's growth against its eigenvalues."""
from __future__ import annotations

import numpy as np
import pytest

from tribofmu.coupling.passages import NearRunaways, loop_growth


class ThresholdLaw:
    """A lubricant that melts at f = 1 (melt_margin as the boundary law's)."""

    def melt_margin(self, f: float) -> float:
        return 1.0 - f


STABLE = (4.0e3, 2.0e-2, 1.0e10, -1.0e5)  # p q < c (-r): the loop damps
UNSTABLE = (4.0e3, 6.0e-2, 2.0e10, -1.0e5)  # p q > c (-r)


@pytest.mark.parametrize("slopes, grows", [(STABLE, False), (UNSTABLE, True), ((0.0, 0.0, 0.0, -5.0), False),
                                           ((1.0, 1.0, -3.0, 0.5), False), ((1.0, 0.0, 0.0, 0.5), True)])
def test_the_loop_growth_is_the_larger_real_part_of_the_loops_eigenvalues(slopes, grows):
    c, p, q, r = slopes
    expected = max(np.linalg.eigvals(np.array([[-c, p], [q, r]])).real)
    assert loop_growth(*slopes) == pytest.approx(expected, rel=1e-9, abs=1e-9)
    assert (loop_growth(*slopes) > 0) == grows


def passage(error: float, f_path=(0.80, 0.82, 0.84, 0.85), end=STABLE) -> NearRunaways:
    """A run whose loop turns unstable at f_path[0] and follows f_path with a carried error
    ``error`` in f, then ends with a step of slopes ``end`` to f = 0.83."""
    watch = NearRunaways(ThresholdLaw(), safety=2.0)
    watch.step(STABLE, 0.78, f_path[0], 0.0)
    for f0, f1 in zip(f_path, f_path[1:]):
        watch.step(UNSTABLE, f0, f1, error)
    watch.step(end, f_path[-1], 0.83, error)
    return watch


def test_a_passage_that_turns_back_within_the_runs_own_error_of_its_rise_is_undecided():
    # the rise 0.80 -> 0.85 is 0.05; with the margin 2, an error of 0.025 reaches it
    assert passage(0.03).undecided and passage(0.03).ratio == pytest.approx(2 * 0.03 / 0.05)
    assert not passage(0.02).undecided and passage(0.02).ratio == pytest.approx(0.8)


def test_a_passage_that_melts_is_decided_whatever_the_error():
    watch = passage(0.5, f_path=(0.80, 0.9, 1.05))  # f passed the threshold: the melt was taken
    assert watch.ratio == 0.0 and not watch.undecided


def test_a_passage_in_which_f_only_fell_is_no_approach_to_a_melt():
    # (re-solidifying: the loop briefly unstable as the modulus returns, f falling)
    watch = passage(0.5, f_path=(0.99, 0.95, 0.90))
    assert watch.ratio == 0.0 and not watch.undecided


def test_the_worst_passage_of_the_run_counts():
    watch = passage(0.03)
    watch.step(UNSTABLE, 0.80, 0.82, 1e-4)
    watch.step(STABLE, 0.82, 0.81, 1e-4)  # a later, well decided one does not clear it
    assert watch.undecided


def test_a_snapshot_taken_inside_a_passage_carries_it_and_the_estimates_flags():
    """A run restored to a state snapshot (a host's set-FMU-state on the pair) reports as if it
    had never gone past it: the passage under way, the worst ratio so far and the carry's flags
    travel with the estimate's export, through JSON."""
    import json

    from tribofmu.coupling.estimate import GlobalErrorEstimate
    from tribofmu.physics.laws.boundary import BoundaryLaw

    law = BoundaryLaw(m=0.05, gamma=-2 / 3, S=3e-9)
    estimate = GlobalErrorEstimate(law)
    estimate.near_runaways.law = ThresholdLaw()  # (melting at f = 1, as the fake passages above)
    estimate.ex, estimate.ev, estimate.ef, estimate.w2 = 1e-6, 2e-5, 3e-2, 1e4
    estimate.watch(STABLE, 0.78, 0.80)
    estimate.watch(UNSTABLE, 0.80, 0.84)  # inside the passage: it has not turned back yet
    snapshot = json.loads(json.dumps(estimate.export()))
    estimate.saturated = estimate.passed_event = True
    estimate.watch(STABLE, 0.84, 0.83)  # it turns back: undecided (2 x 0.03 over a rise of 0.04)
    assert estimate.near_runaways.undecided

    restored = GlobalErrorEstimate(law)
    restored.near_runaways.law = ThresholdLaw()
    restored.restore(snapshot)
    assert not restored.saturated and not restored.passed_event and restored.near_runaways.ratio == 0.0
    restored.watch(STABLE, 0.84, 0.83)  # the same step again after the restore: the same verdict
    assert restored.near_runaways.ratio == estimate.near_runaways.ratio
    # a snapshot that went past it is restored with what it had seen, on an estimate that had not
    later = GlobalErrorEstimate(law)
    later.restore(json.loads(json.dumps(estimate.export())))
    assert later.saturated and later.passed_event and later.near_runaways.undecided
