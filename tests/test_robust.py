"""Robust least squares helpers (torquemap.robust)."""

from __future__ import annotations

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
