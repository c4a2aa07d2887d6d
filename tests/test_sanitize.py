"""Logs as real controllers write them: repeated stamps, implausible samples, gaps (issues 12, 15)."""

from __future__ import annotations

import dataclasses

import numpy as np

from torquemap.io import Log
from torquemap.sanitize import implausible_samples, max_gap_for, sanitize_log


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
    assert any("repeat" in w for w in clean.warnings)
    assert any("gaps in time" in w for w in clean.warnings)


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
