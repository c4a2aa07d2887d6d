"""A Coulomb level the logs never reach: the Stribeck term's extrapolation.

A friction law's Coulomb level is its friction at speeds where the Stribeck term has decayed.
When the fitted Stribeck velocity lies above the speeds a joint reaches in the logs, the
Coulomb and Stribeck columns are nearly collinear over the data, and the fit may split the
friction between them as a large negative Coulomb level and a Stribeck level of the opposite
sign, whose curve over the speeds reached is right. A direct
drive (a simulated UR3 at gear 1, wrist_3_joint: Coulomb -0.02 to -0.048 N m, Stribeck +0.02 to
+0.041 N m, the Stribeck term keeping 74-78 % of its level at the 99th-percentile motor
speed, 1.1-1.7 rad/s) and white current noise on a geared joint (the two-link test arm with 1 A:
elbow Coulomb -0.27 N m, Stribeck +0.30 N m at 166 rad/s) were refused as "friction negative in
both directions: check the robot file's gravity, gear ratios and torque constants" (new-user
QA, stop 38, Q46). Such a joint is refitted with no Stribeck term (the data cannot tell it from
the Coulomb level); a Coulomb band still negative then is kept at zero when within its own
uncertainty of zero, and refused otherwise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

#: The Stribeck term is unresolved when, at the 99th percentile of the joint's motor speeds in
#: the logs, it keeps more than this share of its level at rest: the data then hold too little
#: of the friction beyond it to fix the Coulomb level (the refused joints of a UR3 at gear 1:
#: 0.74-0.78; the refused two-link elbow under 1 A of noise: 0.61).
STRIBECK_UNRESOLVED = 0.5
#: A Coulomb band (the sum of the two levels) negative by at most this many of its standard
#: deviations is within its uncertainty of zero: kept at zero band, with a warning.
BAND_SIGMAS = 2.0
#: The names of a law's two Stribeck levels among its linear parameters.
STRIBECK_LEVELS = ("stribeck_positive", "stribeck_negative")


@dataclass(frozen=True, slots=True)
class StribeckRefit:
    """A joint's own parameters refitted with no Stribeck term.

    Attributes
    ----------
    parameters
        The joint's columns' parameters (armature, friction, PDTV), the Stribeck levels zero.
    band
        Sum of the two Coulomb levels [N m, motor side] of the refit.
    band_sigma
        Its standard deviation [N m] (least squares, the fit's weight per row).
    remaining
        The old law's Stribeck term at the 99th percentile motor speed, over its level at rest.
    speed
        That speed [rad/s, motor side].
    """

    parameters: NDArray[np.float64]
    band: float
    band_sigma: float
    remaining: float
    speed: float


def stribeck_remaining(law: Any, speeds: NDArray[np.float64]) -> tuple[float, float]:
    """``(share, w99)``: the share of its level at rest that the law's Stribeck term keeps at
    the 99th percentile ``w99`` [rad/s] of ``speeds`` (motor side); share 0 for a law with no
    Stribeck term."""
    w99 = float(np.percentile(np.abs(speeds), 99)) if speeds.size else 0.0
    velocity = getattr(law, "stribeck_velocity", None)
    if velocity is None or not velocity > 0:
        return 0.0, w99
    exponent = float(getattr(law, "stribeck_exponent", 1.0))
    return math.exp(-((w99 / float(velocity)) ** exponent)), w99


def refit_without_stribeck(
    law: Any,
    block: NDArray[np.float64],
    target: NDArray[np.float64],
    speeds: NDArray[np.float64],
    variance: float,
) -> StribeckRefit | None:
    """Joint parameters refitted to ``target`` (m,) [N m, motor side] on the columns ``block``
    (m, c: armature, then the law's linear parameters, then PDTV) with the Stribeck levels held
    at zero; None when the law has no Stribeck term, or its term is resolved by ``speeds`` [rad/s]
    (:data:`STRIBECK_UNRESOLVED`). ``variance`` [N^2 m^2] is one row's, for the band's sigma."""
    names: Sequence[str] = law.linear_parameter_names
    if "stribeck_positive" not in names or "coulomb_positive" not in names:
        return None
    remaining, w99 = stribeck_remaining(law, speeds)
    if remaining <= STRIBECK_UNRESOLVED:
        return None
    drop = [1 + names.index(s) for s in STRIBECK_LEVELS]
    keep = [c for c in range(block.shape[1]) if c not in drop]
    B = block[:, keep]
    z, *_ = np.linalg.lstsq(B, target, rcond=None)
    v = np.zeros(block.shape[1])
    v[keep] = z
    a = np.zeros(len(keep))
    a[keep.index(1 + names.index("coulomb_positive"))] = 1.0
    a[keep.index(1 + names.index("coulomb_negative"))] = 1.0
    gram = B.T @ B
    sigma = float(np.sqrt(max(float(a @ np.linalg.pinv(gram) @ a) * variance, 0.0)))
    return StribeckRefit(
        parameters=v, band=float(a @ z), band_sigma=sigma, remaining=remaining, speed=w99
    )
