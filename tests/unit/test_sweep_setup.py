"""A sweep's setup, before any point runs: the grid read like --set, the local cluster bound to
the loopback interface only."""
from __future__ import annotations

from pathlib import Path

import pytest

from scenes import FIG2


def test_parse_grid_reads_values_like_set():
    from tribofmu.studies.sweep.grid import grid_points, parse_grid
    g = parse_grid(["drive.omega=10, 20.5,1e2", "time.window=[1,2],[2, 3]", "friction.regime=dry,fluid"])
    assert g == {"drive.omega": [10, 20.5, 100.0], "time.window": [[1, 2], [2, 3]],
                 "friction.regime": ["dry", "fluid"]}
    points = grid_points({"a.b": [1, 2], "c.d": [3, 4, 5]})
    assert len(points) == 6 and points[0] == {"a.b": 1, "c.d": 3} and points[3] == {"a.b": 2, "c.d": 3}


def test_the_local_cluster_listens_on_the_loopback_only(monkeypatch):
    """Scheduler and dashboard of the sweep's LocalCluster bind 127.0.0.1 (not all interfaces)."""
    import distributed
    from tribofmu.scene.scenario import load_scenario
    from tribofmu.studies.sweep.runner import run_dask
    seen = {}

    class Stop(Exception):
        pass

    def fake_cluster(**kwargs):
        seen.update(kwargs)
        raise Stop
    monkeypatch.setattr(distributed, "LocalCluster", fake_cluster)
    with pytest.raises(Stop):
        run_dask([load_scenario(FIG2)], [0], Path("."), (None, None, None, 10, None), lambda i, o: None,
                 False, "x", None, 1, lambda m: None)
    assert seen["host"] == "127.0.0.1" and seen["dashboard_address"].startswith("127.0.0.1:")
