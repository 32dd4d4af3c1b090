"""Fixtures shared by the test tiers.

- ``unit/``: physics, scene and study code on its own (no FMUs);
- ``master/``: the coupling algorithms against fake slaves (:mod:`fakes`);
- ``integration/``: the built FMUs through fmpy, the master, the CLI and Dask;
- ``external/``: the SSP export in third-party masters (fmpy's SSP master, libcosim, Ecos).

The FMUs are built once per session from the working tree (:func:`fmu_dir`); a test that
changes FMU files copies them first. Under pytest-xdist (``bash .ci/run`` runs ``-n auto``)
each worker process builds its own, into its own temporary folder.

A test marked ``alone`` (one that measures wall time, loads every core, signals a process
or runs under valgrind) runs with no other test beside it: every test holds a lock shared
with the other workers' tests, an ``alone`` test holds it exclusively (:func:`_alone`).
The summary ends with each tier's time (:func:`pytest_terminal_summary`).
"""
from __future__ import annotations

import contextlib
import fcntl
import os
from pathlib import Path

import pytest

TIERS = ("unit", "master", "integration", "external", "native")


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory) -> Path:
    """Every FMU (:func:`tribofmu.scene.wiring.fmu_names`) built from the working tree into a
    fresh temporary directory, once per session: a test uses these instead of building again,
    unless the build or the cache is what it tests."""
    from tribofmu.build import build_fmus

    out = tmp_path_factory.mktemp("fmus")
    build_fmus(out)
    return out


@pytest.fixture(scope="session")
def fmu3_dir(tmp_path_factory) -> Path:
    """The same FMUs built as FMI 3.0 co-simulation FMUs (``tribofmu build --fmi 3``)."""
    from tribofmu.build import build_fmus

    out = tmp_path_factory.mktemp("fmus3")
    build_fmus(out, fmi=3)
    return out


@pytest.fixture(scope="session")
def fmu_paths(fmu_dir) -> dict[str, Path]:
    """The built FMUs by name: ``{"Friction": .../Friction.fmu, ...}``."""
    return {path.stem: path for path in sorted(fmu_dir.glob("*.fmu"))}


@pytest.fixture
def env(tmp_path):
    """A subprocess environment with its own FMU cache and temp folder (for ``cli_run.tribofmu``)."""
    cache, tmp = tmp_path / "cache", tmp_path / "tmpdir"
    tmp.mkdir()
    return dict(os.environ, TRIBOFMU_CACHE=str(cache), TMPDIR=str(tmp), PYTHONDONTWRITEBYTECODE="1")


# -- tests that run alone --------------------------------------------------------------------
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


@pytest.fixture(autouse=True)
def _alone(request, tmp_path_factory):
    """Under pytest-xdist: an ``alone`` test waits until no other worker is in a test, and no
    other worker starts one until it is done; other tests run side by side. The locks are in
    the run's temporary folder, which holds every worker's own."""
    if not hasattr(request.config, "workerinput"):  # one process: every test is alone already
        yield
        return
    with turn(tmp_path_factory.getbasetemp().parent, bool(request.node.get_closest_marker("alone"))):
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


def pytest_configure(config):
    if not hasattr(config, "workerinput"):  # the controller (or the only process) reports
        config.pluginmanager.register(TierClock(), "tribofmu_tier_clock")


def pytest_terminal_summary(terminalreporter, config):
    clock = config.pluginmanager.get_plugin("tribofmu_tier_clock")
    if clock is not None and clock.tests:
        terminalreporter.write_sep("-", "time per tier")
        for line in clock.lines():
            terminalreporter.write_line(line)
