"""Estimation in blocks and streaming (torquemap.stream) against the batch estimator."""

from __future__ import annotations

import dataclasses
import itertools
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import Ran

from torquemap.errors import InputError
from torquemap.estimate import ForceEstimate, ForceEstimator, estimate_forces
from torquemap.io import iter_log_chunks, read_log, read_table
from torquemap.model import Model, load_model
from torquemap.stream import _concatenate, estimate_in_chunks, settling_time

# one worker runs the module, so its module fixtures (the model, the circle, the batch
# estimate) are built once
pytestmark = pytest.mark.xdist_group("stream")


@pytest.fixture(scope="module")
def model(scara_identified: Ran) -> Model:
    return load_model(scara_identified.folder / "bench" / "model.toml")


@pytest.fixture(scope="module")
def circle(scara_bench: Path) -> Path:
    return scara_bench / "circle.csv"


@pytest.fixture(scope="module")
def batch(model: Model, circle: Path) -> ForceEstimate:
    return estimate_forces(model, read_log(circle, model.robot))


def _finite_equal(a: np.ndarray, b: np.ndarray, atol: float) -> None:
    np.testing.assert_array_equal(np.isfinite(a), np.isfinite(b))
    f = np.isfinite(a)
    np.testing.assert_allclose(a[f], b[f], rtol=0, atol=atol)


def test_blocks_equal_the_batch_estimate(model: Model, circle: Path, batch: ForceEstimate) -> None:
    # 62 k samples in blocks of 8000 answered (4 s) read in chunks of 5000 rows: eight block
    # boundaries, none of them a gap
    parts = list(
        estimate_in_chunks(model, iter_log_chunks(circle, model.robot, rows=5000), rows=8000)
    )
    got = _concatenate(parts)
    assert got.t.size == batch.t.size
    np.testing.assert_array_equal(got.t, batch.t)
    np.testing.assert_array_equal(got.flag, batch.flag)
    # equal to rounding: the differentiator's sums run from another first sample, and its
    # acceleration amplifies rounding by 1/h^2 (measured 7e-10 N m; the estimate's own error
    # against the truth is ~1e-2 N m)
    _finite_equal(got.tau_ext, batch.tau_ext, 1e-8)
    assert batch.force is not None and got.force is not None
    _finite_equal(got.force, batch.force, 1e-7)


def test_a_log_within_one_block_is_the_batch_estimate(
    model: Model, circle: Path, batch: ForceEstimate
) -> None:
    (only,) = estimate_in_chunks(model, iter_log_chunks(circle, model.robot, rows=7000))
    np.testing.assert_array_equal(only.tau_ext, batch.tau_ext)
    assert only.warnings == batch.warnings


def test_streaming_agrees_with_the_batch_within_the_noise(
    model: Model, circle: Path, scara_bench: Path, batch: ForceEstimate
) -> None:
    log = read_log(circle, model.robot)
    est = ForceEstimator(model)
    h = float(np.median(np.diff(log.t)))
    assert est.latency == pytest.approx(
        settling_time(cutoff=2.0, window=est.window, tolerance=1e-6) + 0.25
    )
    parts, lag, held = [], 0.0, 0
    kt = np.array([j.torque_constant for j in model.robot.joints])
    step = 1500  # samples per update (0.75 s): fewer, larger blocks keep the test fast
    for a in range(0, log.t.size, step):
        sl = slice(a, a + step)
        part = est.update(log.t[sl], log.q[sl], log.motor_torque[sl] / kt)
        answered = parts[-1].t[-1] if parts and parts[-1].t.size else log.t[0]
        if part.t.size:
            parts.append(part)
            answered = part.t[-1]
        lag = max(lag, float(log.t[sl][-1] - answered))
        held = max(held, est.buffered)
    parts.append(est.finish())
    got = _concatenate([p for p in parts if p.t.size])
    np.testing.assert_array_equal(got.t, log.t)
    # the stated latency holds (to the updates' own length), and memory is bounded by it
    assert lag <= est.latency + step * h
    assert held * h <= 2 * est.margin + est.hop + 2 * step * h
    np.testing.assert_array_equal(got.flag, batch.flag)
    truth = read_table(scara_bench / "truth.csv")
    sound = batch.flag == 0
    noise = np.sqrt(np.mean((batch.tau_ext[sound, 1] - truth["tau_ext_b"][sound]) ** 2))
    diff = np.nanmax(np.abs(got.tau_ext - batch.tau_ext))
    # the filters' tail cut at 1e-6 of their input: orders below the estimate's own error
    assert diff < 1e-3 * noise


def test_the_paper_method_and_bad_streams_are_refused(model: Model) -> None:
    with pytest.raises(InputError, match="paper"):
        ForceEstimator(model, method="paper")  # type: ignore[arg-type]
    est = ForceEstimator(model)
    est.update([0.0, 0.001], np.zeros((2, 2)), np.zeros((2, 2)))
    with pytest.raises(InputError, match="backwards"):
        est.update([0.0005], np.zeros(2), np.zeros(2))
    with pytest.raises(InputError, match="one of them"):
        est.update([0.002], np.zeros(2))
    with pytest.raises(InputError, match="shorter"):
        est.finish()  # 1 ms of log: as the batch estimator says


def test_epoch_stamps_give_the_same_answer_at_the_same_cost(model: Model, circle: Path) -> None:
    log = read_log(circle, model.robot)
    n = 20000
    zero = dataclasses.replace(log, t=log.t[:n], q=log.q[:n], motor_torque=log.motor_torque[:n])
    epoch = dataclasses.replace(zero, t=1.7e9 + zero.t)
    past = dataclasses.replace(zero, t=5000.0 + zero.t)
    a = estimate_forces(model, zero)
    for shifted in (epoch, past):
        b = estimate_forces(model, shifted)
        np.testing.assert_array_equal(a.flag, b.flag)
        # same step, same kernels: the answers agree to rounding
        _finite_equal(a.tau_ext, b.tau_ext, 1e-9)
    costs = {}
    for name, which in (("zero", zero), ("epoch", epoch)) * 2:
        t0 = time.process_time()
        estimate_forces(model, which)
        spent = time.process_time() - t0
        costs[name] = min(costs.get(name, np.inf), spent)
    # the old irregular-time path cost 6.5-8.6x; the fast path costs the same, up to the noise
    # of a shared machine
    assert costs["epoch"] < 1.6 * costs["zero"]


def test_the_summary_median_keeps_every_stride_th_value() -> None:
    from torquemap.stream import _Decimated

    values = np.random.default_rng(1).normal(size=10_000)
    keep = _Decimated(cap=1000)
    for a in range(0, values.size, 777):  # uneven parts: the phase must carry over
        keep.add(values[a : a + 777])
    assert keep.stride == 16  # 10000 values into at most 1000: halved four times
    # exactly the median of every 16th value (an independent decimation of the whole)
    assert keep.median() == np.median(values[::16])


def test_the_summary_magnitudes_are_the_kept_values_hypot() -> None:
    # the hypot formed for the kept values only: exactly add() of every value's hypot
    from torquemap.stream import _Decimated

    xy = np.random.default_rng(2).normal(size=(10_000, 2))
    whole, kept = _Decimated(cap=1000), _Decimated(cap=1000)
    for a in range(0, xy.shape[0], 777):
        part = xy[a : a + 777]
        whole.add(np.hypot(part[:, 0], part[:, 1]))
        kept.add_hypot(part[:, 0], part[:, 1])
    assert kept.stride == whole.stride == 16
    assert kept.median() == whole.median()


def _one_motor() -> Model:
    from torquemap.model import model_from_dict

    return model_from_dict(
        {
            "robot": {"kinematics": "none"},
            "joints": {"m": {"gear_ratio": 10, "torque_constant": 0.5}},
        }
    )


@pytest.mark.parametrize("step", [1, 700])
def test_a_gap_longer_than_the_margin_is_flagged_as_in_the_batch(step: int) -> None:
    # a 10 s gap (the logger paused) is longer than the stream's 2.2 s margin, so no block
    # held both of its sides; before: the filters' support next to it was flagged 0 (sound)
    # in the stream and 8 (gap) in the batch, with the same numbers
    from torquemap.io import Log

    m = _one_motor()
    t = np.r_[np.arange(0.0, 6.0, 1e-3), np.arange(16.0, 22.0, 1e-3)]
    rng = np.random.default_rng(0)
    q = np.sin(t)[:, None]
    i = (0.2 + 0.01 * np.sin(3 * t) + rng.normal(0.0, 1e-3, t.size))[:, None]
    batch = estimate_forces(m, Log(t=t, q=q, motor_torque=0.5 * i, joint_names=("m",)))
    assert 0 < np.count_nonzero(batch.flag == 8) < t.size // 4  # the gap's two sides
    est = ForceEstimator(m)
    # updates of `step` rows over the 2 s either side of the gap, 2000 rows elsewhere
    cuts = np.r_[0, 2000, 4000, np.arange(4000, 8000, step), 8000, 10_000, t.size]
    parts = [est.update(t[a:b], q[a:b], i[a:b]) for a, b in itertools.pairwise(cuts)]
    parts.append(est.finish())
    got = _concatenate([p for p in parts if p.t.size])
    np.testing.assert_array_equal(got.t, t)
    np.testing.assert_array_equal(got.flag, batch.flag)
    _finite_equal(got.tau_ext, batch.tau_ext, 1e-6)
    assert any("gaps in time" in w for w in est.warnings)


def test_samples_of_the_wrong_shape_are_named() -> None:
    est = ForceEstimator(_one_motor())
    with pytest.raises(InputError, match=r"i has shape \(3, 1\) for 2 times of 1 joints \(m\)"):
        est.update([0.0, 0.001], np.zeros((2, 1)), np.zeros((3, 1)))
    with pytest.raises(InputError, match=r"q has shape \(2, 2\) for 2 times of 1 joints"):
        est.update([0.0, 0.001], np.zeros((2, 2)), np.zeros((2, 1)))
    assert est.buffered == 0  # nothing half-taken
