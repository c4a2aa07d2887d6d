"""The parameters' share of the sigma where estimation bridges the model torque.

Over a whole fit's reversal band estimation replaces the model torque by the line between its
ends (:func:`torquemap.estimate.bridge_gaps`) and then low-passes it, so the parameters' error
reaches the answer as ``L B G delta``. :func:`torquemap.uncertainty.bridged_parameter_variance`
bridges the regressor's columns (:func:`torquemap.uncertainty.bridge_columns`); here it is set
against a second algorithm: the estimator's own one-column bridge applied to the torque of each
column of a factor of ``C``, then the low-pass and the sum of squares.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from torquemap.estimate import bridge_gaps
from torquemap.filters import lowpass
from torquemap.friction_law import SpeedTableFriction
from torquemap.uncertainty import (
    bridge_columns,
    bridged_parameter_variance,
    parameter_variance_direct,
    regressor_columns,
)


def _signals(n: int, rng: np.random.Generator, h: float = 1e-3) -> dict[str, np.ndarray]:
    t = h * np.arange(n)
    # reversals every 1.25 s through rest, and fast stretches between them
    velocity = 20.0 * np.sin(2 * np.pi * 0.4 * t) + 0.01 * rng.standard_normal(n)
    theta = np.cumsum(velocity) * h
    return {
        "t": t,
        "theta": theta,
        "velocity": velocity,
        "acceleration": np.gradient(velocity, h) + rng.standard_normal(n),
        "modulation": np.cos(0.3 * theta),
    }


def _law() -> SpeedTableFriction:
    return SpeedTableFriction(
        speeds=(0.05, 0.2, 0.8, 2.0, 5.0, 12.0, 25.0),
        positive=(0.08, 0.07, 0.06, 0.05, 0.05, 0.05, 0.05),
        negative=(0.09, 0.08, 0.06, 0.06, 0.05, 0.05, 0.05),
        viscous=1e-4,
        viscous_negative=2e-4,
        zero_velocity=0.02,
    )


def _names(law: SpeedTableFriction) -> list[str]:
    return [
        "inertia.constant",
        "pdtv.1.both.a",
        "pdtv.1.both.b",
        "pdtv.3.positive.a",
        "pdtv.3.positive.b",
        *(f"friction.{k}" for k in law.linear_parameter_names),
    ]


@pytest.mark.parametrize("support", [0.0, 0.05])
def test_bridge_columns_is_the_estimators_bridge_per_column(support: float) -> None:
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 4000))
    gaps = np.zeros(t.size, dtype=bool)
    for a in (0, 500, 1700, 3900):  # runs at both ends of the log and inside it
        gaps[a : a + 100] = True
    values = rng.standard_normal((t.size, 5))
    out = bridge_columns(t, values, gaps, support=support)
    for j in range(values.shape[1]):
        one = bridge_gaps(t, values[:, j], gaps, longest=math.inf, support=support, ends=True)
        np.testing.assert_allclose(out[:, j], one, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("seed", [0, 1])
def test_bridged_variance_is_the_bridged_torques_variance(seed: int) -> None:
    rng = np.random.default_rng(seed)
    law = _law()
    names = _names(law)
    p = len(names)
    w = rng.standard_normal((p, p)) * np.geomspace(1e-2, 1e-5, p)
    cov = w @ w.T
    x = _signals(12_000, rng)
    bridged = np.abs(x["velocity"]) < 1.0
    got = bridged_parameter_variance(
        names, cov, law=law, cutoff=2.0, bridged=bridged, support=0.01, **x
    )
    # second algorithm: each column of the factor W (C = W W^T) is a torque G w_k, bridged by
    # the estimator's own function, then low-passed; the variance is the sum of their squares
    g = regressor_columns(names, law=law, **{k: v for k, v in x.items() if k != "t"})
    torques = [
        bridge_gaps(x["t"], g @ w[:, k], bridged, longest=math.inf, support=0.01, ends=True)
        for k in range(p)
    ]
    want = np.sum(lowpass(x["t"], np.column_stack(torques), cutoff=2.0) ** 2, axis=1)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12 * float(want.max()))
    # and not the unbridged regressor's (the low-pass carries the bridged samples' knots)
    plain = parameter_variance_direct(names, cov, law=law, cutoff=2.0, **x)
    assert not np.allclose(got, plain, rtol=1e-3)


def test_knots_only_bridged_samples_reach_add_nothing() -> None:
    # the two lowest knots' hats end at 0.2 rad/s; every sample slower than 0.5 rad/s is
    # bridged: however wide their variance (a prior's), the answer's variance does not see it
    rng = np.random.default_rng(5)
    law = _law()
    names = _names(law)
    p = len(names)
    w = rng.standard_normal((p, p)) * 1e-3
    cov = w @ w.T
    wide = cov.copy()
    for key in ("positive_0", "negative_0"):
        i = names.index(f"friction.{key}")
        wide[i, i] += 1.0  # 1 N m sd: 20 times the friction level
    x = _signals(10_000, rng)
    bridged = np.abs(x["velocity"]) < 0.5
    kw = {"law": law, "cutoff": 2.0, "bridged": bridged, **x}
    np.testing.assert_allclose(
        bridged_parameter_variance(names, wide, **kw),
        bridged_parameter_variance(names, cov, **kw),
        rtol=1e-9,
    )
    # the unbridged form carries it into the answered samples around the reversals
    plain = parameter_variance_direct(names, wide, law=law, cutoff=2.0, **x)
    base = parameter_variance_direct(names, cov, law=law, cutoff=2.0, **x)
    assert float(np.max((plain / base)[~bridged])) > 2.0
