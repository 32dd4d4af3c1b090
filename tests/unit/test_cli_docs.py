"""The CLI as documented: the synopsis of docs/cli.md is the parser's, every option is named
there, --help is plain text with an example; result.csv's column table is the writers'."""
import re

import numpy as np
import pytest

from tribofmu import api, cli, columns

from scenes import ROOT


CLI_PAGE = ROOT / "docs" / "cli.md"  # the CLI reference the README links to


def readme_cli_block() -> list[str]:
    text = CLI_PAGE.read_text()
    section = text.split("\n## Synopsis\n", 1)[1]
    block = re.search(r"```\n(.*?)```", section, re.S).group(1)
    return [line.split("  #")[0].rstrip() for line in block.strip().splitlines()]


def test_column_table_is_the_one_writers_use():
    sc = api.load("dry_load_oscillation")
    assert [c.name for c in columns.columns_for(sc)] == [c.name for c in columns.RESULT_CSV_COLUMNS if c.name not in ("T", "Q")]
    signals = {k: np.arange(3.0) + i for i, k in enumerate(("time", "X", "V", "x", "v", "F", "f", "stuck", "n"))}
    table = columns.rows(signals, sc)
    assert table.shape == (3, len(columns.columns_for(sc)))


def test_the_readme_synopsis_is_the_parser():
    lines = readme_cli_block()
    assert [line for line in lines if not line.startswith("tribofmu --version")] == cli.synopsis(), (
        "docs/cli.md 'Synopsis' block drifted from the parser; it should read:\n" + "\n".join(cli.synopsis()))


def test_every_option_help_lists_is_named_in_the_readme():
    readme = CLI_PAGE.read_text()
    parser = cli._parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name, p in sub.choices.items():
        assert f"tribofmu {name}" in readme, name
        for action in p._actions:
            flags = [f for f in action.option_strings if f not in ("-h", "--help")]
            if flags:  # one of its spellings (-q for -q/--quiet)
                assert any(re.search(rf"tribofmu {name} .*{re.escape(f)}(?![\w-])", readme) for f in flags), (name, flags)


@pytest.mark.parametrize("command", [None, "build", "simulate", "plot", "scenes", "export-ssp", "sweep",
                                     "accuracy", "figures"])
def test_help_is_plain_text_with_an_example(command, capsys):
    with pytest.raises(SystemExit):
        cli._parser().parse_args([command, "--help"] if command else ["--help"])
    text = capsys.readouterr().out
    assert "``" not in text and ":mod:" not in text and ":func:" not in text
    assert re.search(r"examples?:\n  tribofmu ", text), text
    if command in ("simulate", "sweep", "accuracy", "export-ssp"):
        assert re.search(r"SCENARIO\s+a shipped scene's name", text), text


def test_the_help_says_the_algorithms_the_tol_and_exit_3(capsys):
    from tribofmu.api import DEFAULT_TOL
    from tribofmu.coupling.algorithms import ALGORITHMS
    with pytest.raises(SystemExit):
        cli._parser().parse_args(["simulate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name in ALGORITHMS:
        assert re.search(rf"--algorithm NAME .*\b{re.escape(name)}\b", text), name
    assert "nRMS of v" in text and f"else {DEFAULT_TOL:g}" in text
    with pytest.raises(SystemExit):
        cli._parser().parse_args(["--help"])
    assert "exits 3" in " ".join(capsys.readouterr().out.split())


def test_an_unknown_option_shows_the_commands_usage(capsys):
    with pytest.raises(SystemExit) as stop:
        cli.main(["simulate", "fig2_dry", "--bogus"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: tribofmu simulate ") and "unrecognized arguments: --bogus" in err


def test_figures_recompute_is_sweeps_name_and_rerun_its_old_one():
    for flag in ("--recompute", "--rerun"):
        assert cli._parser().parse_args(["figures", flag]).recompute is True
    assert cli._parser().parse_args(["sweep", "x", "--grid", "a=1", "--recompute"]).recompute is True
