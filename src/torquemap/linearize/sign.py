"""Signs and units that a rig of another kind writes: checked before any table is built.

The tables hold, per phase, a pulse width ``0 .. actuation_max`` (an integer count of the
amplifier) for a torque in the motor's positive direction (docs/linearize-collect.md, DATA.csv).
Three things a new rig gets wrong look like other faults, or like nothing, further on:

* **A force sensor mounted the other way round.** Every reading is negated: the torque falls
  from zero as the pulse width (or, through the tables, the command) rises. The builder found no
  torque above the noise and asked whether the motor was powered; ``linearize evaluate`` printed
  the APMD (Eq 1 is a ratio, blind to the sign), a negative position-independent torque and a
  200 % deviation from the nominal law, exit 0 (QA stop 36). :func:`check_torque_sign` refuses,
  naming the negation that repairs the file: the collection subtracted the bias from each
  reading, so negating both the ``torque`` and ``bias`` columns gives what a sensor mounted the
  right way would have written.
* **A sign-magnitude drive** (a negative pulse width drives the winding the other way). The
  tables have no negative actuation: a winding driven both ways is two phases of the motor file,
  one per direction (a two-phase bipolar stepper: four phases, ``A+ B+ A- B-``).
  :func:`pulse_width_hint` says so beside the out-of-range pulse width.
* **A current command in amperes** (fractional "pulse widths"). The tables' entries are integer
  counts: the command must be given in the drive's counts (milliamperes, for instance) with
  ``actuation_max`` in the same unit. :func:`pulse_width_hint` says so beside the fraction.

This module never imports the simulator.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from torquemap.errors import InputError
from torquemap.robust import robust_scale

#: Share of the positions whose torque must fall (lowest to highest level) to call it reversed.
FALLING_SHARE = 0.75
#: How many rows' noise the median fall must exceed.
NOISE_MULTIPLE = 5.0


def torque_sign_advice(
    position: ArrayLike, level: ArrayLike, torque: ArrayLike, *, what: str = "pulse width"
) -> str:
    """One line when the torque falls as the level rises (a sensor mounted the other way
    round), else "".

    Parameters
    ----------
    position
        Table position of each row, shape (n,).
    level
        Base pulse width (characterisation) or torque command (verification), shape (n,).
    torque
        The rows' torques [N m], shape (n,).
    what
        The level's name in the line (``"pulse width"`` or ``"command"``).

    Returns
    -------
    str
        The line, or "" when the torque rises (or holds no clear direction).

    Notes
    -----
    Per position, ``d`` is the mean torque at its highest level less the mean at its lowest.
    Reversed: at least :data:`FALLING_SHARE` of the positions have ``d < 0`` and the median
    ``d`` is below ``-NOISE_MULTIPLE`` times one row's noise (the robust spread of the rows at
    the lowest level about their position's mean; at least 0), so that a motor that never
    produced torque (``d`` noise about zero) is left to the checks that say so.

    Examples
    --------
    >>> pos = np.repeat(np.arange(8), 5)
    >>> pw = np.tile(np.arange(0, 250, 50), 8)
    >>> torque_sign_advice(pos, pw, 0.01 * pw)
    ''
    >>> torque_sign_advice(pos, pw, -0.01 * pw)[:52]
    'the torque falls as the pulse width rises (at 8 of 8'
    """
    pos = np.asarray(position, dtype=np.int64)
    lv = np.asarray(level, dtype=np.float64)
    tau = np.asarray(torque, dtype=np.float64)
    if pos.size == 0:
        return ""
    keys, index = np.unique(pos, return_inverse=True)
    k = keys.size
    top = np.full(k, -np.inf)
    low = np.full(k, np.inf)
    np.maximum.at(top, index, lv)
    np.minimum.at(low, index, lv)
    at_top = lv == top[index]
    at_low = lv == low[index]
    n_top = np.bincount(index, weights=at_top, minlength=k)
    n_low = np.bincount(index, weights=at_low, minlength=k)
    mean_top = np.bincount(index, weights=np.where(at_top, tau, 0.0), minlength=k) / n_top
    mean_low = np.bincount(index, weights=np.where(at_low, tau, 0.0), minlength=k) / n_low
    spans = top > low
    if not spans.any():
        return ""
    d = (mean_top - mean_low)[spans]
    residual = (tau - mean_low[index])[at_low]
    sigma = robust_scale(residual)
    falling = int((d < 0).sum())
    median = float(np.median(d))
    if falling < FALLING_SHARE * d.size or median >= -NOISE_MULTIPLE * sigma or median >= 0:
        return ""
    return (
        f"the torque falls as the {what} rises (at {falling} of {d.size} positions; median "
        f"{median:.3g} N m from the lowest {what} read to the highest): a force sensor mounted "
        "the other way round? The tables need the torque in the motor's positive direction: "
        "negate the torque and bias columns (or the sensor's scale) and run again"
    )


def check_torque_sign(
    position: ArrayLike,
    level: ArrayLike,
    torque: ArrayLike,
    *,
    what: str = "pulse width",
    path: str | None = None,
) -> None:
    """Refuse rows whose torque falls as the level rises (:func:`torque_sign_advice`).

    Raises
    ------
    InputError
        Naming ``path``, with the line of :func:`torque_sign_advice`.
    """
    advice = torque_sign_advice(position, level, torque, what=what)
    if advice:
        raise InputError(advice, path=path)


def pulse_width_hint(values: ArrayLike, actuation_max: int) -> str:
    """What a pulse-width column outside the tables' counts likely holds, or "".

    Parameters
    ----------
    values
        The ``pulse_width`` column as read, shape (n,).
    actuation_max
        The motor file's full-scale pulse width.

    Returns
    -------
    str
        ``": ..."`` to append to the refusal: a sign-magnitude drive for negative values, a
        current in amperes for fractions within the range; "" otherwise.

    Examples
    --------
    >>> pulse_width_hint([0, -4, 8], 255)[:40]
    ': negative pulse widths (a sign-magnitud'
    >>> pulse_width_hint([0.0, 0.25, 1.5], 2)[:40]
    ': fractional pulse widths (a current in '
    >>> pulse_width_hint([0, 4, 300], 255)
    ''
    """
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if (v < 0).any():
        return (
            ": negative pulse widths (a sign-magnitude drive?): a table entry is one phase's "
            "pulse width 0 .. actuation_max, so a winding driven both ways is two phases of "
            "the motor file, one per direction (a two-phase bipolar stepper: four phases, A+ "
            "B+ A- B-), and DATA.csv holds the positive direction alone"
        )
    inside = v[(v >= 0) & (v <= actuation_max)]
    if inside.size and (inside != np.round(inside)).any():
        return (
            f": fractional pulse widths (a current in amperes?): table entries are the "
            f"drive's integer counts 0 .. {actuation_max}; give the command in counts (e.g. "
            "milliamperes) and actuation_max in the same unit"
        )
    return ""
