"""The whole fit's work done once (stop 41, S43): each shortcut against the code it replaced,
written out here as it was (a second algorithm): equal, not close."""

from __future__ import annotations

import math

import numpy as np
import pytest

from torquemap import identify_whole as iw
from torquemap.smooth_rows import RowSmoother


def _operator_arrays(sm: RowSmoother) -> tuple[np.ndarray, ...]:
    op = sm.operator
    return op.data, op.indices, op.indptr, sm.starts


@pytest.mark.parametrize("kind", ["uniform", "jittered", "gaps"])
def test_a_smoothers_subset_is_the_smoother_built_on_those_rows(kind: str) -> None:
    # uniform time (every window equally wide: the rows' weights read from the piece's
    # smoother), jittered time and time with gaps (windows of different widths: a subset
    # whose widest window is narrower is built again, one as wide is read)
    rng = np.random.default_rng(43)
    n = 6000
    t = np.arange(n) / 2000.0
    if kind == "jittered":
        t = t + rng.uniform(-1e-4, 1e-4, n)
        t.sort()
    elif kind == "gaps":
        t = np.cumsum(np.where(rng.random(n) < 0.01, 0.004, 0.0005))
    rows = np.arange(3, n - 2, 12).astype(np.intp)
    full = RowSmoother.build(t, rows, 0.05)
    picks = [
        np.arange(rows.size),
        np.arange(0, rows.size, 3),
        np.flatnonzero(rng.random(rows.size) < 0.2),
        np.arange(rows.size - 40, rows.size),  # the piece's end (windows clipped, padded)
        np.arange(5, 6),
    ]
    for index in picks:
        index = index.astype(np.intp)
        got = full.subset(index, rows[index], 0.05)
        built = RowSmoother.build(t, rows[index], 0.05)
        for a, b in zip(_operator_arrays(got), _operator_arrays(built), strict=True):
            np.testing.assert_array_equal(a, b)
            assert a.dtype == b.dtype
        assert got.operator.shape == built.operator.shape
        x = rng.normal(size=(n, 3))
        np.testing.assert_array_equal(got(x), built(x))


def _gram_as_it_was(gram: iw._Gram, w: np.ndarray) -> np.ndarray:
    """``_Gram.__call__`` before the rows were scaled in place."""
    diff = gram.base - w
    s = np.flatnonzero(diff)
    if 2 * s.size > w.size:
        return gram.a.T @ (gram.a * w[:, None])
    if s.size == 0:
        return gram.gram.copy()
    d = diff[s]
    part = gram.a[s]
    if np.all(d > 0):
        part = part * np.sqrt(d)[:, None]
        return gram.gram - part.T @ part
    return gram.gram - part.T @ (part * d[:, None])


def test_the_gram_update_scaled_in_place_is_the_same_product() -> None:
    rng = np.random.default_rng(41)
    a = rng.normal(size=(5000, 30)) * rng.lognormal(0.0, 2.0, 30)
    for base in (np.ones(5000), (rng.random(5000) < 0.8).astype(np.float64)):
        gram = iw._Gram(a, base)
        for share in (0.0, 0.05, 0.3, 0.7):
            w = base.copy()
            hit = rng.random(5000) < share
            w[hit] *= rng.uniform(0.1, 1.0, int(hit.sum()))  # Huber's weights: below the base
            np.testing.assert_array_equal(gram(w), _gram_as_it_was(gram, w))
            w[hit & (rng.random(5000) < 0.5)] += 0.5  # and some above it
            np.testing.assert_array_equal(gram(w), _gram_as_it_was(gram, w))


def _held_as_it_was(rows, a, w, prior, m, speeds, steady_speeds):  # type: ignore[no-untyped-def]
    """``_prior_held_knots`` before each steady speed was taken once."""
    k = len(speeds)
    fv = np.abs(
        rows.at(lambda p: p.velocity if p.friction_velocity is None else p.friction_velocity)
    )
    near = np.zeros(fv.size, dtype=bool)
    for x in steady_speeds:
        if x:
            near |= np.abs(np.log(np.maximum(fv, 1e-300) / abs(x))) < math.log(iw.ANCHOR_GAP)
    wa = w * ~near
    out = []
    for start in (m, m + k):
        cols = a[:, start : start + k]
        info = np.einsum("i,ij,ij->j", wa, cols, cols)
        out.append(info < iw.MEASURED_SHARE * np.diag(prior)[start : start + k])
    return out[0], out[1]


def test_the_prior_held_knots_with_each_speed_once_are_the_same() -> None:
    rng = np.random.default_rng(7)
    n = 4000
    t = np.arange(n) / 1000.0
    # a sweep of steady passes both ways and ramps between them (friction speeds on the
    # passes and between), a stretch at rest (speed 0)
    levels = np.repeat([0.5, -0.5, 2.0, -2.0, 0.0, 8.0, -8.0, 30.0], n // 8)
    v = levels * (1.0 + 0.02 * rng.normal(size=n)) + 0.3 * np.sin(t)
    piece = iw.Piece(
        t=t,
        theta=np.cumsum(v) / 1000.0,
        velocity=v,
        acceleration=np.gradient(v, t),
        torque=rng.normal(size=n),
        elbow=np.zeros(n),
        use=np.ones(n, dtype=bool),
        joint_angles=np.zeros((n, 2)),
        friction_velocity=v * (1.0 + 0.01 * rng.normal(size=n)),
    )
    rows = iw._Rows(
        pieces=[piece],
        rows=[np.arange(0, n, 5).astype(np.intp)],
        smoothers=[],
        clusters=np.zeros(n // 5, dtype=np.int64),
        window=0.05,
    )
    speeds = tuple(float(x) for x in np.geomspace(0.1, 40.0, 9))
    k, m = len(speeds), 3
    a = rng.normal(size=(n // 5, m + 2 * k + 2)) * (rng.random((n // 5, 1)) < 0.7)
    w = rng.uniform(0.0, 1.0, n // 5)
    seen = set()
    for scale in (1e-3, 3e3, 1e6):  # none, some and every knot held
        prior = np.diag(np.r_[np.zeros(m), scale * rng.uniform(0.5, 2.0, 2 * k + 2)])
        for steady in ([0.5, 0.5, 2.0, 2.0, 8.0, 8.0, 30.0], [-0.5, 0.5, 0.0, 8.0], [2.0]):
            got = iw._prior_held_knots(rows, a, w, prior, m, speeds, steady)
            want = _held_as_it_was(rows, a, w, prior, m, speeds, steady)
            for g, h in zip(got, want, strict=True):
                np.testing.assert_array_equal(g, h)
                seen.update(bool(x) for x in g)
    assert seen == {True, False}  # knots held and knots measured
