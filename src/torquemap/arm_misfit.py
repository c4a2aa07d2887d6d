"""Whether a joint's misfit is its log's torque noise rather than a robot file at odds.

Identification warns of a joint whose model explains less than
:data:`torquemap.identify_arm.FIT_SHARE` of its torque's variation, and names the robot file
(gravity, gear ratios, torque constants). On a UR3 bench with 10 times the current noise (0.2
A) two wrist joints read 89 and 83 %, all of it noise: the warning blamed the robot file and
estimate repeated it (new-user QA, docs/arm.md). A misfit that is noise looks like the noise:

* the log's torque noise is white: its level above 20 Hz
  (:func:`torquemap.arm_noise.arm_noise_levels`) and above an eighth of the sampling rate agree
  (within :data:`WHITE_LIMIT`; 0.94-1.00 on the UR3 benches, where a leg whose controller
  oscillates at 30-40 Hz reads 3400);
* the fit's residual holds no more than that noise seen through the differentiator's kernel
  (noise bandwidth ``1.2 / (2 window)``): its variance at most :data:`NOISE_LIMIT` times
  ``level * 1.2 / (2 window)`` (1.12-1.22 on the noisy UR3; 4-11 on the shoulder and elbow
  of a UR3 whose robot file has gravity pointing up).

Both hold: the warning names the noise and what to record instead, and the robot file is not
blamed. Either fails (a log too slow to tell, an oscillation, a misfit above the noise): the
warning stands as it was.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from torquemap.arm_model import ArmSignals
from torquemap.arm_noise import arm_noise_levels
from torquemap.model import JointModel
from torquemap.noise_level import HIGH_BAND_SPLIT
from torquemap.robot import Robot

#: The noise is white when its level above 20 Hz is at most this many times its level above
#: an eighth of the sampling rate.
WHITE_LIMIT = 2.0

#: The misfit is the noise when the residual's variance is at most this many times the
#: noise's through the differentiator's kernel.
NOISE_LIMIT = 1.5


def net_noise_levels(
    robot: Robot, joints: Mapping[str, JointModel], signals: ArmSignals, split: float
) -> NDArray[np.float64]:
    """Per joint, the one-sided PSD [N^2 m^2/Hz, motor side] above ``split`` [Hz] of the motor
    torque net of friction and PDTV, on the samples where the joint slides (as
    :func:`torquemap.arm_noise.arm_noise_levels`, at another split), shape (nj,); NaN where it
    cannot be measured."""
    return arm_noise_levels(robot, joints, signals, split)


def upper_split(signals: ArmSignals) -> float:
    """An eighth of the log's sampling rate [Hz] (above the 20 Hz split's band for logs from
    about 320 Hz)."""
    return 0.125 / float(np.median(np.diff(signals.t)))


def misfit_is_noise(residual_sigma: float, level: float, upper_level: float, window: float) -> bool:
    """True when the misfit is the log's white torque noise (see the module docstring).

    Parameters
    ----------
    residual_sigma
        The fit residual's RMS [N m, motor side].
    level
        The noise's PSD above 20 Hz [N^2 m^2/Hz, motor side].
    upper_level
        Its PSD above an eighth of the sampling rate.
    window
        The differentiator's window [s].
    """
    if not (math.isfinite(level) and math.isfinite(upper_level)) or level <= 0 or upper_level <= 0:
        return False
    if level > WHITE_LIMIT * upper_level:
        return False
    noise = level * 1.2 / (2.0 * window)
    return residual_sigma**2 <= NOISE_LIMIT * noise


def noise_misfit_message(name: str, share: float, residual_sigma: float) -> str:
    """The warning for a joint whose misfit is its log's noise."""
    return (
        f"joint {name}: the identified model explains {max(share, 0.0):.0%} of its torque's "
        f"variation, the rest the log's torque noise ({residual_sigma:.3g} N m RMS at the motor "
        "after the differentiator, white above 20 Hz), not the robot file: the motion moves too "
        "little torque against it; record larger or faster motions (torquemap excite) or a "
        "quieter current signal (the sigmas hold the noise)"
    )


def explained_share(text: str) -> float | None:
    """The share in an "explains only" warning of :func:`torquemap.identify_arm.scale_warnings`,
    or None for another warning."""
    marker = "the identified model explains only "
    at = text.find(marker)
    if at < 0:
        return None
    value = text[at + len(marker) :].split("%", 1)[0]
    try:
        return float(value) / 100.0
    except ValueError:
        return None


__all__ = [
    "HIGH_BAND_SPLIT",
    "NOISE_LIMIT",
    "WHITE_LIMIT",
    "explained_share",
    "misfit_is_noise",
    "net_noise_levels",
    "noise_misfit_message",
    "upper_split",
]
