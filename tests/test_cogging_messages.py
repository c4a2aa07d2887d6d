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
