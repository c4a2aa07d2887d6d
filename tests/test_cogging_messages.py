"""cogging verify on sweeps a real slow motor gives: what the refusal says."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.io import write_table
from torquemap.model import JointModel, Model, PdtvLine, save_model
from torquemap.robot import robot_from_dict


def test_a_sweep_with_large_speed_ripple_says_how_much_it_holds(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 1.5 revolutions at 1 rad/s whose speed swings +-60 % at 7 CPR (a slow sweep of a cogging
    # motor, like tests/data/odrive's): a third of it lies within 20 % of the median speed.
    # Before, the refusal said only "0.5 motor revolutions at a steady speed" for a log the
    # user recorded as 1.5 revolutions at a constant commanded speed
    rb = robot_from_dict(
        {"robot": {"kinematics": "none"}, "joints": {"m": {"gear_ratio": 1, "torque_constant": 1}}}
    )
    save_model(
        tmp_path / "m.toml",
        Model(robot=rb, joints={"m": JointModel(pdtv=(PdtvLine(7, 0.01, 0.0),))}),
    )
    t = np.arange(0.0, 3 * np.pi, 1e-3)
    theta = t + (0.6 / 7) * np.sin(7 * t)  # speed 1 + 0.6 cos(7 t)
    write_table(tmp_path / "s.csv", {"t": t, "q_m": theta, "i_m": 0.01 * np.cos(7 * theta)})
    assert main(["cogging", "verify", str(tmp_path / "m.toml"), str(tmp_path / "s.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "s.csv: joint m: the log holds" in err[0]
    steady = float(err[0].split("holds ")[1].split(" ")[0])
    assert steady < 1.0
    assert "(within 20 % of its pass's median speed; 1.5 revolutions in all)" in err[0]


def test_verify_subtracts_only_what_the_exported_table_applied() -> None:
    # a model with a 7 CPR line and a 2.25 CPR one (non-integer: pdtv-map leaves it out of the
    # table). A drive applying the table adds the 7 CPR line only; the position loop then
    # supplies the 2.25 CPR line, which is still there. Before: verify subtracted every model
    # line from the total current and called the 2.25 CPR line removed (0 left)
    from torquemap.cogging import verify_cogging
    from torquemap.io import Log

    rb = robot_from_dict(
        {"robot": {"kinematics": "none"}, "joints": {"m": {"gear_ratio": 1, "torque_constant": 1}}}
    )
    lines = (PdtvLine(7, 0.01, 0.3), PdtvLine(2.25, 0.02, 0.0))
    model = Model(robot=rb, joints={"m": JointModel(pdtv=lines)})
    t = np.arange(0.0, 16 * np.pi, 1e-3)
    theta = 2.0 * t  # 16 revolutions at 2 rad/s
    applied = 0.01 * np.cos(7 * theta + 0.3)  # the table: the integer line
    true = applied + 0.02 * np.cos(2.25 * theta)
    total = applied + (true - applied) + 0.03  # feed-forward plus what the loop supplied
    after = Log(t=t, q=theta[:, None], motor_torque=total[:, None], joint_names=("m",))
    result = verify_cogging(model, after)
    left = {ln.order: ln.torque_after for ln in result.lines}
    assert left[7.0] < 1e-4  # cancelled by the table
    assert abs(left[2.25] - 0.02) < 1e-3  # not in the table: all of it left
