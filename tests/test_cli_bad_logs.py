"""Issue 12, bad input, from the CLI: a log of another robot, a log too slow for what is asked.

Every command that reads a log (identify, estimate, spectrum, report) answers one line that
says what is wrong and what to record instead, exit 2, no output; ``report`` describes what it
can and says so in the report. The robot and its logs are the two-link arm of
tests/test_vertical.py (small and fast).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from test_vertical import ROBOT, current_columns, sweeps, truth_model

from torquemap.cli.main import main
from torquemap.io import write_table, write_toml
from torquemap.model import model_to_dict


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("bad_logs")
    write_toml(d / "robot.toml", ROBOT)
    write_toml(d / "model.toml", model_to_dict(truth_model()))  # type: ignore[arg-type]
    log = sweeps(vertical=False)
    cols = current_columns(log)
    write_table(d / "log.csv", cols)
    write_table(d / "other.csv", {k.replace("_a", "_x"): v for k, v in cols.items()})
    still = {k: (np.full_like(v, v[0]) if k.startswith("q_") else v) for k, v in cols.items()}
    write_table(d / "still.csv", {k: v[:3000] for k, v in still.items()})
    write_table(d / "ms.csv", {**cols, "t": cols["t"] * 1000.0})  # time in milliseconds
    write_table(d / "degrees.csv", {**cols, "q_a": np.degrees(cols["q_a"])})
    write_table(d / "constant.csv", {**cols, "i_a": np.full_like(cols["i_a"], 0.2)})
    first_b = int(np.argmax(cols["q_b"] != cols["q_b"][0]))  # the sweeps move a, then b
    write_table(d / "only_a.csv", {k: v[: first_b - 1] for k, v in cols.items()})
    # the true model, with the notes a whole-log fit writes: its steady sweep speeds (motor
    # side; friction through zero, so that a joint at rest while the other sweeps is bridged)
    doc = model_to_dict(truth_model())  # type: ignore[arg-type]
    speeds = [20.0, -20.0, 60.0, -60.0]
    doc["identification"] = {
        "joints": {j: {"friction_fit": "whole", "speeds": speeds} for j in ("a", "b")}
    }
    write_toml(d / "model_speeds.toml", doc)
    return d


def _one_line(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err, err
    return err


COMMANDS = {
    "identify": lambda d, log, out: ["identify", str(d / "robot.toml"), log, "-o", out + ".toml"],
    "estimate": lambda d, log, out: ["estimate", str(d / "model.toml"), log, "-o", out + ".csv"],
    "spectrum": lambda d, log, out: [
        "spectrum", str(d / "model.toml"), log, "--joint", "a", "-o", out + ".png"
    ],
    "report": lambda d, log, out: ["report", str(d / "model.toml"), log, "-o", out + ".html"],
}  # fmt: skip


@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_log_of_another_robot_is_refused(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    out = str(tmp_path / "out")
    err = _one_line(COMMANDS[command](files, str(files / "other.csv"), out), capsys)
    assert "other.csv" in err and "another robot" in err and "(x)" in err and "(a, b)" in err
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    ("command", "says"),
    [
        ("identify", "record each joint alone at several steady speeds"),
        ("spectrum", "record each joint alone at several steady speeds"),
        ("estimate", "record every joint moving faster than that"),
    ],
)
def test_a_log_too_slow_says_what_to_record(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str, says: str
) -> None:
    out = str(tmp_path / "out")
    err = _one_line(COMMANDS[command](files, str(files / "still.csv"), out), capsys)
    assert "still.csv" in err and says in err
    assert not list(tmp_path.iterdir())


def test_report_says_it_in_the_report(files: Path, tmp_path: Path) -> None:
    out = tmp_path / "r.html"
    assert (
        main(["report", str(files / "model.toml"), str(files / "still.csv"), "-o", str(out)]) == 0
    )
    assert "record every joint moving faster than that" in out.read_text()


@pytest.mark.parametrize("command", ["identify", "estimate"])
def test_time_in_milliseconds_is_named(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    # before: "no stretch ... record without gaps longer than 0.125 s", nothing about units
    out = str(tmp_path / "out")
    err = _one_line(COMMANDS[command](files, str(files / "ms.csv"), out), capsys)
    assert "ms.csv" in err and "median time step is 2 s: 't' must be in seconds" in err
    assert not list(tmp_path.iterdir())


def test_a_cut_off_float64_cannot_hold(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: a traceback (numpy.linalg.LinAlgError: Singular matrix)
    argv = COMMANDS["estimate"](files, str(files / "constant.csv"), str(tmp_path / "f"))
    err = _one_line([*argv, "--cutoff", "1e-9"], capsys)
    assert "constant.csv" in err and "float64 cannot hold that filter" in err
    assert not list(tmp_path.iterdir())


def test_a_joint_that_never_moves_is_left_unidentified(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: exit 2 with "joint b: no sample to fit" (no file, nothing to do about it); now
    # as the pass method: the joint that moved is identified, the other left with a warning
    out = tmp_path / "m.toml"
    argv = COMMANDS["identify"](files, str(files / "only_a.csv"), str(tmp_path / "m"))
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "joint b never moves at a steady speed: left unidentified" in err
    assert "too few samples where it alone moves" in err and out.exists()
    # a model with joint b unidentified, on a log where b moves: said, not silently answered
    capsys.readouterr()
    argv = ["estimate", str(out), str(files / "log.csv"), "-o", str(tmp_path / "f.csv")]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "joint b was not identified" in err and "joint a was not identified" not in err


def test_a_constant_current_and_a_log_in_degrees_are_warned(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    model = str(files / "model_speeds.toml")
    for log, says in (
        ("constant.csv", r"joint {}: the current \(torque\) is 0\.02 N m at every sample while"),
        # a moves half the log, at 57 x its 20 and 60 rad/s: above 90 rad/s but on its ramps
        ("degrees.csv", r"joint {}: \d\d% of the samples run at motor speeds above 1\.5 times the "
         r"fastest steady sweep pass 60 rad/s"),
    ):  # fmt: skip
        capsys.readouterr()
        assert main(["estimate", model, str(files / log), "-o", str(tmp_path / "f.csv")]) == 0
        err = capsys.readouterr().err
        assert re.search(says.format("a"), err), err
        assert not re.search(says.format("b"), err), err  # b is sound


@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_log_whose_last_line_has_no_line_end_is_warned(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    text = (files / "log.csv").read_bytes()
    assert text.endswith(b"\n") and text[-2:-1].isdigit()
    cut = tmp_path / "cut.csv"
    cut.write_bytes(text[:-2])  # copied while being written: the last number lost a digit
    crlf = tmp_path / "crlf.csv"
    crlf.write_bytes(text.replace(b"\n", b"\r\n"))
    warning = (
        f"torquemap: warning: {cut}: the last line has no line end: if the file was copied "
        "while being written its last row may be cut; check it"
    )
    for log, says in ((cut, warning), (files / "log.csv", None), (crlf, None)):
        out = str(tmp_path / f"{command}_{log.stem}")
        capsys.readouterr()
        # before: exit 0 and nothing said about the cut row
        argv = COMMANDS[command](files, str(log), out)
        if command == "estimate":  # the sweeps move one joint at a time: friction through 0
            argv[1] = str(files / "model_speeds.toml")
        assert main(argv) == 0
        err = capsys.readouterr().err
        assert (warning in err.splitlines()) is (says is not None), err
        assert "no line end" not in err.replace(warning, ""), err
    parquet = tmp_path / "log.parquet"
    parquet.write_bytes(b"PAR1 not a line")  # a Parquet file never warns (it has no lines)
    from torquemap.io import cut_last_line_warning

    assert cut_last_line_warning(parquet) is None
    (tmp_path / "empty.csv").write_bytes(b"")
    assert cut_last_line_warning(tmp_path / "empty.csv") is None


def test_report_names_time_in_milliseconds(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: exit 0, passes described at a thousandth of their speed, nothing about units
    out = tmp_path / "r.html"
    assert main(["report", str(files / "model.toml"), str(files / "ms.csv"), "-o", str(out)]) == 0
    says = "its median time step is 2 s (0.5 Hz): if 't' is in ms or us, convert it to seconds"
    assert says in capsys.readouterr().err
    assert says.replace("'", "&#x27;") in out.read_text()


def test_quasi_static_identification_names_time_in_milliseconds(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: refused without a word about units
    # (these sweeps hold no hold: refused, the refusal now names the unit too)
    argv = COMMANDS["identify"](files, str(files / "ms.csv"), str(tmp_path / "m"))
    err = _one_line([*argv, "--quasi-static"], capsys)
    assert "ms.csv" in err and "its median time step is 2 s" in err
    assert "convert it to seconds" in err and not list(tmp_path.iterdir())


def test_cogging_verify_warns_of_a_log_whose_last_line_has_no_line_end(
    files: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: exit 0 and nothing said about the cut row (the other log-reading commands warned)
    cut = tmp_path / "cut.csv"
    cut.write_bytes((files / "log.csv").read_bytes()[:-2])
    model = str(files / "model.toml")
    assert main(["cogging", "verify", model, str(cut), "--joint", "a"]) == 0
    err = capsys.readouterr().err
    assert f"torquemap: warning: {cut}: the last line has no line end" in err
    assert main(["cogging", "verify", model, str(files / "log.csv"), "--joint", "a"]) == 0
    assert "no line end" not in capsys.readouterr().err
