"""A covariance scale that depends on the gap between passes (stop 34, F41).

:func:`torquemap.uncertainty.gap_scale` regresses the left-out passes' ``log z^2`` on the log of
their gap and predicts an upper bound at the gap a task runs in. Here the left-out errors are
drawn with a standard deviation that grows with the gap as a known power law: the point
estimate recovers the law within its own closed-form standard error, and the one-sided upper
bound lies above the true factor in 95 % of draws. The friction block scaled per sample
(``uncertainty._gap_scaled_variance``) is checked against the covariance scaled directly.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_uncertainty_bridged import _law, _names, _signals

import torquemap.uncertainty as u
from torquemap.uncertainty import (
    LOG_CHI2_VAR,
    gap_covariance_scale,
    gap_scale,
    parameter_variance,
)


def _truth(q: np.ndarray | float, level: float, power: float) -> np.ndarray:
    return np.asarray(level * np.asarray(q, dtype=np.float64) ** power)


@pytest.mark.parametrize(("level", "power"), [(0.04, 1.0), (0.2, -0.5)])
def test_the_scale_recovers_a_known_growth_with_the_gap(level: float, power: float) -> None:
    # z = error / sd drawn with variance level * q^power at gaps q log-uniform on [0.2, 5]
    rng = np.random.default_rng(3)
    n = 4000
    q = np.exp(rng.uniform(math.log(0.2), math.log(5.0), n))
    z = np.sqrt(_truth(q, level, power)) * rng.standard_normal(n)
    at = np.array([0.3, 1.0, 3.0])
    got = gap_scale(q, z, at, confidence=0.5)  # the point estimate
    want = _truth(at, level, power)
    # the prediction's closed-form standard error in log: var (1/n + (u0 - mean u)^2 / S_uu)
    lu = np.log(q)
    se = np.sqrt(
        LOG_CHI2_VAR * (1 / n + (np.log(at) - lu.mean()) ** 2 / np.sum((lu - lu.mean()) ** 2))
    )
    assert np.all(np.abs(np.log(got / want)) < 4 * se)


def test_the_upper_bound_covers_95_percent() -> None:
    # 12 left-out passes at gaps 0.3-3, the factor 0.05 sqrt(q); the bound at q = 0.5
    rng = np.random.default_rng(7)
    n, trials = 12, 2000
    truth = float(_truth(0.5, 0.05, 0.5))
    covered = 0
    for _ in range(trials):
        q = np.exp(rng.uniform(math.log(0.3), math.log(3.0), n))
        z = np.sqrt(_truth(q, 0.05, 0.5)) * rng.standard_normal(n)
        covered += float(gap_scale(q, z, np.array([0.5]))[0]) >= truth
    # binomial sd of the share over 2000 draws: 0.0049; 4 of them
    assert abs(covered / trials - 0.95) < 4 * math.sqrt(0.95 * 0.05 / trials)


def test_few_points_equal_gaps_or_a_pass_give_no_shrinkage() -> None:
    z = np.full(6, 1e-3)
    q = np.array([0.5, 0.5, 1.0, 1.0, 2.0, 2.0])
    assert np.all(gap_scale(q[:2], z[:2], np.array([1.0])) == 1.0)  # fewer than 3 points
    assert np.all(gap_scale(np.full(6, 1.0), z, np.array([1.0])) == 1.0)  # slope unknown
    out = gap_scale(q, z, np.array([0.0, 1.0]))
    assert out[0] == 1.0 and out[1] < 1e-3  # at a pass: 1; between: tiny z, tiny factor
    assert np.all(gap_scale(q, np.full(6, 30.0), np.array([1.0])) == 1.0)  # never wider


def test_the_joint_scale_is_one_at_a_pass_and_below_the_slowest() -> None:
    passes = [1.0, 3.0, 9.0, 27.0, -1.0, -3.0, -9.0, -27.0]
    q = np.array([1.2, 1.2, 1.2, 1.2, 2.4, 2.4, 2.4, 2.4])  # interior / end passes' gaps
    z = np.full(8, 0.05) * np.sqrt(q)
    table = {"interpolation": {"gaps": q.tolist(), "errors": z.tolist(), "sigmas": [1.0] * 8}}
    v = np.array([0.5, 3.0, -9.0, math.sqrt(27.0), -math.sqrt(27.0)])
    got = gap_covariance_scale(table, {"speeds": passes}, v, 1e-3, confidence=0.5)
    assert got is not None
    assert got[0] == 1.0 and got[1] == 1.0 and got[2] == 1.0
    # between 3 and 9 the gap is (log 3 / 2)^2 = 0.30; z^2 = 0.0025 q exactly, so the estimate
    np.testing.assert_allclose(
        got[3:], 0.0025 * (math.log(3.0) / 2) ** 2 * math.exp(-u.LOG_CHI2_MEAN), rtol=1e-9
    )


def test_the_scaled_block_is_the_covariance_scaled(monkeypatch: pytest.MonkeyPatch) -> None:
    # with a constant factor k the per-sample form k A + 2 sqrt(k) B + C is the variance of
    # the covariance whose friction block's sd is scaled by sqrt(k)
    rng = np.random.default_rng(5)
    law = _law()
    names = _names(law)
    p = len(names)
    w = rng.standard_normal((p, p)) * np.geomspace(1e-2, 1e-5, p)
    cov = w @ w.T
    x = _signals(6000, rng)
    k = 0.07
    monkeypatch.setattr(u, "gap_covariance_scale", lambda *a, **kw: np.full(x["t"].size, k))
    kw = {"law": law, "cutoff": 2.0, **x}
    var = parameter_variance(names, cov, **kw)
    got = u._gap_scaled_variance(var, {}, {}, names, cov, width=1e-3, **kw)
    d = np.array([math.sqrt(k) if n.startswith("friction.") else 1.0 for n in names])
    want = parameter_variance(names, cov * np.outer(d, d), **kw)
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-9 * float(want.max()))
    assert not np.allclose(got, var, rtol=1e-2)
