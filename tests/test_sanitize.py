"""Logs as real controllers write them: repeated stamps, implausible samples, gaps (issues 12, 15)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.ndimage import median_filter

from torquemap.io import Log
from torquemap.sanitize import (
    JUMP_FACTOR,
    MEDIAN_SPAN,
    SPIKE_SIGMAS,
    angle_jumps,
    implausible_samples,
    max_gap_for,
    sanitize_log,
    top_percentile,
)


def _log(t: np.ndarray, q: np.ndarray, tau: np.ndarray) -> Log:
    return Log(t=t, q=q[:, None], motor_torque=tau[:, None], joint_names=("m",), path="x.csv")


def test_wild_values_are_found_and_only_they() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 5.0, 1e-3)
    tau = 0.05 * np.sign(np.sin(2.0 * t)) + rng.normal(0.0, 0.01, t.size)  # steps stay sound
    for wild in (1e300, 1e6, -30.0):
        x = tau.copy()
        x[1234] = wild
        assert np.flatnonzero(implausible_samples(x)).tolist() == [1234]
    assert not implausible_samples(tau).any()
    # an encoder: quantised, moving by whole counts, one glitch of a few thousand counts
    q = np.round(40.0 * np.sin(t) * 1000.0) / 1000.0
    q[300] += 5.0
    assert np.flatnonzero(implausible_samples(q)).tolist() == [300]


def test_repeated_stamps_dropped_gaps_cut_and_values_bridged() -> None:
    t = np.arange(0.0, 4.0, 1e-3)
    t = np.concatenate((t[:1000], t[999:2000], t[2000:] + 1000.0))  # one repeat, one 1000 s gap
    q = 0.1 * t
    tau = np.cos(t)
    tau[2500] = 1e6
    clean = sanitize_log(_log(t, q, tau), window=0.05)
    assert clean.repeated.sum() == 1 and clean.repeated[1000]
    assert clean.implausible.sum() == 1 and clean.implausible[2500]
    assert len(clean.pieces) == 2
    assert clean.gaps[0][1] - clean.gaps[0][0] > 1000 - 1e-6
    second = clean.pieces[1]
    k = int(np.flatnonzero(second.rows == 2500)[0])
    # the wild value is replaced by the line between its neighbours
    assert abs(second.log.motor_torque[k, 0] - np.cos(t[2500])) < 1e-5
    assert all(np.all(np.diff(p.log.t) > 0) for p in clean.pieces)
    assert (
        "1 sample repeats the previous time stamp (first at t = 0.999 s): dropped" in clean.warnings
    )
    assert any("gaps in time" in w for w in clean.warnings)


def test_bridging_leaves_the_log_as_read_and_a_sound_log_is_not_copied() -> None:
    t = np.arange(0.0, 4.0, 1e-3)
    q, tau = 0.1 * t, np.cos(t)
    wild = tau.copy()
    wild[2500] = 1e6
    log = _log(t, q, wild)
    clean = sanitize_log(log, window=0.05)
    assert clean.implausible[2500] and abs(clean.pieces[0].log.motor_torque[2500, 0]) < 1.0
    # the bridged channel is a copy: the caller's log keeps its wild value
    assert log.motor_torque[2500, 0] == 1e6
    # nothing bridged: the pieces read the log's own arrays (no copy of the whole log)
    sound = _log(t, q, tau)
    piece = sanitize_log(sound, window=0.05).pieces[0].log
    assert np.shares_memory(piece.q, sound.q)
    assert np.shares_memory(piece.motor_torque, sound.motor_torque)


def test_gaps_the_filters_bridge_do_not_cut() -> None:
    # a host poll at ~300 Hz with gaps of 20 to 100 ms: within what a 0.05 s window bridges
    rng = np.random.default_rng(1)
    steps = rng.uniform(2.5e-3, 4.5e-3, 3000)
    steps[rng.choice(steps.size, 40, replace=False)] = rng.uniform(0.02, 0.1, 40)
    t = np.cumsum(steps)
    clean = sanitize_log(_log(t, 0.1 * t, np.sin(t)), window=0.05)
    assert max_gap_for(0.05) >= 0.1
    assert len(clean.pieces) == 1 and not clean.unprocessed.any()


def test_a_persistent_angle_jump_cuts_the_log() -> None:
    # an angle that jumps by 0.4 rad in 1 ms and stays (an encoder re-zeroing) while the arm
    # moves at most 0.6 rad/s: cut there, the sample after the jump flagged
    t = np.arange(3000) * 1e-3
    q = np.c_[0.2 * np.sin(3.0 * t), 0.1 * np.cos(2.0 * t)]
    q[1700:, 1] += 0.4
    log = Log(t=t, q=q, motor_torque=np.zeros_like(q), joint_names=("a", "b"), path="j.csv")
    clean = sanitize_log(log, window=0.05)
    assert len(clean.pieces) == 2
    assert clean.pieces[1].rows[0] == 1700
    assert np.flatnonzero(clean.implausible).tolist() == [1700]
    assert any("jumps" in w and "joint b" in w for w in clean.warnings)
    # the same motion with a gap in time of 80 ms (the arm moves on at its speed) is no jump
    gap = np.r_[t[:1700], t[1700:] + 0.08]
    moved = np.c_[0.2 * np.sin(3.0 * gap), 0.1 * np.cos(2.0 * gap)]
    quiet = sanitize_log(dataclasses.replace(log, t=gap, q=moved), window=0.05)
    assert not quiet.implausible.any() and len(quiet.pieces) == 1


def _implausible_everywhere(x: np.ndarray, span: int = MEDIAN_SPAN) -> np.ndarray:
    """The rule of :func:`implausible_samples` with the running median of every sample (the
    implementation before the cheap pre-test): the reference the fast path must equal."""
    u = x / np.max(np.abs(x))
    med = median_filter(u, size=span, mode="nearest")
    dev = np.abs(u - med)
    du = np.abs(np.diff(u))
    moves = du[du > 0]
    typical = float(np.median(moves)) if moves.size else 0.0
    step = float(np.percentile(np.abs(np.diff(med)), 99))
    floor = max(SPIKE_SIGMAS * 1.4826 * float(np.median(dev)), 10 * step, 10 * typical, 1e-12)
    bad = dev > floor
    return np.zeros(x.size, bool) if bad.mean() > 0.2 else bad


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    tail=st.sampled_from([0.0, 1.0, 3.0]),
    spikes=st.integers(0, 5),
    quantum=st.sampled_from([0.0, 1e-3]),
    span=st.sampled_from([3, 5, 7, MEDIAN_SPAN]),
)
def test_the_cheap_pretest_changes_no_answer(
    seed: int, tail: float, spikes: int, quantum: float, span: int
) -> None:
    # smooth motion, Gaussian or heavy-tailed (Student t) noise, spikes of every size, with
    # and without encoder quantisation: the same samples as the running median everywhere
    rng = np.random.default_rng(seed)
    n = 3000
    t = np.arange(n) * 1e-3
    x = np.sin(3.0 * t) + 0.3 * np.sign(np.sin(0.7 * t))
    noise = rng.standard_t(tail, n) if tail else rng.normal(size=n)
    x = x + 0.01 * noise
    if quantum:
        x = np.round(x / quantum) * quantum
    x[rng.integers(0, n, spikes)] += rng.choice([-1.0, 1.0], spikes) * 10.0 ** rng.uniform(
        -2, 3, spikes
    )
    np.testing.assert_array_equal(
        implausible_samples(x, span=span), _implausible_everywhere(x, span)
    )


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    spikes=st.integers(0, 5),
    quantum=st.sampled_from([0.0, 1e-4, 1e-2]),
    noise=st.sampled_from([0.0, 1e-5, 1e-3]),
    span=st.sampled_from([3, 5, 7, MEDIAN_SPAN]),
)
def test_fast_ramps_change_no_answer(
    seed: int, spikes: int, quantum: float, noise: float, span: int
) -> None:
    # an angle swept fast and slow, both ways, with reversals, holds, re-zeroings and spikes:
    # every ramp sample is far from its neighbours (the pre-test's suspects), most windows are
    # monotone (their median is the sample itself); the same samples as the running median
    # everywhere
    rng = np.random.default_rng(seed)
    n = 4000
    speed = np.repeat(rng.choice([-40.0, -3.0, 0.0, 0.5, 8.0, 60.0], 8), n // 8)
    x = np.cumsum(speed) * 1e-3 + noise * rng.normal(size=n)
    x[int(rng.integers(1, n)) :] -= rng.uniform(0.5, 3.0)
    if quantum:
        x = np.round(x / quantum) * quantum
    x[rng.integers(0, n, spikes)] += rng.choice([-1.0, 1.0], spikes) * 10.0 ** rng.uniform(
        -3, 1, spikes
    )
    np.testing.assert_array_equal(
        implausible_samples(x, span=span), _implausible_everywhere(x, span)
    )


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    jumps=st.integers(0, 4),
    quantised=st.booleans(),
    smooth=st.booleans(),
)
def test_the_jump_pretest_changes_no_answer(
    seed: int, jumps: int, quantised: bool, smooth: bool
) -> None:
    # the percentiles computed always (the implementation before the pre-test) as reference
    rng = np.random.default_rng(seed)
    n = int(rng.integers(9, 600))
    t = np.cumsum(rng.uniform(0.5, 1.5, n)) * 1e-3
    q = np.sin(t * rng.uniform(1, 50)) if smooth else np.cumsum(rng.choice([0, 1, 2], n) * 1e-3)
    for _ in range(jumps):
        q[int(rng.integers(1, n)) :] += rng.uniform(-1, 1) * 10 ** rng.uniform(-4, 1)
    if quantised:
        q = np.round(q * 100) / 100
    dq, dt = np.abs(np.diff(q)), np.diff(t)
    top = JUMP_FACTOR * max(float(np.percentile(dq, 99)), 1e-12)
    fast = JUMP_FACTOR * max(float(np.percentile(dq / dt, 99)), 1e-12)
    jump = (dq > top) & (dq / dt > fast)
    expected = np.zeros(n, dtype=bool)
    if jump.mean() <= 0.005:
        expected[1:] = jump
    np.testing.assert_array_equal(angle_jumps(t, q), expected)


def _ramped_torque(rate: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A motor torque with the inertia pulses of 14 ms speed ramps (J a while accelerating,
    30 times the noise) between friction levels, sampled at ``rate`` [Hz] with 20 % jitter."""
    t = np.arange(0.0, 6.0, 1.0 / rate)
    t = t + rng.uniform(-0.2, 0.2, t.size) / rate
    tau = 0.05 * np.sign(np.sin(2.0 * t)) + rng.normal(0.0, 0.003, t.size)
    for start in (0.6, 2.1, 3.7, 5.2):  # each ramp: 14 ms of acceleration torque
        tau[(t >= start) & (t < start + 0.014)] += 0.19
    return t, tau


def test_a_ramp_is_judged_in_time_not_in_samples() -> None:
    # the same physical motion (14 ms acceleration pulses, a real torque) at 281 Hz (4 samples
    # each) and at 2 kHz (28 samples): no sample of either is implausible; before, the running
    # median of 9 samples removed the 4-sample pulses at 281 Hz and they were flagged (random
    # SCARA 104's sweep). A single wild value is still found at both rates.
    for rate in (281.0, 2000.0):
        t, tau = _ramped_torque(rate, np.random.default_rng(int(rate)))
        log = _log(t, 0.1 * t, tau)
        clean = sanitize_log(log, window=0.05)
        assert not clean.implausible.any(), (rate, clean.warnings)
        wild = tau.copy()
        wild[t.size // 3] = 5.0
        found = sanitize_log(_log(t, 0.1 * t, wild), window=0.05)
        assert np.flatnonzero(found.implausible).tolist() == [t.size // 3]


@pytest.mark.parametrize("seed", range(6))
def test_top_percentile_is_numpy_percentile_bit_for_bit(seed: int) -> None:
    # second algorithm: numpy's own percentile (a selection among every value)
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4096, 300_000))
    steps = np.abs(np.diff(np.cumsum(rng.standard_normal(n + 1))))
    steps[rng.integers(0, n, 40)] = 50.0  # jumps, as at a re-zeroing
    quantised = np.round(rng.exponential(size=n) * 3) / 7  # ties, many equal values
    for x in (steps, quantised, np.zeros(n)):
        for q in (50.0, 95.0, 99.0, 99.9, 100.0):
            assert top_percentile(x, q) == np.percentile(x, q)
    with_nan = steps.copy()
    with_nan[7] = np.nan
    assert np.isnan(top_percentile(with_nan, 99.0))


def test_an_angle_wrapped_to_one_turn_is_named() -> None:
    # a continuous joint as ROS JointState publishes it, wrapped to (-pi, pi]: each whole-turn
    # jump was "an encoder glitch or re-zeroing?"; a 0.4 rad jump still is
    t = np.arange(6000) * 1e-3
    q = np.c_[np.pi - 0.5 + 0.3 * t, 0.1 * np.cos(2.0 * t)]
    q[:, 0] = (q[:, 0] + np.pi) % (2 * np.pi) - np.pi
    log = Log(t=t, q=q, motor_torque=np.zeros_like(q), joint_names=("a", "b"), path="w.csv")
    clean = sanitize_log(log, window=0.05)
    (note,) = [w for w in clean.warnings if "jumps" in w]
    assert "joint a" in note and "by -6.283 rad): an angle wrapped to one turn" in note
    q[1700:, 1] += 0.4
    clean = sanitize_log(dataclasses.replace(log, q=q), window=0.05)
    (note,) = [w for w in clean.warnings if "jumps" in w and "joint b" in w]
    assert "an encoder glitch or re-zeroing?" in note
