"""The external torques' content above the estimate's cut-off, measured on the log.

An arm's estimate is the external torque seen through a low-pass (or the momentum observer's
lag); a force that changes faster than that (a contact made or broken, a tool chattering as
it slides) is smoothed, and the error against the true force is what the filter removed. The
identification's covariance and noise do not hold it: on a direct-drive UR3 bench (gear 1,
2^20-count encoders; new-user QA, docs/arm.md) only 78 / 76 % of the fy / fz errors lay
within 2 sigma, while against the true force low-passed at the cut-off 89-98 % of each joint's
did, and the part removed carried 0.046 N m RMS on the shoulder against sigmas of 0.0015.

The unfiltered estimate (the rigid-body torques less the drives', before the final filter)
holds that part: above the cut-off it follows the true torque's to a correlation of 0.96-1.00
on that bench, plus the noise the identification measured in the same band. So
:func:`fast_torque_variance` takes the local mean square of the unfiltered estimate less the
reported one and adds what exceeds the noise floor (the identification residual's power
between the cut-off and its full band, scaled up for a log noisier than the identification's)
to the joint's variance, where it is at least :data:`FAST_FACTOR` times the floor.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from torquemap.filters import lowpass

#: The local mean square must exceed the noise floor by this factor before its excess counts:
#: the local level of noise alone scatters about its mean, and a log whose force stays slower
#: than the cut-off must leave the sigmas as they were.
FAST_FACTOR = 2.0


#: The local mean square is the larger of the removed part's square through low-passes at
#: these shares of the estimate's cut-off: the slower one holds the tails of a step, the faster
#: one its peak (on a contact made and broken: 92 / 89 % of the errors within 2 sigma with the
#: slower alone, 99 / 98 % with both; on the UR3 direct drive fy / fz 0.89 / 0.84 and 0.90 /
#: 0.86).
LOCAL_RATIO = 0.5
SHARP_RATIO = 1.0


def band_noise_floor(
    info: Mapping[str, Any] | None,
    gear: NDArray[np.float64],
    cutoff: float,
    louder: NDArray[np.float64],
) -> NDArray[np.float64] | None:
    """Joint-side variance [N^2 m^2] of the noise above ``cutoff`` [Hz], shape (nj,): the
    identification residual's ``residual_sigma^2`` less its power below ``cutoff`` (log-log
    interpolation of ``residual_sigma_lowpass``), times ``louder`` where above 1 (the log's
    noise level over the identification's, :func:`torquemap.arm_noise.arm_noise_levels` over
    ``noise_high_psd``: a log read at a lower rate holds the same noise in a narrower band).
    NaN where ``louder`` is (not measured): the log's own median level is used there. None
    when the model lacks the residual's table."""
    if not isinstance(info, Mapping):
        return None
    full = info.get("residual_sigma")
    cut = info.get("residual_lowpass_hz")
    table = info.get("residual_sigma_lowpass")
    if not (isinstance(full, list) and isinstance(cut, list) and isinstance(table, list)):
        return None
    sigma = np.asarray(full, dtype=float)
    fc = np.asarray(cut, dtype=float)
    low = np.asarray(table, dtype=float)
    if sigma.shape != gear.shape or low.shape != (fc.size, sigma.size) or fc.size == 0:
        return None
    out = np.empty(sigma.size)
    for k in range(sigma.size):
        ok = np.isfinite(low[:, k]) & (low[:, k] > 0)
        if not ok.any():
            return None
        value = math.exp(float(np.interp(math.log(cutoff), np.log(fc[ok]), np.log(low[ok, k]))))
        out[k] = max(sigma[k] ** 2 - value**2, 0.0)
    result: NDArray[np.float64] = out * gear**2 * np.maximum(louder, 1.0)
    return result


def fast_torque_variance(
    t: NDArray[np.float64],
    unfiltered: NDArray[np.float64],
    reported: NDArray[np.float64],
    cutoff: float,
    floor: NDArray[np.float64] | None,
) -> NDArray[np.float64]:
    """Per sample and joint, the variance [N^2 m^2] of the external torque the estimate's
    filter removed, shape (n, nj).

    Parameters
    ----------
    t
        Time [s], shape (n,).
    unfiltered
        The external torque before the final filter [N m], shape (n, nj).
    reported
        The estimate's external torque [N m], shape (n, nj).
    cutoff
        The estimate's cut-off [Hz] (the local mean square: :data:`LOCAL_RATIO`,
        :data:`SHARP_RATIO`).
    floor
        The noise's variance in that band per joint [N^2 m^2] (:func:`band_noise_floor`; NaN
        where unknown), or None: the log's median local level stands in there.

    Returns
    -------
    ndarray
        ``local - floor`` where the local mean square exceeds :data:`FAST_FACTOR` times the
        floor, else 0. (Not the log's median alone: a hopping leg's force is faster than the
        cut-off at most of its samples, 0.15-0.32 N m against a noise floor of 0.013.)
    """
    removed = unfiltered - reported
    square = removed**2
    local = np.maximum(
        lowpass(t, square, cutoff=LOCAL_RATIO * cutoff),
        lowpass(t, square, cutoff=SHARP_RATIO * cutoff),
    )
    local = np.maximum(local, 0.0)
    level = np.median(local, axis=0)
    base = level if floor is None else np.where(np.isfinite(floor), floor, level)
    out: NDArray[np.float64] = np.where(local > FAST_FACTOR * base, local - base, 0.0)
    return out


def fast_torque_message(
    extra: NDArray[np.float64],
    variance: NDArray[np.float64],
    cutoff: float,
    joint_names: tuple[str, ...],
) -> str | None:
    """A warning naming the joints whose variance over the log the fast part ``extra``
    dominates (its mean exceeds the mean of the other terms ``variance``), else None: there
    the filter's removal, not the model, limits the forces. (A log whose force steps at a few
    contacts adds to the sigmas there and stays quiet: the UR3 bench's circle, 1-2 % of the
    joints' variance.)"""
    if extra.size == 0:
        return None
    ratio = extra.mean(axis=0) / np.maximum(variance.mean(axis=0), 1e-300)
    named = [joint_names[k] for k in np.flatnonzero(ratio > 1.0)]
    if not named:
        return None
    share = float(np.mean(np.any(extra > variance, axis=1)))
    return (
        f"the external torques change faster than the {cutoff:.3g} Hz cut-off follows (a "
        "contact made or broken, a tool chattering as it slides): on "
        f"{', '.join(named)} what the filter removed outweighs the model's uncertainty, and at "
        f"{share:.0%} of the samples the forces are smoothed; the sigmas include it (a higher "
        "--cutoff follows the force, with more noise)"
    )
