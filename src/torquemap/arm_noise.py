"""The white-noise level of an arm's motor torques above the estimate's band.

The arm's counterpart of :mod:`torquemap.noise_level` (which the per-joint estimate uses): a
log polled slower than the identification's holds the same current noise per sample in a
narrower band, so its power spectral density in the estimate's band is higher by the ratio of
the rates. The identification's low-passed residual (``residual_sigma_lowpass``) then
understates the estimate's noise: on a simulated 6-axis arm identified at 1 kHz, its task log
read every 10th sample (100 Hz) had 2.3 to 3.3 times the 1 kHz force error and only 56-76 % of
the wrench errors within 2 sigma, with no warning (new-user QA, docs/arm.md).

:func:`arm_noise_levels` measures the level per joint on the motor torque net of the model's
friction and PDTV (the rigid-body and rotor-inertia torques of a smooth motion hold nothing
above :data:`torquemap.noise_level.HIGH_BAND_SPLIT`), on the samples where the joint slides.
Identification records it (``[identification.arm] noise_high_psd``); estimation measures it on
its log and adds what exceeds the model's, through its own filter's noise bandwidth, to the
sigmas (:func:`noise_excess_variance`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from torquemap.arm_model import ArmSignals
from torquemap.model import JointModel, pdtv_torque
from torquemap.noise_level import HIGH_BAND_SPLIT, high_band_psd
from torquemap.robot import Robot

#: A log's level must exceed the model's by this factor before the excess counts: the level of
#: one log is measured to a few per cent, and a log at the identification's rate must leave the
#: sigmas as they were.
EXCESS_FACTOR = 1.5


def arm_noise_levels(
    robot: Robot,
    joints: Mapping[str, JointModel],
    signals: ArmSignals,
    split: float = HIGH_BAND_SPLIT,
) -> NDArray[np.float64]:
    """Per joint, the one-sided PSD [N^2 m^2/Hz, motor side] above ``split`` (20 Hz) of the
    motor torque net of friction and PDTV, shape (nj,); NaN where it cannot be measured (a log
    slower than 4 ``split``, too few sliding samples).

    A sample counts where the joint's motor speed exceeds 4 widths of its friction law's
    transition (the step at a reversal is no noise).
    """
    out = np.full(len(robot.joints), math.nan)
    for k, joint in enumerate(robot.joints):
        jm = joints[joint.name]
        n = signals.gear[k]
        w = n * signals.qd[:, k]
        net = (
            signals.motor_torque[:, k]
            - jm.friction.torque(w)
            - pdtv_torque(n * signals.q_measured[:, k], jm.pdtv, velocity=signals.qd[:, k])
        )
        width = max(float(getattr(jm.friction, "zero_velocity", 0.0)), 1e-9)
        out[k] = high_band_psd(signals.t, net, np.abs(w) > 4.0 * width, split=split)
    return out


def pooled_levels(levels: Sequence[NDArray[np.float64]], weights: Sequence[float]) -> list[float]:
    """The levels of several logs pooled per joint (weighted mean of the finite ones), as a
    list for the model file; 0.0 where no log measured it (0 reads as "not measured")."""
    stack = np.array(levels, dtype=float)
    w = np.asarray(weights, dtype=float)[:, None] * np.isfinite(stack)
    total = w.sum(axis=0)
    mean = np.where(total > 0, np.nansum(stack * w, axis=0) / np.maximum(total, 1e-300), 0.0)
    return [float(v) for v in mean]


def noise_excess_variance(
    info: Mapping[str, Any] | None,
    robot: Robot,
    joints: Mapping[str, JointModel],
    signals: ArmSignals,
    bandwidth: float,
) -> tuple[NDArray[np.float64], str | None]:
    """Joint-side variance [N^2 m^2] to add to each joint's sigma for a log noisier than the
    identification's, shape (nj,), and a warning naming the joints (None when none).

    ``(level - own) N^2 bandwidth`` where the log's level exceeds :data:`EXCESS_FACTOR` times
    the model's ``noise_high_psd`` (``bandwidth``: the estimate's final filter's noise
    bandwidth [Hz]); 0 where the model records no level or the log's cannot be measured.
    """
    nj = len(robot.joints)
    raw = info.get("noise_high_psd") if isinstance(info, Mapping) else None
    if not isinstance(raw, list) or len(raw) != nj:
        return np.zeros(nj), None
    own = np.array([float(v) for v in raw])
    level = arm_noise_levels(robot, joints, signals)
    louder = np.isfinite(level) & (own > 0) & (level > EXCESS_FACTOR * own)
    excess = np.where(louder, level - own, 0.0)
    var = excess * signals.gear**2 * bandwidth
    if not louder.any():
        return var, None
    step = float(np.median(np.diff(signals.t)))
    named = ", ".join(
        f"{robot.joints[k].name} {level[k] / own[k]:.2g}x" for k in np.flatnonzero(louder)
    )
    return var, (
        f"the log's torque noise above 20 Hz exceeds the identification logs' ({named}; this "
        f"log is sampled at {1.0 / step:.4g} Hz: a log slower than theirs holds the same noise "
        "per sample in a narrower band; impacts, or a model at odds with the log, add to it); "
        "the sigmas include the excess"
    )
