"""The whole fit's table prior centred on a generalized Stribeck curve (torquemap.friction_prior)."""

from __future__ import annotations

import numpy as np
from numpy.testing import assert_allclose

from torquemap.friction_prior import amplitude, curve_precision, search_curve, stribeck_shape


def _smoothness(k: int) -> np.ndarray:
    """A second-difference precision plus a small ridge (full rank, so it can be inverted)."""
    d2 = np.diff(np.eye(k), 2, axis=0) / 0.05
    return d2.T @ d2 + 1e-2 * np.eye(k)


def test_the_reduced_precision_is_the_prior_of_a_curve_plus_a_deviation() -> None:
    # a second algorithm: knots = Fs phi + d with Fs ~ N(0, s^2) and d ~ N(0, P^-1) has the
    # covariance P^-1 + s^2 phi phi^T; its inverse must be the rank-one reduction
    k, spread = 7, 0.3
    p = _smoothness(k)
    phi = stribeck_shape(np.geomspace(0.1, 10.0, k), 1.0, 2.0)
    full = np.zeros((2 * k + 3, 2 * k + 3))
    full[1 : 1 + 2 * k, 1 : 1 + 2 * k] = np.kron(np.eye(2), p)
    out = curve_precision(full, 1, k, (phi, np.zeros(k)), spread)
    expected = np.linalg.inv(np.linalg.inv(p) + spread**2 * np.outer(phi, phi))
    # (the direct inverse of an ill-conditioned P^-1 + s^2 phi phi^T loses ~1e-9 relative)
    scale = float(np.max(np.abs(expected)))
    assert_allclose(out[1 : 1 + k, 1 : 1 + k], expected, rtol=1e-7, atol=1e-7 * scale)
    # the other direction (no curve) and the other columns are untouched
    assert_allclose(out[1 + k : 1 + 2 * k, 1 + k : 1 + 2 * k], p)
    assert np.all(out[0] == 0) and np.all(out[-1] == 0)


def test_the_amplitude_is_the_conditional_mean_of_fs() -> None:
    # E[Fs | knots] of the joint Gaussian: s^2 phi^T (P^-1 + s^2 phi phi^T)^-1 knots
    rng = np.random.default_rng(1)
    k, spread = 6, 2.0
    p = _smoothness(k)
    phi = stribeck_shape(np.geomspace(0.2, 5.0, k), 0.8, 1.5)
    knots = rng.normal(size=k)
    cov = np.linalg.inv(p) + spread**2 * np.outer(phi, phi)
    expected = spread**2 * phi @ np.linalg.solve(cov, knots)
    assert abs(amplitude(p, knots, phi, spread) - expected) < 1e-9 * max(1.0, abs(expected))


def test_the_search_finds_the_velocity_of_a_curve_seen_at_its_passes() -> None:
    # knots seen directly (a design that picks the knots at five pass speeds, noise 1e-4 of a
    # level 1) from Fc + Fs exp(-(s / vs)^delta): the penalised objective prefers the curve's
    # own velocity, within a grid step (1.25x), and a positive amplitude
    speeds = np.geomspace(0.1, 30.0, 14)
    passes = [1, 4, 7, 10, 13]
    truth = 1.0 + 0.6 * stribeck_shape(speeds, 2.0, 2.0)
    rng = np.random.default_rng(0)
    a = np.zeros((len(passes), 2 * speeds.size))
    for row, i in enumerate(passes):
        a[row, i] = 1.0
    y = truth[passes] + 1e-4 * rng.normal(size=len(passes))
    d1 = np.diff(np.eye(speeds.size), axis=0) / 1.0
    d2 = np.diff(np.eye(speeds.size), 2, axis=0) / 0.05
    block = d1.T @ d1 + d2.T @ d2
    precision = np.kron(np.eye(2), block)
    noise = 1e-8

    def objective(q: np.ndarray) -> tuple[float, np.ndarray]:
        normal = a.T @ a + noise * q + 1e-12 * np.eye(a.shape[1])
        coef = np.linalg.solve(normal, a.T @ y)
        return float(np.sum((y - a @ coef) ** 2) + noise * coef @ q @ coef), coef

    curve, q = search_curve(objective, precision, 0, list(speeds), 1.0)
    assert 2.0 / 1.25 <= curve.velocity[0] <= 2.0 * 1.25
    assert curve.velocity[1] == 0.0  # the other direction has no data: no curve
    coef = objective(q)[1]
    phi = stribeck_shape(speeds, curve.velocity[0], curve.exponent[0])
    assert amplitude(block, coef[: speeds.size], phi, 1.0) > 0
    # between the passes the table follows the curve more closely than the smoothness prior
    # alone, which draws a + b log s through them (measured: largest error 0.035 against 0.059
    # of the level; the curve's exponent is the grid's, not the truth's)
    between = [5, 6, 8, 9]
    plain = objective(precision)[1]
    assert np.max(np.abs(coef[between] - truth[between])) < 0.7 * np.max(
        np.abs(plain[between] - truth[between])
    )
