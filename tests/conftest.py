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
with the other workers' tests, an ``alone`` test holds it exclusively (:func:`_alone`, :func:`suite_support.turn`).
The README walk, the longest test, is collected first; the summary ends with each tier's time
(:func:`pytest_terminal_summary`).
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest

from suite_support import TierClock, turn

# One run of a checked call at a time, in the test's own process (and in the commands it starts,
# which inherit this): the suite keeps both cores busy with tests already (-n auto), and many
# tests watch a run from inside its process (spies on the recorder, the coupling, the FMUs),
# which a forked run is not. The forked runs, the default of a user's call, are tested on their
# own: tests/master/test_forked_runs.py and tests/integration/test_forked_checks.py.
os.environ.setdefault("TRIBOFMU_CHECK_WORKERS", "1")


@pytest.fixture(scope="session")
def fmu_dir(tmp_path_factory) -> Path:
    """Every FMU (:func:`tribofmu.fmu.registry.fmu_names`) built from the working tree into a
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
def pytest_collection_modifyitems(config, items):
    """The README walk (``newcomer``, minutes long) first: under xdist the run ends no earlier
    than its longest test's start plus its length, so the longest starts at once."""
    items.sort(key=lambda item: item.get_closest_marker("newcomer") is None)


def pytest_configure(config):
    if not hasattr(config, "workerinput"):  # the controller (or the only process) reports
        config.pluginmanager.register(TierClock(), "tribofmu_tier_clock")


def pytest_terminal_summary(terminalreporter, config):
    clock = config.pluginmanager.get_plugin("tribofmu_tier_clock")
    if clock is not None and clock.tests:
        terminalreporter.write_sep("-", "time per tier")
        for line in clock.lines():
            terminalreporter.write_line(line)
