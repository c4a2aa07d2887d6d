"""The public Python API: top-level names, callable modules, validation at construction."""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import torquemap
from torquemap.errors import InputError
from torquemap.model import JointModel, Model, PdtvLine
from torquemap.robot import Joint, robot_from_dict

ROBOT = {
    "robot": {"kinematics": "none"},
    "joints": {"m": {"gear_ratio": 2, "torque_constant": 0.5}},
}


def test_every_exported_name_resolves_and_has_a_docstring() -> None:
    for name in torquemap.__all__:
        obj = getattr(torquemap, name)
        assert (obj.__doc__ or "").strip(), name
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = torquemap.nope  # type: ignore[attr-defined]


@pytest.mark.parametrize("name", ["identify", "estimate", "pdtv_map"])
def test_callable_modules_stay_modules(name: str) -> None:
    module = importlib.import_module(f"torquemap.{name}")
    assert getattr(torquemap, name) is module and callable(module)
    # ``import torquemap.x as m`` gives the module, whichever was imported first
    code = f"import torquemap.{name} as m, torquemap, types; print(isinstance(m, types.ModuleType), torquemap.{name} is m)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True", "True"]


def test_estimate_module_keeps_its_classes() -> None:
    import torquemap.estimate as m

    assert torquemap.estimate.ForceEstimate is m.ForceEstimate
    assert torquemap.estimate.estimate_forces is m.estimate_forces


def test_import_is_light() -> None:
    # the top-level names load on first use: importing the package pulls no numpy
    code = "import sys, torquemap; print('numpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_calling_the_module_is_calling_the_function() -> None:
    # a pure 2 CPR ripple, rotated at constant speed: the callable module identifies it
    robot = robot_from_dict(ROBOT)
    t = np.arange(0.0, 8.0, 2e-3)
    theta = 3.0 * t  # motor angle [rad], ~3.8 motor revolutions
    # with the current noise every real log has (0.1 mN m): noise-free, the whole fit's line
    # search has a zero noise floor and numerical residue at 1e-8 N m passes its tests
    noise = np.random.default_rng(0).normal(0.0, 1e-4, t.size)
    tau = 0.02 + 0.004 * np.cos(2.0 * theta + 0.3) + noise
    log = torquemap.log_from_columns({"t": t, "q_m": theta / 2.0, "tau_m": tau}, robot)
    result = torquemap.identify(robot, log)
    lines = result.model.joints["m"].pdtv
    assert [ln.order for ln in lines] == [2.0]
    # 4000 samples of 0.1 mN m noise: the amplitude to ~3e-6 N m, far better than 1 %
    np.testing.assert_allclose(lines[0].amplitude, 0.004, rtol=1e-2)
    table = torquemap.pdtv_map(result.model, "m", bins=8)
    np.testing.assert_allclose(table.torque, 0.004 * np.cos(2 * table.motor_angle + 0.3), atol=1e-4)
    est = torquemap.estimate(result.model, log)
    # no load: the external torque is ~0 compared with the 0.02 N m friction
    assert np.max(np.abs(est.tau_ext[est.flag == 0])) < 0.002


def test_save_and_load_model_round_trip(tmp_path: Path) -> None:
    robot = robot_from_dict(ROBOT)
    model = Model(robot=robot, joints={"m": JointModel(pdtv=(PdtvLine(2.0, 0.01, 0.3),))})
    torquemap.save_model(tmp_path / "m.toml", model)
    back = torquemap.load_model(tmp_path / "m.toml")
    assert back.robot.joints[0].torque_constant == 0.5
    assert back.joints["m"].pdtv[0].amplitude == 0.01


def test_log_validates_at_construction() -> None:
    with pytest.raises(
        InputError, match=r"q must have shape \(n, n_joints\) = \(3, 1\), got \(3,\)"
    ):
        torquemap.Log(
            t=[0.0, 1, 2], q=[0.0, 1, 2], motor_torque=np.zeros((3, 1)), joint_names=("a",)
        )
    with pytest.raises(InputError, match="goes backwards"):
        torquemap.Log(
            t=[0.0, 2, 1], q=np.zeros((3, 1)), motor_torque=np.zeros((3, 1)), joint_names=("a",)
        )
    with pytest.raises(InputError, match="motor_torque holds NaN"):
        torquemap.Log(
            t=[0.0, 1], q=np.zeros((2, 1)), motor_torque=[[0.0], [np.nan]], joint_names=("a",)
        )
    log = torquemap.Log(t=[0, 1], q=[[0], [1]], motor_torque=[[0], [0]], joint_names=["a"])
    assert log.q.dtype == np.float64 and log.joint_names == ("a",) and log.path == "<memory>"


def test_log_from_columns_refuses_ragged_arrays() -> None:
    robot = robot_from_dict(ROBOT)
    with pytest.raises(InputError, match=r"column 'i_m' has shape \(2,\), 't' has \(3,\)"):
        torquemap.log_from_columns({"t": [0, 1, 2], "q_m": [0, 1, 2], "i_m": [0, 1]}, robot)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"gear_ratio": -1.0}, "gear_ratio must be positive"),
        ({"gear_ratio": float("nan")}, "gear_ratio must be positive"),
        ({"torque_constant": 0}, "torque_constant must be positive"),
        ({"encoder_counts_per_rev": 0}, "encoder_counts_per_rev must be an integer"),
        ({"position_unit": "deg"}, "position_unit must be one of"),
    ],
)
def test_joint_validates_at_construction(kwargs: dict[str, object], message: str) -> None:
    spec: dict[str, object] = {"name": "a", "gear_ratio": 10.0, "torque_constant": 0.1, **kwargs}
    with pytest.raises(InputError, match=message):
        Joint(**spec)  # type: ignore[arg-type]
