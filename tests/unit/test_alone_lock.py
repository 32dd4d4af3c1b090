"""The test suite's own machinery (tests/suite_support.py): a test marked ``alone`` runs with no
other test beside it, and the summary's time per tier adds up what each tier took."""
from __future__ import annotations

import re
import threading
import time
import types

from suite_support import TierClock, tier_of, turn

WAIT = 0.3  # s: long enough for a thread that is free to go to have gone


def entered_within(run_dir, alone: bool, entered: threading.Event, leave: threading.Event) -> threading.Thread:
    def take():
        with turn(run_dir, alone):
            entered.set()
            leave.wait(30)
    thread = threading.Thread(target=take, daemon=True)
    thread.start()
    return thread


def test_an_alone_turn_waits_for_shared_ones_and_they_for_it(tmp_path):
    """(flock locks belong to open files: two threads of one process contend as two workers do.)"""
    shared_in, shared_out = threading.Event(), threading.Event()
    other_shared_in, other_shared_out = threading.Event(), threading.Event()
    entered_within(tmp_path, False, shared_in, shared_out)
    entered_within(tmp_path, False, other_shared_in, other_shared_out)
    assert shared_in.wait(10) and other_shared_in.wait(10)  # shared turns run side by side
    alone_in, alone_out = threading.Event(), threading.Event()
    entered_within(tmp_path, True, alone_in, alone_out)
    assert not alone_in.wait(WAIT)  # not while a shared test runs
    shared_out.set()
    assert not alone_in.wait(WAIT)
    other_shared_out.set()
    assert alone_in.wait(10)
    late_in, late_out = threading.Event(), threading.Event()
    entered_within(tmp_path, False, late_in, late_out)
    assert not late_in.wait(WAIT)  # no shared test starts while the alone one runs
    alone_out.set()
    assert late_in.wait(10)
    late_out.set()


def test_a_waiting_alone_turn_goes_before_the_next_shared_one(tmp_path):
    first_in, first_out = threading.Event(), threading.Event()
    entered_within(tmp_path, False, first_in, first_out)
    assert first_in.wait(10)
    alone_in, alone_out = threading.Event(), threading.Event()
    entered_within(tmp_path, True, alone_in, alone_out)
    time.sleep(WAIT)  # the alone turn waits at the room, holding the turnstile
    next_in, next_out = threading.Event(), threading.Event()
    entered_within(tmp_path, False, next_in, next_out)
    first_out.set()
    assert alone_in.wait(10) and not next_in.is_set()
    alone_out.set()
    assert next_in.wait(10)
    next_out.set()


def report(nodeid: str, duration: float, start: float, stop: float):
    return types.SimpleNamespace(nodeid=nodeid, duration=duration, start=start, stop=stop)


def test_time_per_tier_sums_the_phases_and_spans_first_start_to_last_end():
    assert tier_of("tests/unit/test_physics.py::test_x") == "unit"
    assert tier_of("tests/native/test_native_hosts.py::test_y[a/b]") == "native"
    assert tier_of("tests/cli_run.py::test_z") == "other"
    clock = TierClock()
    for r in (report("tests/unit/test_a.py::t1", 0.5, 100.0, 100.5), report("tests/unit/test_a.py::t1", 2.0, 100.5, 102.5),
              report("tests/unit/test_b.py::t2", 1.0, 101.0, 102.0), report("tests/master/test_c.py::t3", 3.0, 90.0, 93.0)):
        clock.pytest_runtest_logreport(r)
    unit, master = clock.lines()  # in the tiers' order, not the reports'
    # tests, summed seconds, span
    assert (unit.split()[0], re.findall(r"[\d.]+", unit)) == ("unit", ["2", "3.5", "2.5"])
    assert (master.split()[0], re.findall(r"[\d.]+", master)) == ("master", ["1", "3.0", "3.0"])
