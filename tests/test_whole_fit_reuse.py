"""The whole fit's work done once (stop 40, S42): each shortcut against the code it replaced,
written out here as it was (a second algorithm): equal, not close."""

from __future__ import annotations

import math

import numpy as np
import pytest

from torquemap._fit_kernels import segment_medians
from torquemap.friction_prior import (
    EXPONENTS,
    SPREAD,
    VELOCITY_STEP,
    amplitude,
    curve_precision,
    search_curve,
    stribeck_shape,
)


def _sorted_medians(v: np.ndarray, starts: np.ndarray, stops: np.ndarray) -> np.ndarray:
    """The segment medians as they were: each segment sorted."""
    out = np.empty(starts.size)
    for s, (a, b) in enumerate(zip(starts, stops, strict=True)):
        seg = np.sort(v[a:b])
        out[s] = 0.5 * (seg[(b - a - 1) // 2] + seg[(b - a) // 2])
    return out


@pytest.mark.parametrize("kind", ["normal", "integers", "rounded", "descending", "nan"])
def test_selected_segment_medians_are_the_sorted_ones(kind: str) -> None:
    # odd and even counts from 1 to 400 values, ties, values in falling order (a pivot's worst
    # case), a NaN (sorted last as numpy sorts it)
    rng = np.random.default_rng(40)
    for _ in range(300):
        n = int(rng.integers(1, 400))
        if kind == "integers":
            v = rng.integers(-3, 4, size=n).astype(np.float64)
        elif kind == "rounded":
            v = np.round(rng.normal(size=n), 1)
        elif kind == "descending":
            v = np.sort(rng.normal(size=n))[::-1].copy()
        else:
            v = rng.normal(size=n)
        if kind == "nan":
            v[int(rng.integers(0, n))] = np.nan
        cuts = np.unique(np.r_[0, rng.integers(1, n + 1, size=int(rng.integers(0, 6))), n])
        starts, stops = cuts[:-1].astype(np.intp), cuts[1:].astype(np.intp)
        got = segment_medians(v, starts, stops)
        np.testing.assert_array_equal(got, _sorted_medians(v, starts, stops))


def _search_as_it_was(objective, precision, offset, speeds, level, velocities):  # type: ignore[no-untyped-def]
    """search_curve before the pairs were kept: every pair evaluated where the loop meets it."""
    k = len(speeds)
    x = np.asarray(speeds, dtype=np.float64)
    spread = SPREAD * max(level, 1e-12)
    lo, hi = velocities
    count = max(2, math.ceil(math.log(hi / lo) / math.log(VELOCITY_STEP)) + 1)
    grid = [(0.0, 2.0)] + [(float(v), e) for v in np.geomspace(lo, hi, count) for e in EXPONENTS]
    chosen = [(0.0, 2.0), (0.0, 2.0)]

    def shapes(c):  # type: ignore[no-untyped-def]
        return stribeck_shape(x, *c[0]), stribeck_shape(x, *c[1])

    best = objective(precision)[0]
    for _ in range(2):
        moved = False
        for side in (0, 1):
            start = offset + side * k
            block = precision[start : start + k, start : start + k]
            for candidate in grid:
                trial = list(chosen)
                trial[side] = candidate
                value, coef = objective(
                    curve_precision(precision, offset, k, shapes(trial), spread)
                )
                if not value < best - 1e-12 * abs(best):
                    continue
                phi = shapes(trial)[side]
                if candidate[0] > 0 and amplitude(block, coef[start : start + k], phi, spread) < 0:
                    continue
                best, chosen, moved = value, trial, True
        if not moved:
            break
    gains = [0.0, 0.0]
    for side in (0, 1):
        if chosen[side][0] > 0:
            trial = list(chosen)
            trial[side] = (0.0, 2.0)
            gains[side] = (
                objective(curve_precision(precision, offset, k, shapes(trial), spread))[0] - best
            )
    return chosen, best, gains


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_curve_search_evaluates_each_pair_once_and_chooses_as_before(seed: int) -> None:
    # knots seen at a few pass speeds in both directions from Fc + Fs exp(-(s / vs)^delta),
    # each direction its own curve (or none): the same curves, objective and gains as the
    # search that evaluated every pair it met, from fewer evaluations, none repeated
    rng = np.random.default_rng(seed)
    speeds = np.geomspace(0.1, 30.0, 14)
    k = speeds.size
    passes = [1, 4, 7, 10, 13]
    truth_up = 1.0 + rng.uniform(0.0, 0.8) * stribeck_shape(speeds, rng.uniform(0.5, 5.0), 2.0)
    truth_down = 0.9 + (seed % 2) * 0.5 * stribeck_shape(speeds, 1.0, 1.0)
    a = np.zeros((2 * len(passes), 2 * k))
    y = np.zeros(2 * len(passes))
    for row, i in enumerate(passes):
        a[row, i] = 1.0
        a[len(passes) + row, k + i] = 1.0
        y[row] = truth_up[i]
        y[len(passes) + row] = truth_down[i]
    y += 1e-3 * rng.normal(size=y.size)
    d1 = np.diff(np.eye(k), axis=0) / 1.0
    d2 = np.diff(np.eye(k), 2, axis=0) / 0.05
    precision = np.kron(np.eye(2), d1.T @ d1 + d2.T @ d2)
    noise = 1e-6
    seen: list[bytes] = []

    def objective(q: np.ndarray) -> tuple[float, np.ndarray]:
        seen.append(q.tobytes())
        normal = a.T @ a + noise * q + 1e-12 * np.eye(a.shape[1])
        coef = np.linalg.solve(normal, a.T @ y)
        return float(np.sum((y - a @ coef) ** 2) + noise * coef @ q @ coef), coef

    chosen, best, gains = _search_as_it_was(objective, precision, 0, speeds, 1.0, (0.5, 10.0))
    before = len(seen)
    seen.clear()
    curve, _ = search_curve(objective, precision, 0, list(speeds), 1.0, velocities=(0.5, 10.0))
    assert list(zip(curve.velocity, curve.exponent, strict=True)) == chosen
    assert curve.objective == best
    assert list(curve.gain) == gains
    assert len(seen) == len(set(seen)) < before  # each precision once, fewer than before


def test_a_fit_that_reuses_an_earlier_fits_product_is_the_same_fit() -> None:
    # _irls with the gram of an earlier fit on the same design and rows equals _irls building
    # its own (== on every number); a gram of other rows is not used
    from torquemap.identify_whole import _Gram, _irls

    rng = np.random.default_rng(5)
    n, p = 3000, 6
    a = rng.normal(size=(n, p))
    y = a @ rng.normal(size=p) + rng.standard_t(2, size=n)  # heavy tails: Huber's weights < 1
    keep = (rng.random(n) > 0.2).astype(np.float64)
    clusters = np.arange(n) // 50
    prior = 1e-3 * np.eye(p)
    first = _irls(a, y, keep, prior, keep=keep, clusters=clusters)
    assert first.gram is not None and first.gram.a is a
    again = _irls(a, y, first.weights, 2.0 * prior, keep=keep, clusters=clusters, gram=first.gram)
    fresh = _irls(a, y, first.weights, 2.0 * prior, keep=keep, clusters=clusters)
    assert again.gram is first.gram
    for name in ("coef", "bread", "residual", "weights"):
        np.testing.assert_array_equal(getattr(again, name), getattr(fresh, name))
    assert again.objective == fresh.objective
    other = (rng.random(n) > 0.5).astype(np.float64)
    mine = _irls(a, y, other, prior, keep=other, clusters=clusters, gram=first.gram)
    assert mine.gram is not first.gram
    np.testing.assert_array_equal(
        mine.coef, _irls(a, y, other, prior, keep=other, clusters=clusters).coef
    )
    assert isinstance(mine.gram, _Gram)
