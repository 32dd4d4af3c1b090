"""The test suite's own machinery, used by tests/conftest.py (and tested by
tests/unit/test_alone_lock.py): the turns that let a test marked ``alone`` run with no other
test beside it under pytest-xdist, and the time per tier the summary ends with."""
from __future__ import annotations

import contextlib
import fcntl
from pathlib import Path

TIERS = ("unit", "master", "integration", "external", "native")


# -- tests that run alone ------------------------------------------------------------------
@contextlib.contextmanager
def _flock(path: Path, operation: int):
    with open(path, "a") as fh:
        fcntl.flock(fh, operation)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


@contextlib.contextmanager
def turn(run_dir: Path, alone: bool):
    """A test's turn among the workers whose locks are in ``run_dir``: alone (no other test
    runs meanwhile) or shared (beside any test that is not alone). A readers-writer lock on
    two files: the turnstile, taken by both kinds, lets a waiting alone test in before the
    other worker's next test, which would otherwise keep the room busy."""
    turnstile, room = run_dir / "alone.turnstile", run_dir / "alone.room"
    if alone:
        with _flock(turnstile, fcntl.LOCK_EX), _flock(room, fcntl.LOCK_EX):
            yield
    else:
        with _flock(turnstile, fcntl.LOCK_EX):
            pass
        with _flock(room, fcntl.LOCK_SH):
            yield


# -- each tier's time ------------------------------------------------------------------------
def tier_of(nodeid: str) -> str:
    parts = nodeid.split("/")
    return parts[1] if len(parts) > 2 and parts[0] == "tests" and parts[1] in TIERS else "other"


class TierClock:
    """Per tier: the tests' summed time (set-up, call and tear-down, as --durations counts
    them) and its span, from the first test's start to the last one's end (tiers overlap
    under xdist: the spans add up to more than the run)."""

    def __init__(self):
        self.tests: dict[str, set[str]] = {}
        self.seconds: dict[str, float] = {}
        self.first: dict[str, float] = {}
        self.last: dict[str, float] = {}

    def pytest_runtest_logreport(self, report):
        tier = tier_of(report.nodeid)
        self.tests.setdefault(tier, set()).add(report.nodeid)
        self.seconds[tier] = self.seconds.get(tier, 0.0) + report.duration
        start, stop = getattr(report, "start", None), getattr(report, "stop", None)
        if start is not None and stop is not None:
            self.first[tier] = min(self.first.get(tier, start), start)
            self.last[tier] = max(self.last.get(tier, stop), stop)

    def lines(self) -> list[str]:
        out = []
        for tier in (*TIERS, "other"):
            if tier not in self.tests:
                continue
            span = self.last.get(tier, 0.0) - self.first.get(tier, 0.0)
            out.append(f"{tier:<12} {len(self.tests[tier]):5d} tests  {self.seconds[tier]:7.1f} s in tests"
                       f"  {span:7.1f} s from first start to last end")
        return out
