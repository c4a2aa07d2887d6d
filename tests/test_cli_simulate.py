"""``torquemap simulate scara``: files, determinism, and one-line errors with no output."""

from __future__ import annotations

from pathlib import Path

import pytest

from torquemap.cli.main import main
from torquemap.model import load_model
from torquemap.robot import load_robot

FILES = ["circle.csv", "robot.toml", "sweep.csv", "truth.csv", "truth.toml"]


def test_simulate_scara_writes_the_same_files_as_the_fixture(
    scara_bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "new" / "bench"  # created with its parent
    assert main(["simulate", "scara", "--out", str(out), "--seed", "0"]) == 0
    assert sorted(p.name for p in out.iterdir()) == FILES
    # Deterministic for a given seed: byte for byte what the library wrote for the fixture.
    for name in FILES:
        assert (out / name).read_bytes() == (scara_bench / name).read_bytes(), name
    assert "robot.toml" in capsys.readouterr().out


def test_bench_robot_and_truth_files_load(scara_bench: Path) -> None:
    robot = load_robot(scara_bench / "robot.toml")
    assert robot.joint_names == ("a", "b")
    assert robot.kinematics == "planar2r"
    assert [j.gear_ratio for j in robot.joints] == [100.0, 80.0]  # the paper's harmonic drives
    model = load_model(scara_bench / "truth.toml")
    assert model.joints["b"].pdtv[1].order == 2.0
    assert model.notes["bench"]["spring_force"] == 3.5


def _fails(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse errors
        status = int(exc.code or 0)
    assert status == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1, err
    assert "Traceback" not in err
    return err


def test_negative_seed_fails_without_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "bench"
    err = _fails(["simulate", "scara", "--out", str(out), "--seed", "-1"], capsys)
    assert "seed" in err
    assert not out.exists()


def test_out_is_a_file_fails(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "taken"
    target.write_text("x")
    err = _fails(["simulate", "scara", "--out", str(target)], capsys)
    assert "not a folder" in err and "taken" in err
    assert target.read_text() == "x"


def test_out_below_a_file_fails(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "taken"
    target.write_text("x")
    err = _fails(["simulate", "scara", "--out", str(target / "bench")], capsys)
    assert "cannot create" in err and "taken" in err


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate"],
        ["simulate", "scara"],
        ["simulate", "scara", "--out", "x", "--seed", "one"],
        ["simulate", "nosuchbench", "--out", "x"],
    ],
)
def test_usage_errors_are_one_line(
    argv: list[str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)
    _fails(argv, capsys)
    assert list(tmp_path.iterdir()) == []
