"""The run's pace check (master/run.py): a run is stopped past max_wall or when its recent pace
projects past it, never by a slow start it has left behind. On a fake clock and a fake coupling
whose steps cost scripted wall seconds: no FMU, no real time."""
from __future__ import annotations

import importlib

import pytest

from tribofmu.coupling.interpolation import NS
from tribofmu.coupling.system import Contact, Point
from tribofmu.master.run import RunLimits, run

run_module = importlib.import_module("tribofmu.master.run")  # (tribofmu.master.run is also the function)

STOP = 100.0  # s simulated, in steps of STEP
STEP = 0.1  # s


class Clock:
    """perf_counter as the fake coupling advances it."""

    def __init__(self):
        self.now = 0.0

    def perf_counter(self) -> float:
        return self.now


class Counters:
    steps = rejected = landed = iterations = forced = stick_steps = 0


class PacedCoupling:
    """Steps of STEP s whose wall cost is cost(t) [s] at simulated t."""

    def __init__(self, clock: Clock, cost):
        self.clock, self.cost, self.counters = clock, cost, Counters()

    def prepare(self, system, scales):
        pass

    def observe(self, points):
        pass

    def advance(self, system, point, stop_ns):
        self.clock.now += self.cost(point.t_ns / NS)
        self.counters.steps += 1
        return [Point(min(point.t_ns + int(STEP * NS), stop_ns), mode=Contact.FORWARD)]

    def finish(self, system):
        pass


class System:
    calls: dict = {}
    calls_by_kind: dict = {}

    def start_point(self):
        return Point(0)


def paced_run(monkeypatch, cost, limits):
    clock = Clock()
    monkeypatch.setattr(run_module, "_time", clock)
    notices = []
    outcome = run(System(), PacedCoupling(clock, cost), STOP, None, limits=limits, notice=notices.append)
    return outcome, clock.now, notices


def slow_start(t: float) -> float:
    """1 s a step for the first 0.5 simulated s (a collapse from rest), then 10 ms: 5 + ~10 s."""
    return 1.0 if t < 0.5 else 1e-2


def test_a_run_slow_at_its_start_then_fast_is_not_stopped(monkeypatch):
    # at 3 s it has spent all its time on 0.3 % of the span: the average pace (and the recent,
    # the same) projects 1000 s, past max_wall; once past the slow start the recent pace
    # finishes in time (as it does)
    outcome, wall, notices = paced_run(monkeypatch, slow_start, RunLimits(max_wall=60.0, notice_after=40.0))
    assert outcome.ok and not outcome.out_of_time, outcome.message
    assert outcome.points[-1].t_ns == int(STOP * NS)
    assert 14.0 < wall < 16.0
    assert not notices  # its slow start alone does not say the run will take long


def test_a_run_that_stays_slow_is_stopped_with_one_line(monkeypatch):
    # 0.5 s a step: 500 s in all against max_wall 60; judged at 3 s, stopped once it has
    # spent a tenth of max_wall
    outcome, wall, notices = paced_run(monkeypatch, lambda t: 0.5, RunLimits(max_wall=60.0, notice_after=1e9))
    assert not outcome.ok and outcome.out_of_time
    assert wall == pytest.approx(6.0)
    assert "\n" not in outcome.message
    assert outcome.message.startswith("stopped at t = 1.2 s of 100 s after 6 s: at this pace the run would "
                                      "take 8.33 min"), outcome.message
    assert "--max-wall" in outcome.message and "past --max-wall" not in outcome.message


def test_the_notice_gives_the_runs_cost_up_front(monkeypatch):
    # 0.2 s a step: 200 s in all, told once, at the second judged interval (6 s)
    outcome, wall, notices = paced_run(monkeypatch, lambda t: 0.2, RunLimits(max_wall=1000.0, notice_after=120.0))
    assert outcome.ok and wall == pytest.approx(200.0)
    assert len(notices) == 1 and "\n" not in notices[0]
    assert notices[0].startswith("this run will take about 3.33 min at its present pace (step now 0.1 s, 30 steps"), notices[0]


def test_a_run_slowed_down_late_is_stopped_by_its_recent_pace_or_past_max_wall(monkeypatch):
    # fast for 90 s of 100 (0.01 s a step: 9 s), then 2 s a step (200 s more): the average
    # pace projects within max_wall for a while; it is stopped at max_wall at the latest
    outcome, wall, notices = paced_run(monkeypatch, lambda t: 0.01 if t < 90.0 else 2.0,
                                       RunLimits(max_wall=60.0, notice_after=1e9))
    assert not outcome.ok and outcome.out_of_time
    assert 50.0 < wall <= 62.0
    assert "would take" in outcome.message and "\n" not in outcome.message


def test_a_run_past_max_wall_before_its_first_judgement_is_stopped(monkeypatch):
    outcome, wall, _ = paced_run(monkeypatch, lambda t: 0.5, RunLimits(max_wall=1.0))
    assert not outcome.out_of_time or wall <= 1.5
    assert outcome.out_of_time and "past --max-wall" in outcome.message and "\n" not in outcome.message


def test_no_max_wall_never_stops(monkeypatch):
    outcome, wall, _ = paced_run(monkeypatch, lambda t: 0.5, RunLimits(max_wall=None))
    assert outcome.ok and wall == pytest.approx(500.0)
