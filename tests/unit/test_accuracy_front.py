"""The accuracy study's verdict: a default is on the accuracy-time front only when no run of the
study, co-simulation or monolithic anchor, is at least 2x faster and more accurate."""
from tribofmu.studies.accuracy import LEGEND, dominating


def row(family, nrms, wall, ok=True, algorithm="adaptive"):
    return dict(family=family, algorithm=algorithm, nrms_v=nrms, wall_time_s=wall, ok=ok)


def test_an_anchor_that_is_faster_and_more_accurate_takes_the_default_off_the_front():
    default = row("coupling", 6e-5, 0.23)
    rows = [default, row("coupling", 4e-5, 0.25), row("monolithic", 2e-6, 0.03, algorithm="event-driven"),
            row("monolithic", 1e-3, 0.01, algorithm="LSODA")]
    better, beaten = dominating(rows, default)
    assert better == [] and [r["algorithm"] for r in beaten] == ["event-driven"]


def test_only_runs_twice_as_fast_more_accurate_and_ok_dominate():
    default = row("coupling", 1e-4, 1.0)
    rows = [default,
            row("coupling", 5e-5, 0.5),                  # 2x faster, more accurate: dominates
            row("coupling", 5e-5, 0.6),                  # not 2x faster
            row("coupling", 1e-4, 0.1),                  # not more accurate
            row("monolithic", 1e-6, 0.1, ok=False),      # failed
            row("monolithic", float("nan"), 0.1)]        # no error measured
    better, beaten = dominating(rows, default)
    assert [(r["nrms_v"], r["wall_time_s"]) for r in better] == [(5e-5, 0.5)] and beaten == []


def test_the_log_says_what_each_column_means():
    text = " ".join(LEGEND)
    for column in ("nRMS(v)", "max", "s =", "steps", "calls", "rhs evaluations", "segments", "reported/true"):
        assert column in text, column
    assert "reported over nRMS(v)" in text


def test_summary_json_says_what_every_csv_column_means():
    from tribofmu.studies.accuracy import COLUMN_MEANINGS, ACCURACY_CSV_COLUMNS
    assert set(ACCURACY_CSV_COLUMNS) <= set(COLUMN_MEANINGS)
