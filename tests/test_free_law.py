"""The free law's regression on stretches of a log (torquemap.free_law).

Smoothing only the stretches widened by a window must give the whole log's smoothing at the
stretches' rows (the reference here: the columns formed on the whole log and smoothed by
filters.smooth_as_acceleration, as the diagnostics did before); the stretches must respect
the budget, keep every run's ends and spread evenly; and the thinned fit must still find a
delay simulated here.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.delay import estimate_motion_delay
from torquemap.filters import differentiate, smooth_as_acceleration
from torquemap.free_law import (
    _friction_basis,
    free_law_rows,
    mask_runs,
    select_stretches,
    speed_knots,
)

WINDOW = 0.05


def _log(kind: str, n: int = 40000) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Time [s], angle [rad], torque [N m] and moving rows of back-and-forth passes."""
    rng = np.random.default_rng(11)
    h = 5e-4
    if kind == "uniform":
        t = np.arange(n) * h
    elif kind == "jitter":
        t = np.cumsum(h * (1.0 + 0.3 * rng.uniform(-1.0, 1.0, n)))
    else:  # a regular log with one gap: the log is irregular, most stretches are regular
        t = np.arange(n) * h
        t[n // 3 :] += 7.3 * h
    # moving at both ends of the log: stretches there meet the filter's end windows
    speed = 6.0 * np.sin(2 * np.pi * t / 4.0 + 0.5) + 2.0 * np.sin(2 * np.pi * t / 0.7)
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))))
    torque = 0.03 * np.sign(speed) + 0.002 * np.cos(4 * angle) + rng.normal(0, 0.003, n)
    rows = np.abs(speed) > 1.0
    return t, angle, torque, rows


def _velocity(t: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """The friction velocity as the diagnostics formed it on the whole log."""
    span = WINDOW / 8
    lo, hi = np.maximum(t - span, t[0]), np.minimum(t + span, t[-1])
    return (np.interp(hi, t, angle) - np.interp(lo, t, angle)) / (hi - lo)


@pytest.mark.parametrize("kind", ["uniform", "jitter", "gap"])
def test_stretches_give_the_whole_logs_smoothing(kind: str) -> None:
    t, angle, torque, rows = _log(kind)
    acc = differentiate(t, angle, window=WINDOW).acceleration
    orders = [1.0, 4.0]

    def law(th: np.ndarray, v: np.ndarray) -> np.ndarray:
        return 0.02 * np.tanh(v) + 0.001 * np.sin(4 * th)

    free = free_law_rows(
        [t], [angle], [acc], [torque], [rows], orders, window=WINDOW, model_torque=law,
        max_rows=6000, max_shift=0.2,
    )  # fmt: skip
    idx = free.index[0]
    assert idx.size <= 6000 and np.all(rows[idx])
    assert idx[0] == 0 and idx[-1] == t.size - 1
    # the reference: every column over the whole log, smoothed over the whole log
    v = _velocity(t, angle)
    assert_allclose(free.knots, speed_knots(np.abs(v[idx])), rtol=1e-12)
    parts = [_friction_basis(v, free.knots)]
    parts += [np.c_[np.cos(n * angle), np.sin(n * angle)] for n in orders]
    whole = smooth_as_acceleration(t, np.hstack([*parts, law(angle, v)[:, None]]), window=WINDOW)
    design = np.hstack([acc[:, None], whole[:, :-1]])[idx]
    design = design[:, np.any(design != 0, axis=0)]
    y = smooth_as_acceleration(t, torque, window=WINDOW)
    # relative to each column's size: the whole log's double integral (20 s) rounds at about
    # 1e-10 of it after the differentiator's 1 / h^2; a window's edge missed by one sample
    # would change the smoothing by about 1 / 100 of the signal (100 samples per window)
    scale = np.max(np.abs(design), axis=0)
    assert_allclose(free.design / scale, design / scale, rtol=0, atol=1e-9)
    assert_allclose(free.model, whole[idx, -1], rtol=0, atol=1e-9 * 0.02)
    assert_allclose(free.torque, y[idx], rtol=0, atol=1e-9 * 0.03)
    for delay in (-0.2, -0.0371, 0.113, 0.2):
        assert_allclose(
            free.torque_at(delay), np.interp(t[idx] + delay, t, y), rtol=0, atol=1e-9 * 0.03
        )
    # inside a stretch the rows are consecutive: one window holds window / step of them
    assert_allclose(free.correlation, WINDOW / np.median(np.diff(t)), rtol=0.02)


def test_small_logs_keep_every_row() -> None:
    t, angle, torque, rows = _log("jitter", n=8000)
    acc = differentiate(t, angle, window=WINDOW).acceleration
    free = free_law_rows([t], [angle], [acc], [torque], [rows], [4.0], window=WINDOW)
    np.testing.assert_array_equal(free.index[0], np.flatnonzero(rows))


def test_stretches_keep_every_runs_ends_within_the_budget() -> None:
    rng = np.random.default_rng(2)
    logs, masks = [], []
    for n, h in ((300000, 5e-4), (120000, 2.9e-3)):
        t = np.cumsum(h * (1.0 + 0.1 * rng.uniform(-1.0, 1.0, n)))
        mask = np.zeros(n, dtype=bool)
        cuts = np.sort(rng.choice(n, 60, replace=False))
        for a, b in zip(cuts[::2], cuts[1::2], strict=True):
            mask[a:b] = True
        mask[rng.choice(n, 30)] = True  # single samples: runs of one row
        logs.append(t)
        masks.append(mask)
    budget = 40000
    chosen = select_stretches(logs, masks, window=WINDOW, max_rows=budget)
    total = sum(b - a for s in chosen for a, b in s)
    assert budget * 0.95 <= total <= budget
    for t, mask, stretches in zip(logs, masks, chosen, strict=True):
        starts = {a for a, _ in stretches}
        stops = {b for _, b in stretches}
        length = int(np.ceil(4 * WINDOW / ((t[-1] - t[0]) / (t.size - 1))))
        for a, b in mask_runs(mask):
            # each run's first and last rows, where a pass's ramps are
            assert a in starts and b in stops
            inside = [(p, q) for p, q in stretches if a <= p and q <= b]
            if inside != [(a, b)]:  # thinned (else the run is short enough to keep whole)
                # its start, its end and at least one stretch in its middle
                assert len(inside) >= 3 and all(q - p == length for p, q in inside)
                gaps = np.diff([p for p, _ in inside])
                # evenly spaced to a row (rounding)
                assert gaps.max() - gaps.min() <= 1
        assert all(mask[a:b].all() for a, b in stretches)
        assert all(q <= p for (_, q), (p, _) in itertools.pairwise(stretches))


def test_many_short_runs_still_fit_the_budget() -> None:
    t = np.arange(200000) * 1e-3
    mask = np.zeros(t.size, dtype=bool)
    mask[::4] = True  # 50 000 runs of one row
    chosen = select_stretches([t], [mask], window=WINDOW, max_rows=10000)[0]
    assert 0 < sum(b - a for a, b in chosen) <= 10000
    # spread over the whole log, not its start
    assert chosen[0][0] == 0 and chosen[-1][0] > 0.99 * t.size


def test_thinned_fit_finds_a_simulated_delay() -> None:
    # passes with ramps at 2 kHz, the torque channel 40 ms late; 3 % of the rows fitted
    rng = np.random.default_rng(5)
    h, delay, inertia = 5e-4, 0.04, 2e-3
    vel: list[np.ndarray] = [np.zeros(400)]
    for v in (2.0, 5.0, 12.0, 30.0):
        for s in (1, -1):
            up = np.arange(0.0, v, 150.0 * h) * s
            vel += [up, np.full(int(6 * np.pi / v / h), v * s), up[::-1], np.zeros(400)]
    w = np.concatenate(vel)
    t = np.arange(w.size) * h
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * h)))
    tau = inertia * np.gradient(w, h) + np.where(w != 0, 0.03 * np.sign(w) + 1e-3 * w, 0.0)
    recorded = np.interp(t - delay, t, tau) + rng.normal(0, 0.002, t.size)
    d = differentiate(t, angle, window=WINDOW)
    rows = np.abs(d.velocity) > 1.0
    assert rows.sum() > 30 * 2000
    est = estimate_motion_delay(
        [t], [d.position], [d.acceleration], [recorded], [rows], [], window=WINDOW,
        max_rows=2000,
    )  # fmt: skip
    # the grid's step is 12.5 ms, refined by a parabola: within 2 ms (4 samples)
    assert est.significant
    assert_allclose(est.delay, delay, atol=0.002)
