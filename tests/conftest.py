"""Fixtures shared by the test tiers.

- ``unit/``: physics, scene and study code on its own (no FMUs);
- ``master/``: the coupling algorithms against fake slaves (:mod:`fakes`);
- ``integration/``: the built FMUs through fmpy, the master, the CLI and Dask;
- ``external/``: the SSP export in third-party masters (fmpy's SSP master, libcosim, Ecos).

The FMUs are built once per session from the working tree (:func:`fmu_dir`); a test that
changes FMU files copies them first.
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest


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
