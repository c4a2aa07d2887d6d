"""What the surface misses, carried between measured positions along its contours
(torquemap.linearize.contour).

Checked on closed forms built inside the test: a sharp knee that moves between measured
positions (torque ``0.1 (u - k(p))`` above it), modelled a few pulse widths early by a model
that is otherwise right, measured every 4th position and pulse width; and a residual that
follows the actuation alone under gains that change between measured positions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from torquemap.linearize.contour import carry_along_contours, check_contour

P, U = 32, 96
u = np.arange(U, dtype=np.float64)
p = np.arange(P)
ANCHORS = np.arange(0, P, 4)
LEVELS = np.arange(0, U, 4, dtype=np.float64)
SLOPE = 0.1


def _residual(model: NDArray[np.float64], data: NDArray[np.float64]) -> NDArray[np.float64]:
    """What the model misses, as the builder forms it: zero where both read zero, measured at
    the measured pulse widths only, linear between them."""
    res = np.where((model <= 0) & (data <= 0), 0.0, data - model)
    cols = LEVELS.astype(int)
    return np.stack([np.interp(u, LEVELS, r[cols]) for r in res])


def _fixed(res: NDArray[np.float64]) -> NDArray[np.float64]:
    """The residual interpolated between measured positions at a fixed pulse width."""
    out = res.copy()
    wrapped = np.concatenate([ANCHORS - P, ANCHORS, ANCHORS + P])
    for q in np.setdiff1d(p, ANCHORS):
        i = int(np.searchsorted(wrapped, q))
        a, b = int(wrapped[i - 1]), int(wrapped[i])
        w = (b - q) / (b - a)
        out[q] = w * res[a % P] + (1 - w) * res[b % P]
    return out


def _moving_knee() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    knee = 40 + 8 * np.sin(2 * np.pi * p / P) + 3 * np.sin(2 * np.pi * 3 * p / P)
    early = 3 + np.cos(2 * np.pi * p / P)
    data = np.maximum(SLOPE * (u[None, :] - knee[:, None]), 0.0)
    model = SLOPE * (u[None, :] - knee[:, None] + early[:, None])
    return model, data


def test_contours_carry_the_knee_between_measured_positions() -> None:
    model, data = _moving_knee()
    res = _residual(model, data)
    out = carry_along_contours(model, res, ANCHORS, limit=1.0)
    between = np.setdiff1d(p, ANCHORS)
    assert np.array_equal(out[ANCHORS], res[ANCHORS])
    zone = ((data < 1.0) & (model > 0))[between]
    along = (np.maximum(model + out, 0.0) - data)[between][zone]
    fixed = (np.maximum(model + _fixed(res), 0.0) - data)[between][zone]
    # exact but for the residual's linear interpolation between measured pulse widths across
    # each measured position's knee (one cell of up to 0.4 N m there): measured 0.011 N m rms
    # against 0.044 for the fixed pulse width
    assert np.sqrt(np.mean(along**2)) < 0.5 * np.sqrt(np.mean(fixed**2))
    assert np.sqrt(np.mean(along**2)) < 0.02

    # where the torque leaves zero (half a pulse width's torque): the fixed pulse width puts
    # it early (the earlier knee of the two measured positions), the contours do not
    def leaves(curve: NDArray[np.float64]) -> NDArray[np.int64]:
        return np.argmax(curve > 0.05, axis=1)

    truth = leaves(data[between])
    fixed_early = leaves(np.maximum(model + _fixed(res), 0.0)[between]) - truth
    along_early = leaves(np.maximum(model + out, 0.0)[between]) - truth
    assert fixed_early.mean() < -1.0  # measured -1.2 pulse widths
    assert abs(along_early.mean()) < 0.5  # measured -0.3


def test_the_check_prefers_the_contours_for_a_moving_knee() -> None:
    model, data = _moving_knee()
    check = check_contour(model, _residual(model, data), ANCHORS, LEVELS, limit=1.0)
    assert check.cells > 0
    assert check.rms_contour < check.rms_fixed
    assert check.preferred  # measured t = 2.7


def test_the_check_keeps_the_fixed_pulse_width_where_the_residual_follows_the_actuation() -> None:
    # the model misses a ripple in the actuation alone, the same at every position, while the
    # gains change between measured positions: the contours read it at other pulse widths
    gain = 1 + 0.5 * np.sin(2 * np.pi * p / P)
    model = gain[:, None] * SLOPE * (u[None, :] - 10)
    data = np.maximum(model + 0.05 * np.sin(u / 3)[None, :], 0.0)
    check = check_contour(model, _residual(model, data), ANCHORS, LEVELS, limit=1.0)
    assert check.rms_fixed < 1e-12  # the fixed pulse width is exact here
    assert not check.preferred  # measured t = -3.2


def test_the_check_needs_three_measured_positions() -> None:
    model, data = _moving_knee()
    check = check_contour(model, _residual(model, data), ANCHORS[:2], LEVELS, limit=1.0)
    assert check.cells == 0
    assert not check.preferred
