"""The check's runs two at a time (tribofmu.forked_runs), against fake runs: the same runs are
taken and the same result reported as one at a time; a run started ahead and not asked for is
stopped and leaves nothing; a child's exception, progress and notices reach the parent; a child
killed, or a parent killed, ends cleanly."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time

from pathlib import Path

import numpy as np
import pytest

from tribofmu import checked, forked_runs
from tribofmu.errors import ArgumentError, FMUCallError, TriboFMUError
from tribofmu.master.run import RunProgress
from tribofmu.run_folder import run_folder

from test_checked import FakeRuns, VouchingRuns, power_law

pytestmark = pytest.mark.skipif(not hasattr(os, "fork"), reason="forked runs need fork()")


class EstimatingRuns(FakeRuns):
    """FakeRuns whose own (propagated) estimate is ``own`` times its true window error."""

    def __init__(self, error, own: float):
        super().__init__(error)
        self.own = own

    def __call__(self, **kw):
        result = super().__call__(**kw)
        exact = FakeRuns(lambda step_tol: 0.0)(step_tol=1.0)
        result.stats["estimated_error"] = {"nrms_v": self.own * checked.window_difference(result, exact)}
        return result


def sequence(workers, error, sink=None, own=None, **kw):
    runs = FakeRuns(error) if own is None else EstimatingRuns(error, own)
    return checked.checked_simulation(runs, tol=1e-3, max_wall=None, sink=sink, workers=workers, **kw)


def leftovers() -> list[str]:
    """What runs left in this process's run folder (spools, result pickles)."""
    return sorted(p.name for p in run_folder().iterdir() if p.name.startswith(("run-", "tribofmu-spool-")))


@pytest.mark.parametrize("error", [power_law(0.3), power_law(2.0), power_law(300.0), power_law(50.0, 0.5)],
                         ids=["one pair", "a chain of three", "a new pair planned", "slow order"])
def test_two_workers_take_the_same_runs_and_report_the_same_result(error):
    before = leftovers()
    one, two = sequence(1, error), sequence(2, error)
    assert [r["step_tol"] for r in two.stats["check"]["runs"]] == [r["step_tol"] for r in one.stats["check"]["runs"]]
    assert np.array_equal(one.v, two.v)
    assert two.ok == one.ok and two.stats["estimated_error"] == one.stats["estimated_error"]
    assert two.stats["check"]["workers"] == 2 and one.stats["check"]["workers"] == 1
    assert leftovers() == before


@pytest.mark.parametrize("own", [power_law(0.2), power_law(2.0), power_law(0.02, 0.3)],
                         ids=["one run", "a second planned", "slow order"])
def test_two_workers_take_the_same_vouching_runs_and_report_the_same_result(own):
    before = leftovers()
    one, two = (checked.checked_simulation(VouchingRuns(own, own=own), tol=1e-3, max_wall=None, workers=w)
                for w in (1, 2))
    assert [r["step_tol"] for r in two.stats["check"]["runs"]] == [r["step_tol"] for r in one.stats["check"]["runs"]]
    assert np.array_equal(one.v, two.v)
    assert two.ok == one.ok and two.stats["estimated_error"] == one.stats["estimated_error"]
    assert leftovers() == before


AHEAD = 1e-3 / (checked.ESTIMATE_SAFETY / checked.STEP_CONTROL.safety) ** 1.5  # tol 1e-3's run ahead


class TimedVouchingRuns(VouchingRuns):
    """VouchingRuns that tell their progress halfway, at ``wall_time`` [s] into the run."""

    def __init__(self, error, own, wall_time, order=None):
        super().__init__(error, own=own, order=order)
        self.wall_time = wall_time

    def __call__(self, step_tol=None, max_wall=None, sink=None, progress=None, notice=None, aim=False):
        if progress is not None:
            progress(RunProgress(t=1.0, stop_time=2.0, steps=5, rejected=0, wall_time=self.wall_time))
        return super().__call__(step_tol, max_wall=max_wall, sink=sink, progress=progress, notice=notice)


@pytest.mark.parametrize("own, steps, here, stopped", [
    (power_law(0.09, 2.0 / 3.0), [1e-3, AHEAD], 1, 0),  # planned at 3.5e-4: the run ahead is taken
    (power_law(0.2), [1e-3], 1, 1),  # the first meets tol: the run ahead is stopped unused
    (power_law(2.0), [1e-3, None], 2, 1),  # planned past a check ratio from it: a new run, here
], ids=["the run ahead taken", "one run", "a second planned elsewhere"])
def test_a_scene_whose_runs_vouch_runs_the_first_here_and_its_successor_ahead(own, steps, here, stopped):
    """The first run of a scene whose runs vouch runs in the call's process (most often the
    last: a fork would only cost), and the run its plan most likely asks for next ahead in a
    child (CheckSequence.then); the same runs and result as one at a time."""
    before = leftovers()
    runs = TimedVouchingRuns(own, own=own, wall_time=2 * forked_runs.PROGRESS_EVERY_S, order=2.0 / 3.0)
    two = checked.checked_simulation(runs, tol=1e-3, max_wall=None, workers=2, vouches=True)
    one = checked.checked_simulation(VouchingRuns(own, own=own, order=2.0 / 3.0), tol=1e-3, max_wall=None,
                                     workers=1, vouches=True)
    taken = [r["step_tol"] for r in two.stats["check"]["runs"]]
    assert len(taken) == len(steps) and taken == [r["step_tol"] for r in one.stats["check"]["runs"]]
    assert all(want is None and got < AHEAD / checked.CHECK_RATIO or got == pytest.approx(want)
               for got, want in zip(taken, steps))
    assert np.array_equal(one.v, two.v) and two.ok and one.ok
    assert len(runs.calls) == here  # (a forked run's call is not recorded here)
    assert two.stats["check"]["workers"] == 2 and two.stats["check"]["runs_stopped_unused"] == stopped
    assert leftovers() == before


class TighteningRuns(TimedVouchingRuns):
    """TimedVouchingRuns whose aiming run tightens its tolerance for its window after its first
    progress report (the run ahead started by then) and tells so in the next, as a run whose
    lead-in decided does (coupling/lead_in.py); its errors are the tightened tolerance's."""

    def __call__(self, step_tol=None, max_wall=None, sink=None, progress=None, notice=None, aim=False):
        window = step_tol / 4.0 if aim else step_tol
        if progress is not None:
            progress(RunProgress(t=0.8, stop_time=2.0, steps=4, rejected=0, wall_time=self.wall_time,
                                 step_tol=step_tol))
            time.sleep(0.2)  # (the child ahead has started)
            self.children_before = child_processes()
            progress(RunProgress(t=1.2, stop_time=2.0, steps=6, rejected=0, wall_time=self.wall_time,
                                 step_tol=window))
            self.children_after = child_processes()
        result = VouchingRuns.__call__(self, window, max_wall=max_wall, sink=sink, notice=notice)
        result.stats["step_tol"], result.stats["window_step_tol"] = step_tol, window
        return result


def child_processes() -> set[int]:
    """This process's live children (Linux's /proc)."""
    pid = os.getpid()
    return {int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()}


def test_a_first_run_that_tightens_for_its_window_stops_the_run_ahead_of_it():
    """Tightened, the run here is planned to meet tol: the run ahead, started before its
    decision, is stopped then (its CPU is not spent), and the call ends on the one run."""
    before = leftovers()
    own = power_law(0.5)  # 5e-4 at 1e-3: past tol with the margin; 1.25e-4 tightened: met
    runs = TighteningRuns(own, own=own, wall_time=2 * forked_runs.PROGRESS_EVERY_S)
    result = checked.checked_simulation(runs, tol=1e-3, max_wall=None, workers=2, vouches=True)
    assert result.ok and len(result.stats["check"]["runs"]) == 1 and len(runs.calls) == 1
    assert result.stats["check"]["runs_stopped_unused"] == 1
    assert runs.children_before and not runs.children_after  # stopped at the decision, not at the end
    assert leftovers() == before


class AimingRuns(TimedVouchingRuns):
    """TimedVouchingRuns whose first run aims at its window and tells, a second into it and
    with half of it to go, what its lead-in's mark found: the budget in reach or not."""

    def __init__(self, error, own, reachable, order=None):
        super().__init__(error, own=own, wall_time=10 * forked_runs.PROGRESS_EVERY_S, order=order)
        self.reachable = reachable

    def __call__(self, step_tol=None, max_wall=None, sink=None, progress=None, notice=None, aim=False):
        if progress is not None:
            progress(RunProgress(t=0.8, stop_time=2.0, steps=4, rejected=0, wall_time=self.wall_time,
                                 step_tol=step_tol, aims_at_window=True, window_reachable=self.reachable))
            time.sleep(0.2)  # (a child ahead, if any, has started)
            self.children = child_processes()
        return VouchingRuns.__call__(self, step_tol, max_wall=max_wall, sink=sink, notice=notice)


def test_a_first_run_whose_window_is_in_reach_starts_nothing_ahead():
    """Its lead-in's mark finds the budget in reach: the run most likely ends the call, and a
    fork ahead of it would only cost (however long it has run)."""
    before = leftovers()
    runs = AimingRuns(power_law(0.2), own=power_law(0.2), reachable=True)
    result = checked.checked_simulation(runs, tol=1e-3, max_wall=None, workers=2, vouches=True)
    assert result.ok and len(result.stats["check"]["runs"]) == 1 and not runs.children
    assert result.stats["check"]["runs_stopped_unused"] == 0
    assert leftovers() == before


def test_a_first_run_whose_window_is_out_of_reach_starts_its_successor_ahead():
    """Its lead-in's mark finds no tightening that meets the budget, with half of it to go:
    the run its plan most likely asks for next starts ahead, and is the one taken."""
    before = leftovers()
    own = power_law(0.09, 2.0 / 3.0)
    runs = AimingRuns(own, own=own, reachable=False, order=2.0 / 3.0)
    result = checked.checked_simulation(runs, tol=1e-3, max_wall=None, workers=2, vouches=True)
    taken = [r["step_tol"] for r in result.stats["check"]["runs"]]
    assert result.ok and runs.children and len(runs.calls) == 1  # (the second ran in the child)
    assert taken == [1e-3, pytest.approx(AHEAD)] and result.stats["check"]["runs_stopped_unused"] == 0
    assert leftovers() == before


def test_a_first_run_that_vouches_and_ends_before_its_first_progress_report_starts_nothing_ahead():
    """(A fork costs the parent its copied pages while the child lives: a short run does not
    wait for one ahead.)"""
    own = power_law(0.2)
    runs = TimedVouchingRuns(own, own=own, wall_time=0.5 * forked_runs.PROGRESS_EVERY_S)
    result = checked.checked_simulation(runs, tol=1e-3, max_wall=None, workers=2, vouches=True)
    assert len(runs.calls) == 1 and result.ok and result.stats["check"]["runs_stopped_unused"] == 0


def test_the_sink_gets_the_reported_runs_samples_once_from_a_forked_run():
    received = []
    result = sequence(2, power_law(300.0), sink=lambda start, signals: received.append((start, signals)))
    assert [start for start, _ in received] == [0, 100]
    assert np.array_equal(np.concatenate([s["v"] for _, s in received]), result.v)


def test_a_run_started_ahead_and_not_asked_for_is_stopped():
    # the first run's own estimate (10x its error) says the pair will not meet tol: the chain's
    # third run starts when the first ends; the pair meets tol, and the third is stopped
    result = sequence(2, power_law(0.3), own=10.0)
    assert len(result.stats["check"]["runs"]) == 2
    assert result.stats["check"]["runs_stopped_unused"] == 1


def test_a_first_run_whose_estimate_says_its_pair_meets_tol_starts_nothing_ahead():
    one = sequence(2, power_law(0.3), own=1.0)
    assert len(one.stats["check"]["runs"]) == 2 and one.stats["check"]["runs_stopped_unused"] == 0
    # a wrong guess costs time, never the answer: the same runs and result as one at a time
    fooled = sequence(2, power_law(2.0), own=0.01)
    alone = sequence(1, power_law(2.0))
    assert [r["step_tol"] for r in fooled.stats["check"]["runs"]] == [r["step_tol"] for r in alone.stats["check"]["runs"]]
    assert np.array_equal(fooled.v, alone.v) and fooled.ok == alone.ok


def test_nothing_runs_ahead_of_a_pair_the_plan_expects_to_meet_tol():
    # error = step_tol: the first pair misses (its checked error at MIN_ORDER), and the chain's
    # one more factor is expected to meet tol; the third run meets it, and no fourth was started
    result = sequence(2, power_law(1.0))
    assert len(result.stats["check"]["runs"]) == 3 and result.ok
    assert result.stats["check"]["runs_stopped_unused"] == 0
    # two more factors expected: the fourth is started ahead (and stopped when the third meets)
    result = sequence(2, power_law(1.5))
    assert len(result.stats["check"]["runs"]) == 3 and result.stats["check"]["runs_stopped_unused"] == 1


def test_a_run_with_nothing_to_run_beside_it_runs_in_the_calls_process():
    runs = forked_runs.ForkedRuns(lambda **kw: os.getpid(), lambda: None, 2)
    try:
        assert runs.take(1e-3, None) == (os.getpid(), None)  # no fork: nothing else to run at once
        assert runs.take(1e-3, None, then=5e-4)[0] != os.getpid()
    finally:
        runs.close()


def test_a_childs_exception_is_raised_in_the_parent_as_it_was():
    def failing(**kw):
        raise FMUCallError("friction", "fmi2DoStep", 3, ["at t = 0.1 s"])

    runs = forked_runs.ForkedRuns(failing, lambda: None, 2)
    try:
        with pytest.raises(FMUCallError, match="friction: fmi2DoStep returned fmi2Error: at t = 0.1 s") as caught:
            runs.take(1e-3, None, then=5e-4)
        assert (caught.value.instance, caught.value.status) == ("friction", 3)
    finally:
        runs.close()
    assert not runs.children


def test_an_exception_that_does_not_come_back_from_a_pickle_is_one_line_with_its_words():
    class Odd(Exception):
        def __init__(self, a, b):
            super().__init__(f"odd {a} {b}")

    def failing(**kw):
        raise Odd(1, 2)

    runs = forked_runs.ForkedRuns(failing, lambda: None, 2)
    with pytest.raises(TriboFMUError, match="Odd: odd 1 2"):
        runs.take(1e-3, None, then=5e-4)
    runs.close()


def test_every_error_of_ours_comes_back_from_a_pickle_as_it_was():
    import pickle

    from tribofmu import errors

    for cls in [c for c in vars(errors).values() if isinstance(c, type) and issubclass(c, errors.TriboFMUError)]:
        error = (cls("friction", "fmi3DoStep", 4, ["lost"]) if cls is errors.FMUCallError else cls("one line"))
        back = pickle.loads(pickle.dumps(error))
        assert type(back) is cls and str(back) == str(error)


def test_a_child_killed_from_outside_is_one_line_naming_its_run():
    def killed(**kw):
        os.kill(os.getpid(), signal.SIGKILL)

    runs = forked_runs.ForkedRuns(killed, lambda: None, 2)
    with pytest.raises(TriboFMUError, match=r"per-step tolerance 0.001 ended without a result \(killed by signal 9\)"):
        runs.take(1e-3, None, then=5e-4)
    runs.close()


def test_progress_and_notices_of_the_awaited_run_reach_the_callbacks():
    def talking(step_tol=None, progress=None, notice=None, **kw):
        notice(f"this run will take about 2 h (at {step_tol:g})")
        for k in range(1, 4):
            progress(RunProgress(t=k / 3, stop_time=1.0, steps=10 * k, rejected=k, wall_time=0.01 * k))
            time.sleep(0.15)  # past the child's PROGRESS_EVERY_S: each one is told
        return step_tol

    told, notices = [], []
    runs = forked_runs.ForkedRuns(talking, lambda: None, 2, progress=told.append, notice=notices.append)
    try:
        assert runs.take(1e-3, None, then=5e-4) == (1e-3, None)  # (the result, no spool)
    finally:
        runs.close()
    assert [p.steps for p in told] == [10, 20, 30] and told[-1].t == pytest.approx(1.0)
    assert notices == ["this run will take about 2 h (at 0.001)"]


def test_a_stop_raised_by_the_progress_callback_stops_every_child_and_leaves_nothing():
    def slow(progress=None, **kw):
        for _ in range(600):
            progress(RunProgress(t=0.1, stop_time=1.0, steps=1, rejected=0, wall_time=0.1))
            time.sleep(0.05)

    def stop(_status):
        raise KeyboardInterrupt

    before = leftovers()
    runs = forked_runs.ForkedRuns(slow, checked.Spool, 2, progress=stop)
    started = time.monotonic()
    try:
        with pytest.raises(KeyboardInterrupt):
            runs.take(1e-3, None, then=5e-4)
        pids = [c.pid for c in runs.children]
        assert len(pids) == 2
    finally:
        runs.close()
    assert time.monotonic() - started < 10.0
    for pid in pids:  # reaped: no zombie, no process
        with pytest.raises(ChildProcessError):
            os.waitpid(pid, os.WNOHANG)
    assert leftovers() == before


def test_children_die_with_a_parent_killed_by_sigkill(tmp_path):
    if not sys.platform.startswith("linux"):
        pytest.skip("PR_SET_PDEATHSIG is Linux's")
    script = textwrap.dedent("""
        import sys, time
        from tribofmu import forked_runs
        def slow(**kw):
            time.sleep(60)
        runs = forked_runs.ForkedRuns(slow, lambda: None, 2)
        runs._start(1e-3, None)
        runs._start(5e-4, None)
        print(" ".join(str(c.pid) for c in runs.children), flush=True)
        time.sleep(60)
    """)
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    try:
        pids = [int(p) for p in parent.stdout.readline().split()]
        assert len(pids) == 2
        parent.kill()
        parent.wait(timeout=10)
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and any(_alive(p) for p in pids):
            time.sleep(0.05)
        assert not any(_alive(p) for p in pids)
    finally:
        parent.kill()


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"  # a zombie waits for init: gone
    except FileNotFoundError:
        return False


@pytest.mark.parametrize("value, expected", [("1", 1), ("2", 2), ("8", 2)])
def test_the_environment_sets_the_workers_up_to_two_and_the_cores(monkeypatch, value, expected):
    monkeypatch.setenv(forked_runs.WORKERS_VARIABLE, value)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert forked_runs.check_workers() == min(expected, cores)


@pytest.mark.parametrize("value", ["0", "two", "-1", "1.5"])
def test_a_wrong_workers_variable_is_one_line_naming_it(monkeypatch, value):
    monkeypatch.setenv(forked_runs.WORKERS_VARIABLE, value)
    with pytest.raises(ArgumentError, match=forked_runs.WORKERS_VARIABLE):
        forked_runs.check_workers()


@pytest.mark.parametrize("value", [0, True, 1.0, "2"])
def test_a_wrong_workers_argument_is_refused(value):
    with pytest.raises(ArgumentError, match="check_workers must be a whole number >= 1"):
        forked_runs.check_workers(value)


def test_by_default_a_linux_call_uses_two_cores_when_it_has_them(monkeypatch):
    monkeypatch.delenv(forked_runs.WORKERS_VARIABLE, raising=False)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    expected = min(2, cores) if sys.platform.startswith("linux") else 1
    assert forked_runs.check_workers() == expected


def test_a_call_from_another_thread_runs_one_run_at_a_time():
    import threading

    seen = []
    worker = threading.Thread(target=lambda: seen.append(forked_runs.check_workers(2)))
    worker.start()
    worker.join()
    assert seen == [1]


def test_a_fork_that_fails_runs_the_run_here_and_leaves_the_collector_as_it_was(monkeypatch):
    import gc

    def no_fork():
        raise BlockingIOError(11, "Resource temporarily unavailable")

    monkeypatch.setattr(os, "fork", no_fork)
    before = leftovers()
    result = sequence(2, power_law(0.3), sink=lambda start, signals: None)
    alone = sequence(1, power_law(0.3))
    assert np.array_equal(result.v, alone.v) and result.ok == alone.ok
    assert gc.get_freeze_count() == 0 and gc.isenabled()
    assert leftovers() == before


def test_the_collector_takes_back_the_parents_objects_after_a_fork():
    import gc

    sequence(2, power_law(0.3))
    assert gc.get_freeze_count() == 0


class OutOfTimeRuns(FakeRuns):
    """FakeRuns whose runs tighter than ``below`` run out of their budget (keyed by the
    per-step tolerance: a forked run's call count is its own)."""

    def __init__(self, error, below: float):
        super().__init__(error)
        self.below = below

    def __call__(self, step_tol=None, **kw):
        result = super().__call__(step_tol=step_tol, **kw)
        if step_tol < self.below:
            result.ok, result.message = False, "stopped at t = 1 s: at this pace the run would take 2 h"
            result.stats["out_of_time"] = True
        return result


def test_a_run_out_of_its_budget_ends_the_sequence_as_one_at_a_time_does():
    before = leftovers()
    made = [checked.checked_simulation(OutOfTimeRuns(power_law(300.0), below=6e-4), tol=1e-3, max_wall=100.0,
                                       workers=workers) for workers in (1, 2)]
    one, two = made
    assert not two.ok and two.message == one.message and "not checked" in two.message
    assert [r["step_tol"] for r in two.stats["check"]["runs"]] == [r["step_tol"] for r in one.stats["check"]["runs"]]
    assert np.array_equal(one.v, two.v)
    assert leftovers() == before
