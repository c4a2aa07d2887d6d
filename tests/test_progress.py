"""Progress: one plain line per step when piped, a rich display on a terminal, none if quiet."""

from __future__ import annotations

import io
import re
import time
from pathlib import Path

import pytest
from test_rosbag import ROBOT, write_bag

from torquemap import progress as progress_module
from torquemap.cli.main import main
from torquemap.io import write_toml
from torquemap.progress import NULL, PlainProgress, RichProgress, reporter, steps


def test_plain_lines_one_per_step_not_per_item() -> None:
    out = io.StringIO()
    progress = PlainProgress(out, after=0)
    with progress.step("outer") as outer:
        outer.describe("ignored when piped")
        with progress.step("inner", total=1000) as inner:
            for _ in range(1000):
                inner.advance()
    assert progress.run("last", lambda: 42) == 42
    lines = out.getvalue().splitlines()
    assert len(lines) == 4, lines
    assert lines[0] == "torquemap: outer ..."
    assert re.fullmatch(r"torquemap: inner \.\.\. done \(\d+\.\d s\)", lines[1])
    assert re.fullmatch(r"torquemap: outer: done \(\d+\.\d s\)", lines[2])
    assert re.fullmatch(r"torquemap: last \.\.\. done \(\d+\.\d s\)", lines[3])


def test_a_failed_step_says_so() -> None:
    out = io.StringIO()
    with pytest.raises(ZeroDivisionError), PlainProgress(out, after=0).step("divide"):
        _ = 1 / 0
    assert re.fullmatch(r"torquemap: divide \.\.\. stopped \(\d+\.\d s\)\n", out.getvalue())


def test_only_steps_that_last_leave_a_line() -> None:
    out = io.StringIO()
    progress = PlainProgress(out, after=0.2)
    with progress.step("quick"):
        pass
    with progress.step("slow") as s:
        time.sleep(0.4)
        s.advance()
    assert re.fullmatch(r"torquemap: slow \.\.\. done \(\d+\.\d s\)\n", out.getvalue())


def test_reporter_picks_by_stream() -> None:
    class Tty(io.StringIO):
        def isatty(self) -> bool:
            return True

    assert reporter(quiet=True) is NULL and steps(None) is NULL
    assert isinstance(reporter(stream=io.StringIO()), PlainProgress)
    tty = Tty()
    rich = reporter(stream=tty, after=0)
    assert isinstance(rich, RichProgress)
    with rich.step("simulate", total=3) as s:
        s.advance()
        s.describe("joint a")
    shown = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", tty.getvalue())
    assert re.search(r"(^|[\r\n])done simulate \(\d+\.\d s\)\n", shown), shown


@pytest.fixture
def bag_args(tmp_path: Path) -> list[str]:
    robot = tmp_path / "robot.toml"
    write_toml(robot, ROBOT)
    bag = write_bag(tmp_path / "bag", "ros1")
    return ["rosbag", str(bag), "--robot", str(robot), "-o", str(tmp_path / "log.csv")]


def test_cli_piped_prints_plain_lines(
    bag_args: list[str], capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(progress_module, "SHOW_AFTER", 0.0)  # this import is quicker than 2 s
    assert main(["import", *bag_args]) == 0
    captured = capsys.readouterr()
    assert re.search(
        r"^torquemap: read /joint_states from the bag \.\.\. done \(\d+\.\d s\)$",
        captured.err,
        re.M,
    )
    assert "torquemap:" not in captured.out  # progress never mixes with the results


@pytest.mark.parametrize("where", ["global", "command"])
def test_quiet_prints_no_progress(
    where: str,
    bag_args: list[str],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(progress_module, "SHOW_AFTER", 0.0)
    argv = ["--quiet", "import", *bag_args] if where == "global" else ["import", *bag_args, "-q"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    assert captured.out.startswith("wrote ")
