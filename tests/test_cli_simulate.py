"""``torquemap simulate scara``: files, determinism, and one-line errors with no output."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
from conftest import SIMULATE_SCARA, Ran

from torquemap.cli.main import main
from torquemap.model import load_model
from torquemap.robot import load_robot
from torquemap.sim.scara import Sweep, default_bench

FILES = ["circle.csv", "robot.toml", "sweep.csv", "truth.csv", "truth.toml"]
ORDER = ["robot.toml", "sweep.csv", "circle.csv", "truth.csv", "truth.toml"]  # as printed


def test_simulate_scara_writes_the_bench(scara_run: Ran, scara_bench: Path) -> None:
    # the session's bench is this command's output (docs/tutorial.md's command line)
    assert sorted(p.name for p in scara_bench.iterdir()) == FILES
    assert (
        scara_run.printed[SIMULATE_SCARA]
        == f"wrote {', '.join(sorted(FILES, key=ORDER.index))} to bench\n"
    )


def test_simulate_scara_is_the_library_and_a_function_of_the_seed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Byte for byte what the library writes, for a seed; another seed, other noise. On a bench
    # with one short sweep and a quarter of a circle (the default bench's sweeps take 14 s of
    # CPU, its circle a few more; the code is the same).
    from torquemap.sim import bench as sim_bench

    bench = default_bench()
    short = dataclasses.replace(
        bench,
        sweep=Sweep(speeds=(10.0,), revolutions=1.0, elbow_angles=(0.6,), fast_speeds=0),
        circle=dataclasses.replace(bench.circle, turns=0.25),
    )
    monkeypatch.setattr(sim_bench, "default_bench", lambda: short)
    out = tmp_path / "new" / "bench"  # created with its parent
    assert main(["simulate", "scara", "--out", str(out), "--seed", "3"]) == 0
    sim_bench.write_scara_bench(tmp_path / "lib", seed=3)
    sim_bench.write_scara_bench(tmp_path / "other", seed=4)
    assert sorted(p.name for p in out.iterdir()) == FILES
    for name in FILES:
        assert (out / name).read_bytes() == (tmp_path / "lib" / name).read_bytes(), name
    for name in ("sweep.csv", "circle.csv"):
        assert (out / name).read_bytes() != (tmp_path / "other" / name).read_bytes(), name


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
