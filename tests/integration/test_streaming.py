"""result.csv is streamed as the run produces it, so that a long run's results need not fit in
memory: the rows written equal the whole run's samples, and only the shown window stays in
memory."""
from __future__ import annotations

import numpy as np

from cli_run import main
from scenes import FIG2


def test_streamed_rows_equal_the_whole_run_and_only_the_window_is_kept(fmu_dir, monkeypatch):
    from tribofmu import api
    from tribofmu.master.run import GridRecorder
    monkeypatch.setattr(GridRecorder, "CHUNK", 64)  # many stretches in a short run
    scenario = api.load(FIG2, {"time.periods": 2, "time.window": [1, 2]})
    whole = api.simulate(scenario, fmu_dir=fmu_dir, build=False)
    chunks = []
    sizes = []
    real_init = GridRecorder.__init__

    def spy(self, *args, **kwargs):
        real_init(self, *args, **kwargs)
        sizes.append(len(self.signals["v"]))
    GridRecorder.__init__ = spy
    try:
        part = api.simulate(scenario, fmu_dir=fmu_dir, build=False, keep_window=True,
                            sink=lambda start, signals: chunks.append((start, signals)))
    finally:
        GridRecorder.__init__ = real_init
    starts = [s for s, _ in chunks]
    assert starts[0] == 0 and len(chunks) > 1  # more than one stretch: really streamed
    streamed = {k: np.concatenate([c[k] for _, c in chunks]) for k in ("time", "x", "v", "F")}
    assert np.array_equal(streamed["time"], whole.time)
    for k in ("x", "v", "F"):
        assert np.array_equal(streamed[k], getattr(whole, k)), k
    m = whole.window_mask()
    # memory: the window alone, in each run of the checked sequence (its samples are spooled
    # to disk, and only the reported run's reach the sink)
    assert sizes == [m.sum()] * len(part.stats["check"]["runs"])
    assert np.array_equal(part.time, whole.time[m]) and np.array_equal(part.v, whole.v[m])
    assert part.stats["output_points"] == len(whole.time)


def test_cli_result_csv_has_every_row_of_the_run(tmp_path, fmu_dir, capsys):
    from tribofmu import api
    out = tmp_path / "run"
    assert main("simulate", FIG2, "--out", out, "--fmu-dir", fmu_dir, "-q", "--no-plots",
                "--set", "time.periods=2", "--set", "time.window=[1,2]", capsys=capsys).returncode == 0
    table = np.loadtxt(out / "result.csv", delimiter=",", skiprows=1)
    whole = api.simulate(FIG2, {"time.periods": 2, "time.window": [1, 2]}, fmu_dir=fmu_dir, build=False)
    assert (out / "result.csv").read_text().splitlines()[0] == "time,X,V,x,v,F,f,stuck,dv,a"
    assert table.shape == (len(whole.time), 10)
    assert np.array_equal(table[:, 0], whole.time) and np.array_equal(table[:, 4], whole.v)
