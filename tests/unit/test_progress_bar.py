"""The run's progress bar prints no warning when the run ends past the scene's float stop
time (the master stops on the whole nanosecond nearest it)."""
import io
import warnings
from types import SimpleNamespace

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
