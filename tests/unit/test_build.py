"""The build's checks that come before any FMU is built."""
from __future__ import annotations

import pytest

from tribofmu.build import build_fmus


def test_build_refuses_an_unknown_fmi_version(tmp_path):
    with pytest.raises(ValueError, match="must be 2 or 3, got 4"):
        build_fmus(tmp_path, fmi=4)
    assert not list(tmp_path.iterdir())
