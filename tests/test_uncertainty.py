"""The parameters' share of the estimate's sigma: the fast forms against its definition.

:func:`torquemap.uncertainty.parameter_variance` low-passes a triangular factor's
combinations of the regressor (compiled kernels), at the log's rate (``rate="full"``) or at a
decimated one (the default, :mod:`torquemap.multirate`); :func:`parameter_variance_direct`
forms the (n, p) regressor, low-passes every column and takes ``g^T C g`` per sample (a second
algorithm). Both on data drawn here with a seeded generator, and on the whole-log model of the
SCARA bench.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import WHOLE_MODEL

from torquemap.friction_law import SpeedTableFriction, StribeckFriction
from torquemap.multirate import VARIANCE_RTOL, decimation_factor
from torquemap.uncertainty import (
    joint_uncertainty,
    parameter_variance,
    parameter_variance_direct,
)

# The factor of C is exact algebra; what differs is rounding in the eigen/QR factorisation and
# in the sums (condition of C's correlation times eps): 1e-7 relative leaves three orders
# of margin below the run's observed 1e-10 and five below the 1 % the sigma is asked to hold.
RTOL = 1e-7


def _signals(n: int, *, rng: np.random.Generator, h: float = 5e-4) -> dict[str, np.ndarray]:
    t = h * np.arange(n)
    # reversals, rest and fast passes: every knot of the table and both branches are used
    velocity = 30.0 * np.sin(2 * np.pi * 0.4 * t) ** 3 + 0.01 * rng.standard_normal(n)
    theta = np.cumsum(velocity) * h
    return {
        "t": t,
        "theta": theta,
        "velocity": velocity,
        "acceleration": np.gradient(velocity, h) + rng.standard_normal(n),
        "modulation": np.cos(0.3 * theta),
    }


def _covariance(p: int, rng: np.random.Generator, *, rank: int | None = None) -> np.ndarray:
    a = rng.standard_normal((p, rank or p)) * np.geomspace(1e-2, 1e-6, rank or p)
    scales = np.geomspace(1e-3, 1.0, p)[rng.permutation(p)]
    return np.asarray((scales[:, None] * a) @ (scales[:, None] * a).T)


def _stribeck() -> StribeckFriction:
    """A law whose basis is dense (no table)."""
    return StribeckFriction(
        coulomb_positive=0.05,
        coulomb_negative=0.06,
        viscous=1e-3,
        stribeck_positive=0.02,
        stribeck_negative=0.01,
        stribeck_velocity=0.5,
        zero_velocity=0.01,
    )


def _table_law(rng: np.random.Generator) -> SpeedTableFriction:
    """A speed table of 9 knots with levels drawn from ``rng``."""
    return SpeedTableFriction(
        speeds=tuple(np.geomspace(0.05, 40.0, 9)),
        positive=tuple(0.05 + 0.01 * rng.random(9)),
        negative=tuple(0.06 + 0.01 * rng.random(9)),
        viscous=1e-4,
        viscous_negative=2e-4,
        zero_velocity=0.02,
    )


def _names_table(law: SpeedTableFriction) -> list[str]:
    pdtv = [
        f"pdtv.{order}.{direction}.{part}"
        for order, direction in (
            ("1", "both"),
            ("2", "both"),
            ("21", "both"),
            ("1.25", "both"),
            ("3", "positive"),
            ("48", "negative"),
        )
        for part in ("a", "b")
    ]
    friction = [f"friction.{name}" for name in law.linear_parameter_names]
    # the inertia columns after some lines and friction in the middle: the fast form must not
    # rely on the order identification writes
    return [*pdtv[:4], "inertia.constant", *friction, *pdtv[4:], "inertia.cos_elbow"]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_table_law_matches_direct_formula(seed: int) -> None:
    rng = np.random.default_rng(seed)
    law = _table_law(rng)
    names = _names_table(law)
    cov = _covariance(len(names), rng)
    x = _signals(20_000, rng=rng)
    fast = parameter_variance(names, cov, law=law, cutoff=2.0, rate="full", **x)
    direct = parameter_variance_direct(names, cov, law=law, cutoff=2.0, **x)
    np.testing.assert_allclose(fast, direct, rtol=RTOL, atol=0.0)
    # 2 kHz and 2 Hz: decimated by 19 (the default), held to the accuracy multirate states
    assert decimation_factor(float(x["t"][1]), 2.0) == 19
    decimated = parameter_variance(names, cov, law=law, cutoff=2.0, **x)
    np.testing.assert_allclose(decimated, direct, rtol=VARIANCE_RTOL, atol=0.0)


def test_rank_deficient_covariance_and_dense_law() -> None:
    # a singular C (fewer samples than parameters in a fit) and a law whose basis is dense
    rng = np.random.default_rng(7)
    law = _stribeck()
    names = ["inertia.constant", "pdtv.4.both.a", "pdtv.4.both.b"] + [
        f"friction.{k}" for k in law.linear_parameter_names
    ]
    cov = _covariance(len(names), rng, rank=3)
    x = _signals(8_000, rng=rng)
    fast = parameter_variance(names, cov, law=law, cutoff=5.0, rate="full", **x)
    direct = parameter_variance_direct(names, cov, law=law, cutoff=5.0, **x)
    # singular: the direct form's rounding, eps ||C|| ||g||^2, is the floor of both
    floor = (
        1e-15
        * np.abs(cov).max()
        * np.max(np.sum(np.column_stack([x["acceleration"], np.ones_like(x["t"])]) ** 2, axis=1))
    )
    np.testing.assert_allclose(fast, direct, rtol=RTOL, atol=floor)


@pytest.mark.parametrize("seed", [0, 1])
def test_irregular_time_decimated_on_the_resampled_grid(seed: int) -> None:
    # jittered stamps (3 % of the step) with dropouts: the decimated form runs on the grid the
    # direct formula's low-pass resamples to (rows interpolated alike, the variance back as
    # the signals are), held to the accuracy multirate states; rate="full" keeps the direct
    # formula itself
    rng = np.random.default_rng(seed)
    law = _table_law(rng)
    names = _names_table(law)
    cov = _covariance(len(names), rng)
    x = _signals(20_000, rng=rng)
    x["t"] = x["t"] + 1.5e-5 * rng.uniform(-1.0, 1.0, x["t"].size)
    x = {k: np.delete(v, np.arange(11, v.size, 61)) for k, v in x.items()}
    direct = parameter_variance_direct(names, cov, law=law, cutoff=2.0, **x)
    full = parameter_variance(names, cov, law=law, cutoff=2.0, rate="full", **x)
    np.testing.assert_array_equal(full, direct)
    assert decimation_factor(float(np.median(np.diff(x["t"]))), 2.0) == 19
    decimated = parameter_variance(names, cov, law=law, cutoff=2.0, **x)
    np.testing.assert_allclose(decimated, direct, rtol=VARIANCE_RTOL, atol=0.0)
    assert np.any(decimated != direct)  # the decimated path did run


def test_irregular_short_log_takes_the_direct_formula() -> None:
    # too few decimated samples on the grid: the direct formula, bit for bit
    rng = np.random.default_rng(4)
    law = _stribeck()
    names = ["inertia.constant"] + [f"friction.{k}" for k in law.linear_parameter_names]
    cov = _covariance(len(names), rng)
    x = _signals(600, rng=rng)  # 29 decimated samples on the grid, fewer than MIN_DECIMATED
    x["t"] = x["t"] + 1e-4 * rng.random(x["t"].size)
    fast = parameter_variance(names, cov, law=law, cutoff=2.0, **x)
    direct = parameter_variance_direct(names, cov, law=law, cutoff=2.0, **x)
    np.testing.assert_array_equal(fast, direct)


@WHOLE_MODEL
def test_bench_model_sigma_matches_direct_formula(scara_model: Path, scara_bench: Path) -> None:
    import torquemap.uncertainty as U
    from torquemap.estimate import estimate_forces
    from torquemap.io import read_log
    from torquemap.model import load_model

    model = load_model(scara_model)
    calls: list[tuple[str, dict[str, np.ndarray]]] = []
    original = U.joint_sigma

    def spy(m: object, joint: str, **kw: object) -> np.ndarray:
        calls.append((joint, kw))  # type: ignore[arg-type]
        return original(m, joint, **kw)  # type: ignore[arg-type]

    U.joint_sigma = spy  # type: ignore[assignment]
    try:
        estimate_forces(model, read_log(scara_bench / "circle.csv", model.robot))
    finally:
        U.joint_sigma = original  # type: ignore[assignment]
    assert calls
    for joint, kw in calls:
        table = joint_uncertainty(model, joint)
        assert table is not None
        names = [str(s) for s in table["parameters"]]
        cov = np.asarray(table["covariance"], dtype=np.float64)
        args = {k: kw[k] for k in ("t", "theta", "velocity", "acceleration", "modulation")}
        law = model.joints[joint].friction
        cutoff = float(kw["cutoff"])
        fast = parameter_variance(names, cov, law=law, cutoff=cutoff, rate="full", **args)
        direct = parameter_variance_direct(names, cov, law=law, cutoff=cutoff, **args)
        np.testing.assert_allclose(fast, direct, rtol=RTOL, atol=0.0)
        decimated = parameter_variance(names, cov, law=law, cutoff=cutoff, **args)
        assert decimation_factor(float(np.median(np.diff(args["t"]))), cutoff) == 19
        np.testing.assert_allclose(decimated, direct, rtol=VARIANCE_RTOL, atol=0.0)
