"""A new user's logs and robots (stop 33 probe): cases that gave a silent wrong answer, a
traceback or a confusing message. The robot and its sweeps are the two-link arm of
tests/test_vertical.py (small and fast)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from test_vertical import ROBOT, current_columns, sweeps

from torquemap.cli.main import main
from torquemap.io import read_log, write_table, write_toml
from torquemap.model import load_model

# one worker runs the module (pytest -n 2 --dist loadgroup), so its module fixture `files`
# is built once, not once per worker
pytestmark = pytest.mark.xdist_group("new_user")


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("new_user")
    write_toml(d / "robot.toml", ROBOT)
    log = sweeps(vertical=False)
    cols = current_columns(log)
    write_table(d / "log.csv", cols)
    write_table(d / "milliamps.csv", {**cols, "i_a": 1000.0 * cols["i_a"]})
    text = (d / "log.csv").read_text()
    (d / "comment.csv").write_text("# recorded on the test rig\n" + text)
    # a spreadsheet's export in a decimal-comma locale
    (d / "semicolons.csv").write_text(text.replace(",", ";").replace(".", ","))
    import pyarrow as pa
    import pyarrow.parquet as pq

    stamps = (np.round(cols["t"] * 1e9).astype(np.int64) + 1_700_000_000 * 10**9).astype(
        "datetime64[ns]"
    )
    pq.write_table(
        pa.table({**{k: pa.array(v) for k, v in cols.items()}, "t": pa.array(stamps)}),
        d / "stamps.parquet",
    )
    write_table(d / "coarse_t.csv", {**cols, "t": np.round(cols["t"], 2)})  # 500 Hz in 10 ms
    write_table(d / "rounded.csv", {**cols, "q_b": np.round(cols["q_b"], 4)})  # "%.4f"
    assert (
        main(["identify", str(d / "robot.toml"), str(d / "log.csv"), "-o", str(d / "model.toml")])
        == 0
    )
    return d


def test_identify_records_the_motor_torque_level(files: Path) -> None:
    notes = load_model(files / "model.toml").notes["joints"]
    log = read_log(files / "log.csv", load_model(files / "robot.toml").robot)
    for k, name in enumerate(("a", "b")):
        level = float(np.percentile(np.abs(log.motor_torque[:, k]), 99))
        assert notes[name]["motor_torque_p99"] == pytest.approx(level, rel=1e-3)


def test_a_current_in_milliamps_is_warned(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A current logged in mA made forces 1000 times too large with exit 0 and no word."""
    model = str(files / "model.toml")
    capsys.readouterr()
    assert main(["estimate", model, str(files / "log.csv"), "-o", str(tmp_path / "f.csv")]) == 0
    assert "times the identification logs'" not in capsys.readouterr().err
    assert (
        main(["estimate", model, str(files / "milliamps.csv"), "-o", str(tmp_path / "g.csv")]) == 0
    )
    err = capsys.readouterr().err
    said = re.search(
        r"joint a: the motor torque reaches \S+ N m \(99th percentile\), (\S+) times the "
        r"identification logs' \S+ N m: check the log's units \(current in A, not mA",
        err,
    )
    assert said, err
    assert 900 < float(said.group(1)) < 1100
    assert "joint b: the motor torque reaches" not in err  # b is in A


def test_help_shows_no_doubled_percent(capsys: pytest.CaptureFixture[str]) -> None:
    """argparse formats a description only when it holds '%(prog)': a '%%' printed as such."""
    with pytest.raises(SystemExit):
        main(["simulate", "arm", "--help"])
    out = capsys.readouterr().out
    assert "up to 15 % and" in out and "%%" not in out


def test_angles_written_with_few_decimals_are_named(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A CSV exported with 4 decimals in q was refused as 'a log from another robot?'."""
    capsys.readouterr()
    argv = ["estimate", str(files / "model.toml"), str(files / "rounded.csv")]
    assert main([*argv, "-o", str(tmp_path / "f.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and not (tmp_path / "f.csv").exists()
    assert err.startswith(
        f"torquemap: error: {files / 'rounded.csv'}: joint b: the log's q_b moves in steps of 1e-04 rad"
    )
    assert "it was written with 4 decimals; write the angles with all their digits" in err


@pytest.mark.parametrize(
    ("log", "says"),
    [
        ("comment.csv", "; the first line '# recorded on the test rig' is a comment: the first "
         "line must be the header"),
        ("semicolons.csv", "; the header 't;q_a;q_b;i_a;i_b' is separated by semicolons: "
         "separate columns with commas"),
        ("stamps.parquet", ": column 't' is not numeric (datetime64[ns] values): write it as "
         "seconds, a number"),
    ],
)  # fmt: skip
def test_a_log_as_a_spreadsheet_or_logger_writes_it_is_named(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], log: str, says: str
) -> None:
    capsys.readouterr()
    argv = ["estimate", str(files / "model.toml"), str(files / log)]
    assert main([*argv, "-o", str(tmp_path / "f.csv")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and not (tmp_path / "f.csv").exists()
    assert err.startswith(f"torquemap: error: {files / log}") and err.endswith(says), err


def test_time_written_with_too_few_digits_is_named(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """t rounded to 10 ms on a 500 Hz log: four samples in five repeat a stamp and were dropped
    as if polled twice; the warning now says they were new readings and why they are lost."""
    capsys.readouterr()
    argv = ["estimate", str(files / "model.toml"), str(files / "coarse_t.csv")]
    assert main([*argv, "-o", str(tmp_path / "f.csv")]) == 0
    err = capsys.readouterr().err
    assert re.search(
        r"samples repeat the previous time stamp \(first at t = \S+ s\): dropped; they hold new "
        r"readings: 't' was written with too few digits \(it advances in steps of 0\.01 s\), so "
        r"80% of the samples are lost; write t with all its digits",
        err,
    ), err
    capsys.readouterr()
    assert (
        main(
            [
                "estimate",
                str(files / "model.toml"),
                str(files / "log.csv"),
                "-o",
                str(tmp_path / "g.csv"),
            ]
        )
        == 0
    )
    assert "repeat the previous time stamp" not in capsys.readouterr().err
