"""Robust least squares helpers (torquemap.robust)."""

from __future__ import annotations

import math

import numpy as np
from numpy.testing import assert_array_equal

from torquemap.robust import cluster_medians


def test_cluster_medians_equal_each_clusters_numpy_median() -> None:
    # against a second algorithm: numpy's median of each cluster taken alone (odd and even
    # sizes, labels neither sorted nor contiguous, a cluster of one)
    rng = np.random.default_rng(7)
    labels = rng.choice([-3, 0, 5, 11, 40], size=301)
    labels[17] = 99
    values = rng.normal(size=301)
    got = cluster_medians(values, labels)
    want = np.array([np.median(values[labels == c]) for c in labels])
    assert_array_equal(got, want)
    assert cluster_medians(np.zeros(0), np.zeros(0, dtype=int)).shape == (0,)


def _null_rejections(clusters: int, level: float, reps: int) -> tuple[float, float]:
    """Share of true null Wald tests rejected at ``level``: the sandwich covariance with the
    chi-square reference, and the leave-one-cluster-out covariance with the F(m, G - 1)
    reference; on regressions simulated here with regressors and errors correlated within
    clusters (the regressors vary mostly between clusters: the hard case)."""
    from scipy import stats

    from torquemap.robust import (
        cluster_covariance,
        cluster_jackknife_covariance,
        cluster_wald_pvalue,
        weighted_solve,
    )

    rng = np.random.default_rng(3)
    size, m = 40, 2
    groups = np.repeat(np.arange(clusters), size)
    w = np.ones(groups.size)
    chi_hits = f_hits = 0
    for _ in range(reps):
        x = 3.0 * rng.normal(size=(clusters, m))[groups] + rng.normal(size=(groups.size, m))
        a = np.column_stack([np.ones(groups.size), x])
        y = rng.normal(size=clusters)[groups] + rng.normal(size=groups.size)
        coef, bread = weighted_solve(a, y, w)
        sandwich = cluster_covariance(a, y - a @ coef, w, bread, groups)[1:, 1:]
        c = coef[1:]
        chi_hits += float(c @ np.linalg.pinv(sandwich) @ c) > stats.chi2.ppf(1.0 - level, m)
        jack = cluster_jackknife_covariance(a, y, w, groups)[1:, 1:]
        f_hits += cluster_wald_pvalue(c, jack, clusters) < level
    return chi_hits / reps, f_hits / reps


def test_cluster_wald_keeps_its_level_with_few_clusters() -> None:
    # 12 clusters: the sandwich with a chi-square reference rejects a true null several times
    # more often than asked; the jackknife with F(m, G - 1) stays near the level (Monte Carlo,
    # 1000 regressions: binomial sd of a 5 % rate 0.7 %)
    chi, f = _null_rejections(12, 0.05, 1000)
    assert chi > 0.15
    assert 0.02 < f < 0.09
    # many clusters: both near the level
    chi, f = _null_rejections(150, 0.05, 400)
    assert 0.02 < chi < 0.09
    assert 0.02 < f < 0.09


def test_cluster_jackknife_covariance_equals_explicit_refits() -> None:
    # a second algorithm: refit without each cluster by numpy's lstsq on the remaining rows
    from torquemap.robust import cluster_jackknife_covariance

    rng = np.random.default_rng(5)
    groups = rng.integers(0, 7, size=120)
    a = np.column_stack([np.ones(120), rng.normal(size=120), 1e3 * rng.normal(size=120)])
    y = rng.normal(size=120)
    w = rng.uniform(0.5, 2.0, size=120)
    betas = []
    for g in np.unique(groups):
        keep = groups != g
        sw = np.sqrt(w[keep])
        betas.append(np.linalg.lstsq(a[keep] * sw[:, None], y[keep] * sw, rcond=None)[0])
    b = np.array(betas)
    d = b - b.mean(axis=0)
    want = (len(b) - 1) / len(b) * d.T @ d
    np.testing.assert_allclose(cluster_jackknife_covariance(a, y, w, groups), want, rtol=1e-8)


def _median_cases() -> list[np.ndarray]:
    rng = np.random.default_rng(11)
    cases = [
        rng.normal(size=62_001),
        rng.normal(size=62_000),
        rng.standard_cauchy(size=50_000),
        rng.integers(-3, 4, size=40_000).astype(np.float64),  # ties at the median
        np.full(10_000, 2.5),
        np.sort(rng.normal(size=30_000)),
        rng.exponential(size=4096),
        np.abs(rng.normal(size=20_001)) * 1e-300,
    ]
    spiky = rng.normal(size=33_333)
    spiky[::16] = 1e9  # the sample sees only outliers: the count must catch it
    cases.append(spiky)
    with_inf = rng.normal(size=8192)
    with_inf[:3000] = np.inf
    cases.append(with_inf)
    with_nan = rng.normal(size=9000)
    with_nan[17] = np.nan
    cases.append(with_nan)
    cases.append(rng.normal(size=100))  # short: numpy's itself
    return cases


def test_exact_median_is_numpys() -> None:
    # second algorithm: numpy's median (a partition of every value); the same order
    # statistics and numpy's mean of the two, so the same bits
    from torquemap.robust import exact_median

    for x in _median_cases():
        want = np.median(x)
        got = exact_median(x)
        assert (math.isnan(got) and math.isnan(want)) or got == want, x.size
        assert np.float64(got).tobytes() == np.float64(want).tobytes() or got == 0.0


def test_mad_scale_is_robust_scale() -> None:
    from torquemap.robust import mad_scale, robust_scale

    for x in _median_cases():
        a, b = mad_scale(x), robust_scale(x)
        assert (math.isnan(a) and math.isnan(b)) or a == b, x.size
    assert mad_scale(np.empty(0)) == robust_scale(np.empty(0)) == 0.0
