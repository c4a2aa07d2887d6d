"""Quasi-static identification from one pass of holds in one direction (ODrive's calibration)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.model import load_model

ROBOT = """[robot]
kinematics = "none"

[joints.m]
gear_ratio = 1
torque_constant = 0.5
encoder_counts_per_rev = 4096
position_unit = "counts"
"""


def _one_pass(path: Path, positions: int, step: int = 10) -> None:
    # each position held 0.3 s after a 0.05 s step, all approached from below, like
    # controller.start_anticogging_calibration(); PDTV 0.02 cos(4 theta + 0.5) + 0.01 cos(9
    # theta - 1) N m, friction offset 0.03 N m, current noise 1 mA
    rng = np.random.default_rng(3)
    dt, hold = 0.005, 60
    counts, torque = [], []
    for k in range(positions):
        c = k * 4096 / positions
        counts += list(c - 4096 / positions * (1 - np.arange(1, step + 1) / step)) + [c] * hold
        theta = 2 * np.pi * c / 4096
        tau = 0.02 * np.cos(4 * theta + 0.5) + 0.01 * np.cos(9 * theta - 1.0) + 0.03
        torque += [tau + 0.01] * step + list(tau + rng.normal(0.0, 5e-4, hold))
    t = np.arange(len(counts)) * dt
    table = np.c_[t, np.mod(np.round(counts), 4096), np.asarray(torque) / 0.5]
    np.savetxt(path, table, delimiter=",", header="t,q_m,i_m", comments="", fmt="%.9g")


def test_one_pass_of_holds_is_identified(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 64 holds at 64 positions resolve orders up to 31, but 31 orders take 62 of the 64
    # holds; before: refused "64 holds cannot fit 31 orders; ... lower the max order", for a
    # max order the user never gave
    (tmp_path / "robot.toml").write_text(ROBOT)
    _one_pass(tmp_path / "holds.csv", 64)
    out = tmp_path / "model.toml"
    argv = ["identify", str(tmp_path / "robot.toml"), str(tmp_path / "holds.csv")]
    assert main([*argv, "--quasi-static", "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "64 holds fit orders up to 14 CPR" in err
    lines = sorted(load_model(out).joints["m"].pdtv, key=lambda ln: ln.order)
    assert [ln.order for ln in lines] == [4.0, 9.0]
    np.testing.assert_allclose([ln.amplitude for ln in lines], [0.02, 0.01], atol=5e-4)
    np.testing.assert_allclose([ln.phase for ln in lines], [0.5, -1.0], atol=0.05)


def test_a_max_order_the_holds_cannot_fit_names_the_largest(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "robot.toml").write_text(ROBOT)
    _one_pass(tmp_path / "holds.csv", 64)
    argv = ["identify", str(tmp_path / "robot.toml"), str(tmp_path / "holds.csv")]
    out = tmp_path / "model.toml"
    assert main([*argv, "--quasi-static", "--max-order", "31", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "holds.csv: joint m: 64 holds cannot fit" in err[-1]
    assert err[-1].endswith(
        "64 holds cannot fit 31 orders; hold at more positions or give a max order of at most 30"
    )
    assert not out.exists()


def test_holds_given_to_the_sweep_identification_point_to_quasi_static(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: only "no joint moves at a steady speed ... record constant-speed sweeps", for a
    # calibration log that --quasi-static identifies (test above)
    (tmp_path / "robot.toml").write_text(ROBOT)
    _one_pass(tmp_path / "holds.csv", 64)
    out = tmp_path / "model.toml"
    argv = ["identify", str(tmp_path / "robot.toml"), str(tmp_path / "holds.csv"), "-o", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds.csv: no joint moves at a steady speed" in err[0]
    assert err[0].endswith(
        "; these logs hold the motor still at many positions (an anti-cogging calibration?): "
        "identify --quasi-static reads them"
    )
    assert not out.exists()


def test_holds_reached_within_one_sample_are_found(tmp_path: Path) -> None:
    # an encoder that reads one count throughout each hold and a move done between two
    # samples (a stiff position loop logged at 200 Hz): the smallest step was the move itself,
    # the default tolerance (four of them) spanned every move, the log read as one hold and
    # was refused "no joint holds still at 8 or more positions"; the robot file's count caps it
    (tmp_path / "robot.toml").write_text(ROBOT)
    _one_pass(tmp_path / "holds.csv", 64, step=1)
    out = tmp_path / "model.toml"
    argv = ["identify", str(tmp_path / "robot.toml"), str(tmp_path / "holds.csv")]
    assert main(["--quiet", *argv, "--quasi-static", "-o", str(out)]) == 0
    lines = sorted(load_model(out).joints["m"].pdtv, key=lambda ln: ln.order)
    assert [ln.order for ln in lines] == [4.0, 9.0]
    np.testing.assert_allclose([ln.amplitude for ln in lines], [0.02, 0.01], atol=5e-4)


def test_creeping_holds_of_the_stand_point_to_quasi_static(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the simulated stand's calibration (0.4 s holds, 0.05 s steps): the stiff hold loop creeps
    # through the stiction band, so the 0.05 s differentiator's velocity clears the moving
    # threshold 57 % of the time in short runs, as a joint that sticks and slips does;
    # segment_motion chains such bursts into a pass only if the joint never holds still for two
    # windows (here it does on 56-58 % of the log, on none of random SCARA 204's stick-slip pass)
    from torquemap.io import write_table, write_toml
    from torquemap.sim.actuator import log_columns, robot_document, simulate_holds

    write_toml(tmp_path / "robot.toml", robot_document())
    write_table(tmp_path / "holds.csv", log_columns(simulate_holds(rng=1)))
    out = tmp_path / "model.toml"
    argv = ["identify", str(tmp_path / "robot.toml"), str(tmp_path / "holds.csv"), "-o", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "holds.csv: no joint moves at a steady speed" in err[0]
    assert err[0].endswith("identify --quasi-static reads them")
    assert not out.exists()
