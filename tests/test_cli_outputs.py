"""CLI outputs: the suffix chooses the format, and a suffix no format has fails before any work."""

from __future__ import annotations

from pathlib import Path

import pytest

from torquemap.cli.main import main


@pytest.mark.parametrize(
    "argv,message",
    [
        (["identify", "r.toml", "s.csv", "-o", "m.json"], "unknown model format ('.json')"),
        (["spectrum", "m.toml", "s.csv", "--joint", "a", "-o", "s.jpg"], "figure format ('.jpg')"),
        (
            ["pdtv-map", "m.toml", "--joint", "a", "--bins", "8", "-o", "c"],
            "map format (no suffix)",
        ),
        (["estimate", "m.toml", "c.csv", "-o", "f.xlsx"], "unknown table format ('.xlsx')"),
        (["estimate", "m.toml", "c.csv", "-o", "f.csv", "--figure", "f.eps"], "figure format"),
        (["report", "m.toml", "s.csv", "-o", "r.pdf"], "unknown report format ('.pdf')"),
        (["import", "rosbag", "b.bag", "--robot", "r.toml", "-o", "l.json"], "table format"),
        (["linearize", "build", "m.toml", "d.csv", "-o", "t.bin"], "tables format ('.bin')"),
        (["linearize", "evaluate", "m.toml", "d.csv", "-o", "r.csv"], "report format ('.csv')"),
        (["linearize", "collect", "m.toml", "--sim", "vr", "-o", "d.parquet"], "data format"),
    ],
)
def test_unknown_suffix_is_one_line_and_nothing_is_read(
    argv: list[str],
    message: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)  # none of the input files exists: the suffix is checked first
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    # either message names the format: the suffix check of the command (message) or the
    # shared output check (torquemap.cli.outputs.check_outputs), whichever runs first
    assert (message in err and "the suffix chooses it, use ." in err) or (
        "does not match what is written" in err
    ), err
    assert list(tmp_path.iterdir()) == []
