"""New-user QA, round 36: each test is a problem found by running the CLI as a new user would."""

from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.io import read_table, write_toml
from torquemap.model import load_model
from torquemap.quasistatic import find_holds
from torquemap.vertical import GravityCheck


def test_vertical_message_without_friction_says_so_not_inf() -> None:
    """A model without Coulomb friction printed 'inf% of its Coulomb friction'."""
    message = GravityCheck("j1", 0.2, True, 0.0, 100).message()
    assert "inf" not in message and "no Coulomb friction" in message
    assert "50% of its Coulomb friction" in GravityCheck("j1", 0.2, True, 0.4, 100).message()


ODRIVE = """[robot]
kinematics = "none"

[joints.m]
gear_ratio = 1
torque_constant = 0.04
encoder_counts_per_rev = 8192
position_unit = "counts"
"""


def _holds(path: Path, jitter: float, rows: int = 20, dt: float = 0.01, move: int = 16) -> None:
    # ODrive-like calibration: 8192 / move positions held `rows` samples each, moved within a
    # sample; the encoder reads the hold's count plus rounded Gaussian jitter of `jitter` counts
    rng = np.random.default_rng(7)
    positions = 8192 // move
    count = np.repeat(np.arange(positions) * move, rows).astype(float)
    theta = 2 * np.pi * count / 8192
    tau = 0.02 * np.cos(7 * theta + 0.3) + 0.01 * np.cos(14 * theta - 1.0) + 0.012
    current = (tau + rng.normal(0.0, 2e-4, count.size)) / 0.04
    read = np.round(count + rng.normal(0.0, jitter, count.size)) if jitter else count
    t = np.arange(count.size) * dt
    table = np.c_[t, np.mod(read, 8192), current]
    np.savetxt(path, table, delimiter=",", header="t,q_m,i_m", comments="", fmt="%.9g")


def test_quasi_static_holds_with_encoder_jitter_are_all_found(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # an encoder jittering by about a count about each hold lost 140 of 512 holds to the
    # four-count tolerance (a spread of 5 counts in 5 samples); the jitter's scale now widens it
    (tmp_path / "robot.toml").write_text(ODRIVE)
    _holds(tmp_path / "holds.csv", jitter=1.0)
    d = np.loadtxt(tmp_path / "holds.csv", delimiter=",", skiprows=1)
    theta = np.unwrap(2 * np.pi * d[:, 1] / 8192)
    found = find_holds(d[:, 0], theta, d[:, 2] * 0.04, count=2 * np.pi / 8192)
    assert found.torque.size >= 510
    # each hold at its position (half a move, 8 counts, if two were joined)
    truth = np.arange(512) * 16.0
    off = np.mod(found.motor_angle * 8192 / (2 * np.pi) - truth[:, None] + 4096, 8192) - 4096
    assert float(np.abs(off).min(axis=0).max()) < 3.0  # the mean of 10 samples of 1 count
    out = tmp_path / "model.toml"
    argv = ["identify", str(tmp_path / "robot.toml"), str(tmp_path / "holds.csv")]
    assert main([*argv, "--quasi-static", "-o", str(out)]) == 0
    assert "m: 512 holds at 512 positions" in capsys.readouterr().out
    lines = {ln.order: ln.amplitude for ln in load_model(out).joints["m"].pdtv}
    np.testing.assert_allclose([lines[7.0], lines[14.0]], [0.02, 0.01], atol=1e-3)


def test_quasi_static_jitter_does_not_join_holds_closer_than_it(tmp_path: Path) -> None:
    # holds 3 counts apart with a count of jitter: six times the jitter would span two holds,
    # so the four-count tolerance is kept (never fewer holds than before)
    _holds(tmp_path / "close.csv", jitter=1.0, move=3, rows=30)
    d = np.loadtxt(tmp_path / "close.csv", delimiter=",", skiprows=1)[:9000]
    theta = np.unwrap(2 * np.pi * d[:, 1] / 8192)
    count = 2 * np.pi / 8192
    default = find_holds(d[:, 0], theta, d[:, 2], count=count)
    steps = np.abs(np.diff(theta))
    before = min(4 * float(steps[steps > 1e-12].min()), 4 * count)  # the default before
    narrow = find_holds(d[:, 0], theta, d[:, 2], tolerance=before)
    np.testing.assert_array_equal(default.motor_angle, narrow.motor_angle)
    wide = find_holds(d[:, 0], theta, d[:, 2], tolerance=6 * count)
    assert wide.torque.size < narrow.torque.size  # six counts would have joined holds


def test_quasi_static_holds_of_one_row_are_not_said_to_be_milliseconds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # one averaged row per hold, t in seconds: refused with only "if 't' is in ms or us"
    (tmp_path / "robot.toml").write_text(ODRIVE)
    _holds(tmp_path / "rows.csv", jitter=0.0, rows=1, dt=3.0)
    argv = ["identify", str(tmp_path / "robot.toml"), str(tmp_path / "rows.csv")]
    out = tmp_path / "model.toml"
    assert main(["--quiet", *argv, "--quasi-static", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "rows.csv" in err[0]
    assert "median time step is 3 s" in err[0] and "only one or two rows" in err[0]
    assert "the log may hold one row per hold" in err[0]
    assert not out.exists()


def test_rosbag_continuous_joint_wrapped_to_one_turn_is_unwrapped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # ROS publishes a continuous joint wrapped to (-pi, pi]: the log held 2 pi jumps that
    # estimate cut as glitches; the revolute joint b (never near pi) is left as it is
    import test_rosbag

    t0, q0, effort = test_rosbag.truth()
    spin = np.c_[3.0 * (t0 - t0[0]) + 2.5, q0[:, 1]]  # a turns 6 rad over 2 s, through pi

    def wrapped() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return t0, np.c_[np.angle(np.exp(1j * spin[:, 0])), spin[:, 1]], effort

    monkeypatch.setattr(test_rosbag, "truth", wrapped)
    robot = tmp_path / "robot.toml"
    write_toml(robot, test_rosbag.ROBOT)
    bag = test_rosbag.write_bag(tmp_path / "bag", "ros1")
    out = tmp_path / "log.csv"
    assert main(["import", "rosbag", str(bag), "--robot", str(robot), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "note: a: positions wrapped to one turn" in err and "b:" not in err
    cols = read_table(out)
    np.testing.assert_allclose(cols["q_a"], spin[:, 0], atol=1e-9)
    np.testing.assert_allclose(cols["q_b"], spin[:, 1])


@pytest.fixture(scope="module")
def rigs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    # two random rigs: 0 (3 phases, 512 positions) and 6 (3 phases, 192 positions)
    d = tmp_path_factory.mktemp("rigs")
    for seed in (0, 6):
        argv = ["--quiet", "simulate", "rig", "--random", str(seed), "--out", str(d / f"r{seed}")]
        assert main([*argv, "--readings", "1"]) == 0
    return d


def _build_error(motor: Path, data: Path, out: Path, capsys: pytest.CaptureFixture[str]) -> str:
    argv = ["--quiet", "linearize", "build", str(motor), str(data), "-o", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(data) in err[0] and not out.exists()
    return err[0]


@pytest.mark.xdist_group("qa36_rigs")  # rigs, built once
def test_linearize_build_on_another_motors_data_says_so(
    rigs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: "phase 3 was never energised in the data (no rows where it leads)" alone
    out = tmp_path / "t.npz"
    # simulate rig keeps the collection record beside data.csv (stop 37): it names the motor
    err = _build_error(rigs / "r0" / "motor.toml", rigs / "r6" / "data.csv", out, capsys)
    assert "was collected with another motor file" in err
    assert "positions per cycle 512 (the record: 192)" in err
    # data copied without their record: the data themselves say it
    bare = {rig: tmp_path / f"{rig}.csv" for rig in ("r0", "r6")}
    for rig, path in bare.items():
        path.write_bytes((rigs / rig / "data.csv").read_bytes())
    err = _build_error(rigs / "r0" / "motor.toml", bare["r6"], out, capsys)
    assert "phase 3 was never energised" in err
    assert "the data reach positions 0 .. 191 of the motor file's 512 (3 phases)" in err
    assert "data from another motor?" in err
    # the other way round: "position 192 ... is outside 0 .. 191" alone
    err = _build_error(rigs / "r6" / "motor.toml", bare["r0"], out, capsys)
    assert "outside 0 .. 191, the motor file's 192 positions per cycle" in err
    assert "(the data reach 508): data from another motor?" in err


@pytest.mark.xdist_group("qa36_rigs")  # rigs, built once
def test_linearize_evaluate_of_part_of_the_cycle_says_so(
    rigs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a collection cut after half the cycle: exit 0 and an APMD, nothing about coverage
    motor = rigs / "r0" / "motor.toml"
    argv = ["linearize", "evaluate", str(motor), str(rigs / "r0" / "data.csv")]
    assert main(argv) == 0
    assert "warning" not in capsys.readouterr().err  # the whole cycle: silent
    lines = (rigs / "r0" / "data.csv").read_text().splitlines()
    kept = [lines[0]] + [ln for ln in lines[1:] if int(ln.split(",")[0]) < 200]
    (tmp_path / "cut.csv").write_text("\n".join(kept) + "\n")
    assert main(["linearize", "evaluate", str(motor), str(tmp_path / "cut.csv")]) == 0
    err = capsys.readouterr().err
    assert f"warning: {tmp_path / 'cut.csv'}: the data cover only" in err
    assert "of the 512 positions" in err and "this APMD covers the positions read alone" in err


@pytest.mark.parametrize(("step", "warns"), [(64, True), (4, False)])
def test_linearize_build_names_a_pulse_step_too_coarse_for_the_knee(
    step: int, warns: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # rig 5 collected at every 64th pulse width: tables built with no word, verification APMD
    # 18.0 % (5.9 % at the paper's every 4th, which stays silent)
    rig = tmp_path / "rig"
    argv = ["--quiet", "simulate", "rig", "--random", "5", "--out", str(rig)]
    assert main([*argv, "--pulse-step", str(step), "--readings", "1"]) == 0
    data = rig / "data.csv"
    argv = ["linearize", "build", str(rig / "motor.toml"), str(data), "-o", str(tmp_path / "t.npz")]
    assert main(argv) == 0
    err = capsys.readouterr().err
    said = f"warning: {data}: the collection measured every 64th pulse width: near the knee"
    assert (said in err) is warns
    if warns:
        assert "collect every 8th pulse width or finer (--pulse-step 8)" in err
