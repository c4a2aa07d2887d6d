"""The likely cause of an arm's refusal when its logs' angles are too coarse or read too small.

Two refusals of :func:`torquemap.identify_arm.identify_arm` named a cause that was not the one
(new-user QA, stop 38, Q46, on an SO-101 with gear 345):

* the angle from a servo's output encoder (4096 counts per output turn, written in rad) steps
  by 0.53 rad at the motor: the motor speeds, and the friction on them, are not resolved, and
  the fit was refused as "friction negative ... check the robot file's gravity"
  (:func:`coarse_angle_note` names the step);
* the same servo's raw counts read as motor counts (``position_unit = "counts"``) make every
  joint span a gear ratio's share of its motion, and the refusal "only jitters about a held
  pose" is then a robot file reading output counts as motor counts
  (:func:`output_counts_note`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from torquemap.io import Log
from torquemap.log_quirks import motor_angle_quantum
from torquemap.robot import Robot

#: A joint's angle is too coarse for its motor speed when one step of it at the motor, over
#: the differentiator window, exceeds this share of the joint's 90th-percentile motor speed
#: (an SO-101 from its output encoders: 0.02-0.04, refused; a UR3 at gear 1 with 16384-count
#: encoders: 0.02, refused; UR3 benches that identify: 1000-count encoders at gear 100 0.003-0.004,
#: 16384 counts and a gear-1 UR3 at 2^20 counts under 0.0005).
COARSE_SHARE = 0.01


def coarse_angle_note(
    robot: Robot,
    logs: Sequence[Log],
    speeds: Sequence[NDArray[np.float64]],
    window: float,
) -> str | None:
    """A clause naming the joints whose angles step too coarsely for their motor speeds
    (:data:`COARSE_SHARE`), or None. ``speeds[k]`` are joint ``k``'s motor speeds [rad/s]
    over the fitted samples, ``window`` the differentiator's [s]."""
    coarse: list[tuple[str, float, float, float]] = []
    for k, joint in enumerate(robot.joints):
        steps = [motor_angle_quantum(log.q[:, k], joint.gear_ratio) for log in logs]
        quantum = max(steps) if steps else 0.0
        fast = float(np.percentile(np.abs(speeds[k]), 90)) if speeds[k].size else 0.0
        if quantum > 0 and fast > 0 and quantum / window > COARSE_SHARE * fast:
            coarse.append(
                (joint.name, quantum, quantum / joint.gear_ratio, quantum / window / fast)
            )
    if not coarse:
        return None
    name, motor, joint_step, share = max(coarse, key=lambda c: c[3])
    names = ", ".join(c[0] for c in coarse)
    counts = 2 * math.pi / joint_step
    return (
        f"the logs' angles are too coarse for the motor speeds ({names}): {name}'s moves in "
        f"steps of {joint_step:.3g} rad (2 pi / {counts:.0f} of the joint), {motor:.3g} rad at "
        f"the motor, {share:.1%} of its motor speed within the {window:.3g} s differentiator "
        "window, so its motor speed and friction cannot be resolved; log the motor's encoder "
        '(counts per motor turn: position_unit = "counts" with its encoder_counts_per_rev) '
        "or a finer angle"
    )


def output_counts_note(robot: Robot, travels: Sequence[float], still: float) -> str | None:
    """A clause for logs in which every joint spans under ``still`` [rad] (``travels``, one
    per joint) while its angle is read from encoder counts of the motor: output counts read as
    motor counts (a servo's), or None."""
    geared = [j for j in robot.joints if j.position_unit == "counts" and j.gear_ratio > 1.0]
    if not geared or not all(t < still for t in travels):
        return None
    joint = max(geared, key=lambda j: j.gear_ratio)
    k = robot.joints.index(joint)
    return (
        f"every joint spans under {still:g} rad, so the arm was not still: the counts may be "
        f"of an encoder on the joint's output (a servo's), which the robot file reads as motor "
        f"counts, {joint.gear_ratio:g} times too small ({joint.name} would span "
        f"{travels[k] * joint.gear_ratio:.3g} rad); then write q_<j> in rad (position_unit = "
        '"rad", q = counts x 2 pi / counts per output turn)'
    )
