"""The run's progress bar (time, steps and rejections; no warning when the run ends past the
scene's float stop time: the master stops on the whole nanosecond nearest it), and signals
during a run deferred to the next step."""
import io
import signal
import warnings
from types import SimpleNamespace

import pytest

from tribofmu.progress import RunBar


class TTY(io.StringIO):
    def isatty(self):
        return True


def test_a_run_ending_on_the_nanosecond_past_the_stop_time_warns_nothing():
    stop = 6.5 * 2 * 3.141592653589793 / 30.0  # 1.3613568165...: the run ends at 1.361356817 s
    end = round(stop * 1e9) / 1e9
    assert end > stop
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with RunBar("fig6", stop, enabled=True, stream=TTY(), interval=0.0) as bar:
            bar(SimpleNamespace(t=end / 2, stop_time=end, steps=1, rejected=0))
            bar(SimpleNamespace(t=end, stop_time=end, steps=2, rejected=0))


def test_progress_bar_reports_time_steps_and_rejections():
    import io
    from tribofmu.master.run import RunProgress
    from tribofmu.progress import RunBar
    stream = io.StringIO()
    with RunBar("scene", 2.0, enabled=True, interval=0.0, stream=stream) as bar:
        bar(RunProgress(t=0.5, stop_time=2.0, steps=123, rejected=4, wall_time=0.1))
        text = stream.getvalue()
    assert "25%" in text and "123 steps, 4 rejected" in text and "t = 0.5/2 s" in text
    assert "run 1" not in text  # a call of one run names none
    assert RunBar("scene", 1.0, enabled=False)._bar is None


def test_a_signal_during_a_run_is_deferred_to_the_next_step_and_a_second_one_is_not():
    from tribofmu import progress
    reached = []
    with pytest.raises(KeyboardInterrupt):
        with progress.deferred_interrupts():
            progress._handler(signal.SIGINT, None)  # inside FMU code this must not raise
            reached.append("after the first signal")
    assert reached == ["after the first signal"]
    with pytest.raises(KeyboardInterrupt):
        with progress.deferred_interrupts():
            progress._handler(signal.SIGINT, None)
            progress._handler(signal.SIGINT, None)  # asked twice: stop now
    with pytest.raises(KeyboardInterrupt):
        progress._handler(signal.SIGTERM, None)  # outside a run: at once
    progress.check_interrupt()  # nothing pending is left behind


def _call(bar, walls_per_run, plan, stop=2.0, points=20):
    """Feed bar a checked call: run k of plan[k] ({k: runs planned}), each run's statuses
    over its simulated time with its wall time growing to walls_per_run[k]; returns the
    fractions shown after each status and the projected rests."""
    from tribofmu.master.run import RunProgress
    from tribofmu.progress import run_started
    shown, rests = [], []
    for k, wall in enumerate(walls_per_run, start=1):
        run_started(k, plan[k])
        for i in range(1, points + 1):
            bar(RunProgress(t=stop * i / points, stop_time=stop, steps=10 * i, rejected=0,
                            wall_time=wall * i / points))
            shown.append(bar.fraction)
            rests.append(bar.remaining())
    return shown, rests


def test_one_bar_over_a_checked_call_never_runs_backwards_and_names_its_run():
    """A 40-period fig6 run's check: three runs, the third added after the pair; the bar
    went 0 -> 58 % -> 23 % as each run started before."""
    stream = TTY()
    with RunBar("fig6_boundary", 2.0, enabled=True, stream=stream, interval=0.0) as bar:
        shown, _ = _call(bar, [10.0, 11.0, 12.0], {1: 2, 2: 2, 3: 3})
        text = stream.getvalue()
    assert all(b >= a for a, b in zip(shown, shown[1:])), shown
    assert shown[-1] >= 0.9 and shown[19] <= 0.6  # the first run of a pair: under half the call
    # the run the check added goes on from where the bar was, over the rest of it (no stall)
    assert shown[59] - shown[39] >= 0.5 * (1.0 - shown[39]), (shown[39], shown[59])
    assert "run 1 of 2" in text and "run 2 of 2" in text and "run 3 of 3" in text


def test_the_time_projection_covers_the_whole_call():
    from tribofmu.master.run import RunProgress
    from tribofmu.progress import EXTRA_RUN_CHANCE, FURTHER_RUN_COST, run_started
    stream = TTY()
    with RunBar("fig6_boundary", 2.0, enabled=True, stream=stream, interval=0.0) as bar:
        run_started(1, 2)
        bar(RunProgress(t=0.5, stop_time=2.0, steps=10, rejected=0, wall_time=60.0))  # a quarter in 1 min
        # this run: 3 min more; the pair's second run: 4 min at FURTHER_RUN_COST, and the
        # chance of a third
        assert bar.remaining() == pytest.approx(180.0 + (1 + EXTRA_RUN_CHANCE) * FURTHER_RUN_COST * 240.0)
        bar.notice("this run will take about 4 min at its present pace")
        text = stream.getvalue()
    assert "run 1 of 2 planned so far; the whole call about" in text
    whole = 60.0 + 180.0 + (1 + EXTRA_RUN_CHANCE) * FURTHER_RUN_COST * 240.0
    from tribofmu.master.run import _duration
    assert f"the whole call about {_duration(whole)}" in text


def test_a_bar_outside_a_checked_call_hears_of_no_runs():
    from tribofmu.progress import run_started
    run_started(2, 2)  # no bar entered: nobody to tell, nothing raised
    bar = RunBar("scene", 1.0, enabled=False)
    assert bar.runs == 1
