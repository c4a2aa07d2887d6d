"""The simulated leg bench: a vertical two-link leg on a fixed hip, stepping on a compliant ground.

A hip and a knee (axes along y, so the leg moves in the x-z plane and gravity, along -z, lies in
its plane of motion) carry a thigh and a shank of 0.3 m; the foot (``foot``, the end effector)
is the shank's tip. A 0.3 kg mass the URDF lacks (an ankle or a force sensor) sits 5 cm above
the foot. The hip is fixed (a leg on a test rig, or a stance-free robot's leg); in the task the
foot steps in a loop whose lower part presses 0-15 mm into a ground modelled as a spring-damper
(2000 N/m, 30 N s/m) with sliding friction (coefficient 0.3): contact in about a third of each
cycle, flight otherwise. MuJoCo simulates it like the arms of :mod:`torquemap.sim.arm`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline

from torquemap.sim.arm import TIMESTEP, ArmSpec

THIGH = 0.3  # [m]
SHANK = 0.3  # [m]
GROUND = -0.5  # [m], the ground's height below the hip

LEG_URDF = f"""<?xml version="1.0"?>
<!-- A vertical two-link leg (torquemap's simulated leg bench): hip and knee about y, so the leg
     moves in the x-z plane with gravity in that plane; q = 0 is the leg hanging straight down.
     Thigh and shank {THIGH} m and {SHANK} m; the foot is the shank's tip. -->
<robot name="leg">
  <link name="hip_mount"/>
  <link name="thigh">
    <inertial>
      <origin xyz="0 0 -0.14" rpy="0 0 0"/>
      <mass value="2.0"/>
      <inertia ixx="0.016" ixy="0" ixz="0" iyy="0.016" iyz="0" izz="0.002"/>
    </inertial>
  </link>
  <link name="shank">
    <inertial>
      <origin xyz="0 0 -0.12" rpy="0 0 0"/>
      <mass value="1.0"/>
      <inertia ixx="0.008" ixy="0" ixz="0" iyy="0.008" iyz="0" izz="0.001"/>
    </inertial>
  </link>
  <link name="foot"/>
  <joint name="hip" type="revolute">
    <parent link="hip_mount"/>
    <child link="thigh"/>
    <origin xyz="0 0 0" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-1.2" upper="1.2" effort="60" velocity="6.0"/>
  </joint>
  <joint name="knee" type="revolute">
    <parent link="thigh"/>
    <child link="shank"/>
    <origin xyz="0 0 -{THIGH}" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-2.4" upper="-0.1" effort="60" velocity="8.0"/>
  </joint>
  <joint name="foot_joint" type="fixed">
    <parent link="shank"/>
    <child link="foot"/>
    <origin xyz="0 0 -{SHANK}" rpy="0 0 0"/>
  </joint>
</robot>
"""


def foot_position(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Foot position ``(x, z)`` [m] relative to the hip at joint angles ``q`` (..., 2) [rad]."""
    h, k = q[..., 0], q[..., 1]
    x = -THIGH * np.sin(h) - SHANK * np.sin(h + k)
    z = -THIGH * np.cos(h) - SHANK * np.cos(h + k)
    return np.stack([x, z], axis=-1)


def leg_angles(x: NDArray[np.float64], z: NDArray[np.float64]) -> NDArray[np.float64]:
    """Joint angles (n, 2) [rad] putting the foot at ``(x, z)`` [m], knee bent backwards
    (negative knee angle)."""
    r2 = x**2 + z**2
    c = np.clip((r2 - THIGH**2 - SHANK**2) / (2.0 * THIGH * SHANK), -1.0, 1.0)
    k = -np.arccos(c)
    h = np.arctan2(-x, -z) - np.arctan2(SHANK * np.sin(k), THIGH + SHANK * np.cos(k))
    return np.stack([h, k], axis=-1)


def leg_task_reference(
    duration: float, seed: int
) -> tuple[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]], float]:
    """A stepping reference: the foot runs a loop whose lower part presses into the ground.

    Per seed: cycle period 1.0-1.6 s, stride half-length 4-8 cm, the loop's lowest point
    10-15 mm below the ground (a third of each cycle in contact), its top 35-45 mm above; the
    stride grows from zero over the first second. Returns (q, qd, qdd) at 1 kHz and the ground
    height [m].
    """
    rng = np.random.default_rng(seed + 3000)
    period = rng.uniform(1.0, 1.6)
    stride = rng.uniform(0.04, 0.08)
    depth = rng.uniform(0.010, 0.015)
    lift = 3.0 * depth  # contact while sin(phase) < -1/2: a third of the cycle
    t = np.arange(round(duration / TIMESTEP), dtype=np.float64) * TIMESTEP
    t_knots = np.arange(0.0, duration + 0.01 + 1e-9, 0.01)
    ramp = np.clip(t_knots / 1.0, 0.0, 1.0)
    ramp = ramp * ramp * (3.0 - 2.0 * ramp)
    phase = math.pi / 2.0 + 2.0 * math.pi * t_knots / period
    x = ramp * stride * np.cos(phase)
    z = GROUND + (lift - depth) / 2.0 + (lift + depth) / 2.0 * np.sin(phase)
    knots = leg_angles(x, z)
    s = CubicSpline(t_knots, knots, axis=0, bc_type="clamped")
    return (s(t), s(t, 1), s(t, 2)), GROUND


def ready_pose() -> tuple[float, float]:
    """The leg's pose at the start of the task (the loop's top, 30-45 mm above the ground)."""
    q = leg_angles(np.array([0.0]), np.array([GROUND + 0.03]))[0]
    return float(q[0]), float(q[1])


LEG = ArmSpec(
    name="leg",
    urdf="leg.urdf",
    joints=("hip", "knee"),
    end_effector="foot",
    gear=(40.0, 40.0),
    armature=(4e-5, 4e-5),
    ready=ready_pose(),
    tool_parent="shank",
    tool_mass=0.3,
    tool_offset=(0.0, 0.0, -0.25),
    surface_stiffness=2000.0,
    surface_damping=30.0,
    urdf_text=LEG_URDF,
)
