"""Stop 43 (I63): the compiled paths of identification's per-sample work against the numpy
code they replaced (written out here), the same results to the bit."""

from __future__ import annotations

import numpy as np
import pytest

from torquemap.filters import dilate


def _dilate_numpy(t: np.ndarray, mask: np.ndarray, reach: float) -> np.ndarray:
    """``dilate`` before stop 43: counts of the covering intervals by ``searchsorted``."""
    bad = np.flatnonzero(mask)
    if bad.size == 0:
        return np.asarray(mask, dtype=bool).copy()
    tb = t[bad]
    lo = np.searchsorted(t, tb - reach, side="left")
    hi = np.searchsorted(t, tb + reach, side="right")
    edges = np.bincount(lo, minlength=t.size + 1) - np.bincount(hi, minlength=t.size + 1)
    return np.cumsum(edges[:-1]) > 0


def _times(kind: str, rng: np.random.Generator, n: int) -> np.ndarray:
    if kind == "uniform":  # a regular grid: keys land on samples exactly
        return np.arange(n) * 0.0005
    if kind == "repeated":  # stamps on a coarse grid, many equal
        return np.sort(np.round(rng.uniform(0.0, 5.0, n), 2))
    if kind == "gaps":
        return np.cumsum(np.where(rng.random(n) < 0.01, 0.2, 0.0005))
    return 1.7e9 + np.arange(n) * 0.0005  # Unix-epoch stamps: the keys' rounding decides


@pytest.mark.parametrize("kind", ["uniform", "repeated", "gaps", "epoch"])
def test_dilate_is_the_interval_counts(kind: str) -> None:
    rng = np.random.default_rng(63)
    n = 5000
    t = _times(kind, rng, n)
    runs = np.abs(np.sin(np.arange(n) * 0.01)) < 0.2  # runs of marked samples
    for mask in (
        np.zeros(n, dtype=bool),
        np.ones(n, dtype=bool),
        rng.random(n) < 0.002,
        rng.random(n) < 0.3,
        runs,
        np.eye(1, n, n - 1, dtype=bool)[0],  # the last sample alone
        np.eye(1, n, 0, dtype=bool)[0],  # the first
    ):
        for reach in (0.0, 0.0005, 0.001, 0.025, 0.05, 0.0123, 3.0, 1e9):
            got = dilate(t, mask, reach)
            assert got.dtype == np.bool_ and got.shape == (n,)
            np.testing.assert_array_equal(got, _dilate_numpy(t, mask, reach))
