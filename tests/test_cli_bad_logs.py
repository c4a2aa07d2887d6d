"""Issue 12, bad input, from the CLI: a log of another robot, a log too slow for what is asked.

Every command that reads a log (identify, estimate, spectrum, report) answers one line that
says what is wrong and what to record instead, exit 2, no output; ``report`` describes what it
can and says so in the report. The robot and its logs are the two-link arm of
tests/test_vertical.py (small and fast).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_vertical import KT, ROBOT, sweeps, truth_model

from torquemap.cli.main import main
from torquemap.io import write_table, write_toml
from torquemap.model import model_to_dict


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("bad_logs")
    write_toml(d / "robot.toml", ROBOT)
    write_toml(d / "model.toml", model_to_dict(truth_model()))  # type: ignore[arg-type]
    log = sweeps(vertical=False)
    cols = {
        "t": log.t,
        "q_a": log.q[:, 0],
        "q_b": log.q[:, 1],
        "i_a": log.motor_torque[:, 0] / KT[0],
        "i_b": log.motor_torque[:, 1] / KT[1],
    }
    write_table(d / "other.csv", {k.replace("_a", "_x"): v for k, v in cols.items()})
    still = {k: (np.full_like(v, v[0]) if k.startswith("q_") else v) for k, v in cols.items()}
    write_table(d / "still.csv", {k: v[:3000] for k, v in still.items()})
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
