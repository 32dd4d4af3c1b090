"""The build's checks that come before any FMU is built."""
from __future__ import annotations

import pytest

from tribofmu.build import build_fmus


def test_build_refuses_an_unknown_fmi_version(tmp_path):
    with pytest.raises(ValueError, match="must be 2 or 3, got 4"):
        build_fmus(tmp_path, fmi=4)
    assert not list(tmp_path.iterdir())


def test_the_cache_key_holds_the_environment_not_the_interpreters_name(monkeypatch):
    """Issue 38: `tribofmu` (sys.executable .../bin/python3.11 from its shebang) and `python -m
    tribofmu` (.../bin/python) in one venv kept two caches of the same FMUs. The key holds
    what the native loader binds to: libpython and the environment (sys.prefix)."""
    import sys

    from tribofmu import build
    build.source_hash.cache_clear()
    before = build.default_fmu_dir()
    try:
        monkeypatch.setattr(sys, "executable", sys.executable + "-another-name")
        build.source_hash.cache_clear()
        assert build.default_fmu_dir() == before
        monkeypatch.setattr(sys, "prefix", sys.prefix + "-another-venv")
        build.source_hash.cache_clear()
        if build.native_loader_supported():
            assert build.default_fmu_dir() != before
    finally:
        monkeypatch.undo()
        build.source_hash.cache_clear()
    assert build.default_fmu_dir() == before
