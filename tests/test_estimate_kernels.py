"""The compiled sigma terms against the numpy code they replace (bit for bit)."""

from __future__ import annotations

import numpy as np
import pytest

from torquemap.filters import lowpass
from torquemap.friction_law import SpeedTableFriction
from torquemap.uncertainty import (
    FORM_FRACTION,
    _residual_level,
    _table_levels,
    _table_sign_terms,
)


def _law() -> SpeedTableFriction:
    return SpeedTableFriction(
        speeds=(0.05, 0.3, 1.0, 4.0, 20.0),
        positive=(0.09, 0.07, 0.06, 0.065, 0.08),
        negative=(0.1, 0.075, 0.062, 0.06, 0.07),
        viscous=3e-4,
        viscous_negative=2e-4,
        zero_velocity=0.03,
    )


def _velocity(n: int = 20_000) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(4)
    t = np.arange(n) * 5e-4
    v = 30.0 * np.sin(2 * np.pi * 0.3 * t) + rng.normal(0.0, 0.5, n)
    # at rest, below the first knot, on knots, beyond the last, tiny
    v[:50] = 0.0
    v[50:60] = [0.05, -0.05, 0.3, 20.0, -20.0, 1e-13, -1e-13, 1e-300, 50.0, -50.0]
    return t, v


@pytest.mark.parametrize("slowest", [0.0, 2.5])
@pytest.mark.parametrize("measured", [None, "plain", "accel"])
def test_table_levels_equal_numpy_terms(slowest: float, measured: str | None) -> None:
    law = _law()
    t, v = _velocity()
    acc = np.gradient(v, t)
    width = 0.04
    table = None
    if measured is not None:
        table = {
            "speeds": [0.1, 1.0, 10.0, 40.0],
            "rms": [0.02, 0.01, 0.012, 0.03],
            "reference_cutoff": 1.0,
        }
        if measured == "accel":
            table["acceleration_sigma"] = 1e-5
    got = _table_levels(
        law, table, t=t, velocity=v, cutoff=2.0, width=width, slowest=slowest, acceleration=acc
    )
    assert got is not None
    level, spread, (up, down) = _table_sign_terms(law, v, width, slowest)
    if FORM_FRACTION > 0:
        level = np.hypot(level, FORM_FRACTION * 0.5 * (np.abs(up) + np.abs(down)))
    level = np.hypot(level, spread)
    np.testing.assert_array_equal(got[:, -1], level)
    if table is None:
        assert got.shape == (v.size, 1)
    else:
        misfit = _residual_level(table, t=t, velocity=v, cutoff=2.0, acceleration=acc)
        if measured == "plain":
            np.testing.assert_array_equal(got[:, 0], misfit)
        else:  # hypot as sqrt(a^2 + b^2): within an ulp of the C library's
            np.testing.assert_allclose(got[:, 0], misfit, rtol=2.3e-16, atol=0)
        if measured == "accel":  # the acceleration term is in it
            plain = np.interp(
                np.log(np.maximum(np.abs(v), 1e-12)), np.log(table["speeds"]), table["rms"]
            ) * np.sqrt(2.0)
            low = np.abs(lowpass(t, acc, cutoff=2.0)) * 1e-5
            np.testing.assert_allclose(got[:, 0], np.hypot(plain, low), rtol=1e-12)


def test_table_levels_leave_other_laws_to_numpy() -> None:
    from torquemap.friction_law import StribeckFriction

    t, v = _velocity(100)
    law = StribeckFriction(coulomb_positive=0.04, coulomb_negative=0.06)
    assert (
        _table_levels(
            law, None, t=t, velocity=v, cutoff=2.0, width=0.01, slowest=0.0, acceleration=None
        )
        is None
    )


def test_hypot_into_within_an_ulp_of_numpy() -> None:
    # second algorithm: numpy's hypot (the C library's); sqrt(a^2 + b^2) rounds twice, so
    # within 2 ulp; zeros, NaN, infinity and squares that would overflow or underflow exactly
    from torquemap._estimate_kernels import hypot_into

    rng = np.random.default_rng(3)
    a = rng.lognormal(0.0, 3.0, 5000) * rng.choice([-1.0, 1.0], 5000)
    b = rng.lognormal(0.0, 3.0, 5000)
    special = [0.0, -0.0, np.nan, np.inf, -np.inf, 1e200, 1e-200, 3.0]
    a = np.concatenate([a, np.repeat(special, len(special))])
    b = np.concatenate([b, np.tile(special, len(special))])
    out = np.empty_like(a)
    hypot_into(a, b, out)
    want = np.hypot(a, b)
    np.testing.assert_array_equal(np.isnan(out), np.isnan(want))
    np.testing.assert_array_equal(np.isinf(out), np.isinf(want))
    finite = np.isfinite(want)
    np.testing.assert_allclose(out[finite], want[finite], rtol=4.5e-16, atol=0.0)
    exact = (a == 0) | (b == 0) | ~np.isfinite(a) | ~np.isfinite(b)
    np.testing.assert_array_equal(out[exact], want[exact])
    hypot_into(a, b, a)  # in place
    np.testing.assert_array_equal(a, out)


def test_coupling_torques_equal_numpy_terms() -> None:
    # the numpy expressions the kernel replaces (uncertainty.coupling_level before it): the
    # same operations in the same order, and numpy's cos and sin are the C library's, so
    # bit for bit; NaN and infinite inputs give 0
    from torquemap._estimate_kernels import coupling_torques

    rng = np.random.default_rng(8)
    n = 5000
    q2 = rng.uniform(-4.0, 4.0, n)
    velocity = rng.normal(0.0, 30.0, (n, 2))
    acceleration = rng.normal(0.0, 500.0, (n, 2))
    velocity[:3, 0] = [np.nan, np.inf, 1e200]
    acceleration[3:5, 1] = [np.nan, -np.inf]
    gears = np.array([10.0, 6.0])
    a2, a3 = 3e-3, 1e-3
    with np.errstate(invalid="ignore", over="ignore"):  # the non-finite rows
        qd = velocity / gears
        qdd = acceleration / gears
        c, s = np.cos(q2), np.sin(q2)
        want = np.empty_like(qd)
        want[:, 0] = a2 * (c * qdd[:, 1] - s * (2.0 * qd[:, 0] * qd[:, 1] + qd[:, 1] ** 2))
        want[:, 0] += a3 * qdd[:, 1]
        want[:, 1] = a2 * (c * qdd[:, 0] + s * qd[:, 0] ** 2) + a3 * qdd[:, 0]
    want = np.where(np.isfinite(want), want, 0.0)
    got = np.empty((n, 2))
    coupling_torques(q2, velocity, acceleration, gears, a2, a3, got)
    assert np.count_nonzero(want[:5] == 0.0) >= 5  # the non-finite rows are in the case
    np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
