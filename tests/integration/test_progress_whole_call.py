"""The progress bar of a real checked call: told of each run by the check (run k of n), one
bar that never runs backwards (it went 58 % -> 23 % as each run of the check started)."""
import io

import pytest

from scenes import scene

pytestmark = pytest.mark.integration


class TTY(io.StringIO):
    def isatty(self):
        return True


def test_a_checked_call_shows_one_bar_that_never_runs_backwards(fmu_dir):
    from tribofmu import api
    from tribofmu.progress import RunBar

    # dry friction under a load program (a Load FMU changes n): its runs cannot vouch for
    # themselves, the call makes several
    scenario = api.load(scene("dry_load_oscillation"), {"time.periods": 2.0, "time.window": [1.0, 2.0]})
    shown, runs = [], []
    stream = TTY()

    class Watched(RunBar):
        def __call__(self, status):
            super().__call__(status)
            shown.append(self.fraction)
            runs.append((self.run, self.runs))

    with Watched(scenario.name, scenario.stop_time, enabled=True, stream=stream, interval=0.0) as bar:
        result = api.simulate(scenario, fmu_dir=fmu_dir, build=False, progress=bar)
    made = len(result.stats["check"]["runs"])
    assert made >= 2 and runs[-1] == (made, made), runs[-1]
    assert sorted({k for k, _ in runs}) == list(range(1, made + 1))
    assert all(b >= a for a, b in zip(shown, shown[1:]))
    assert f"run {made} of {made}" in stream.getvalue()
