"""The hybrids of benchmarks/force_decomposition.py (issue 12) take exactly one component from
the donor model and keep every other part and note of the base."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

import numpy as np

from torquemap.friction_law import StribeckFriction
from torquemap.model import InertiaModel, JointModel, Model, PdtvLine
from torquemap.robot import robot_from_dict


def _benchmark() -> Any:
    path = Path(__file__).resolve().parents[1] / "benchmarks" / "force_decomposition.py"
    spec = importlib.util.spec_from_file_location("benchmark_force_decomposition", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _model(scale: float, notes: dict[str, Any]) -> Model:
    robot = robot_from_dict(
        {
            "robot": {"kinematics": "none"},
            "joints": {
                "a": {"gear_ratio": 10.0, "torque_constant": 0.5},
                "b": {"gear_ratio": 20.0, "torque_constant": 0.3},
            },
        }
    )
    joints = {
        name: JointModel(
            inertia=InertiaModel(constant=scale * (k + 1) * 1e-4),
            friction=StribeckFriction(coulomb_positive=scale * 0.01, coulomb_negative=0.02),
            pdtv=(PdtvLine(order=2.0 + k, amplitude=scale * 1e-3, phase=0.1),),
        )
        for k, name in enumerate(("a", "b"))
    }
    return Model(robot=robot, joints=joints, notes=notes)


def test_swap_takes_one_component_and_keeps_the_rest() -> None:
    swap = _benchmark().swap
    base = _model(
        1.0,
        {
            "friction_fit": "whole",
            "joints": {
                "a": {"channel_delay": 0.01, "friction_observed_speed": 0.4, "passes": 3},
                "b": {"channel_delay": 0.02, "friction_observed_speed": 0.5},
            },
        },
    )
    donor = _model(2.0, {"joints": {"a": {"channel_delay": 0.03}, "b": {"channel_delay": 0.04}}})
    for part in ("friction", "pdtv", "inertia"):
        hybrid = swap(base, donor, part)
        for name in ("a", "b"):
            for other in ("friction", "pdtv", "inertia"):
                source = donor if other == part else base
                got = getattr(hybrid.joints[name], other)
                assert got == getattr(source.joints[name], other), (part, name, other)
        assert hybrid.notes == base.notes
    delayed = swap(base, donor, "delay")
    assert [delayed.notes["joints"][n]["channel_delay"] for n in ("a", "b")] == [0.03, 0.04]
    assert delayed.notes["joints"]["a"]["friction_observed_speed"] == 0.4
    assert delayed.notes["joints"]["a"]["passes"] == 3
    assert delayed.joints == base.joints
    # the donor has no bridge: the hybrid has none either, and keeps its own delay
    unbridged = swap(base, donor, "bridge")
    assert all("friction_observed_speed" not in e for e in unbridged.notes["joints"].values())
    assert unbridged.notes["joints"]["b"]["channel_delay"] == 0.02
    both = swap(base, donor, "friction+bridge")
    assert both.joints["a"].friction == donor.joints["a"].friction
    assert "friction_observed_speed" not in both.notes["joints"]["a"]
    # swapping back restores the base
    again = swap(swap(base, donor, "inertia"), base, "inertia")
    assert np.isclose(again.joints["b"].inertia.constant, base.joints["b"].inertia.constant)
    # the base itself is untouched
    assert base.notes["joints"]["a"]["friction_observed_speed"] == 0.4
