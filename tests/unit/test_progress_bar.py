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
