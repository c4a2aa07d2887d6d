"""Sigmas of estimation (torquemap.uncertainty) against closed forms."""

from __future__ import annotations

import math

import numpy as np
from numpy.testing import assert_allclose

from torquemap.friction_law import SpeedTableFriction
from torquemap.model import JointModel, Model
from torquemap.robot import robot_from_dict
from torquemap.uncertainty import joint_sigma

TABLE = SpeedTableFriction(
    speeds=(0.1, 1.0, 2.0, 10.0),
    positive=(0.06, 0.05, 0.04, 0.04),
    negative=(0.05, 0.05, 0.05, 0.05),
    viscous=0.001,
    viscous_negative=0.001,
    zero_velocity=0.01,
)


def _model(slowest: float) -> Model:
    rb = robot_from_dict(
        {
            "robot": {"name": "motor", "kinematics": "none"},
            "joints": {
                "m": {"gear_ratio": 1.0, "torque_constant": 0.1, "encoder_counts_per_rev": 8000}
            },
        }
    )
    # no parameter covariance, no residual noise: the sigma is the model-form terms alone
    notes = {
        "joints": {
            "m": {
                "speeds": [slowest, -slowest],
                "uncertainty": {
                    "parameters": ["inertia.constant"],
                    "covariance": [[0.0]],
                    "residual_psd": 0.0,
                },
            }
        }
    }
    return Model(robot=rb, joints={"m": JointModel(friction=TABLE)}, notes=notes)


def _sigma(model: Model, speed: float) -> float:
    t = np.arange(0.0, 4.0, 1e-3)
    v = np.full(t.size, speed)
    s = joint_sigma(
        model,
        "m",
        t=t,
        theta=speed * t,
        velocity=v,
        acceleration=np.zeros(t.size),
        modulation=np.zeros(t.size),
        cutoff=2.0,
    )
    return float(s[t.size // 2])


def test_below_the_slowest_pass_the_table_departure_is_uncertain() -> None:
    # at 0.5 rad/s, below the slowest steady pass (2 rad/s): the positive table's dry level
    # 0.06 - 0.01 log10(5) = 0.053010 (linear in log speed between 0.1 and 1 rad/s) departs
    # from its 0.04 N m at 2 rad/s by 0.013010 N m; the negative table is flat (no departure).
    # Steady motion: the low-pass of a constant is that constant (1e-6 relative)
    want = 0.06 - 0.01 * math.log10(5.0) - 0.04
    assert_allclose(_sigma(_model(2.0), 0.5), want, rtol=1e-6)
    assert _sigma(_model(2.0), -0.5) < 1e-9
    # above the slowest pass the steady data hold the table: no such term
    assert _sigma(_model(2.0), 3.0) < 1e-9
    # with the slowest pass at 0.5 rad/s the same table is not an extrapolation there
    assert _sigma(_model(0.5), 0.5) < 1e-9
