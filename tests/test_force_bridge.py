"""Bridging in force space (F42): a known smooth Cartesian force on a simulated 2-link pose path
with one joint's torque masked, recovered by :func:`torquemap.estimate.force_space_bridge`
against the joint-torque line of :func:`torquemap.estimate.bridge_gaps`."""

from __future__ import annotations

import numpy as np
import pytest

from torquemap.estimate import bridge_gaps, force_space_bridge
from torquemap.kinematics import jacobian

LINKS = (0.3, 0.25)


def _path() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """1 kHz, 2 s: the arm sweeps 3 rad at the shoulder, the elbow bends: J turns."""
    t = np.arange(0.0, 2.0, 1e-3)
    q = np.column_stack([0.3 + 1.5 * t, 1.2 + 0.5 * np.sin(2.0 * t)])
    return t, q, jacobian(q, LINKS)


def _joint_line(t, jac, tau, mask, support):
    """The joint-space answer: each masked joint's torque a line in time, F = J^-T tau."""
    tau_line = tau.copy()
    for k in range(tau.shape[1]):
        tau_line[:, k] = bridge_gaps(t, tau[:, k], mask[:, k], longest=1.0, support=support)
    return np.linalg.solve(np.swapaxes(jac, 1, 2), tau_line[..., None])[..., 0]


def _case(force: np.ndarray, joints: list[int]):
    t, _q, jac = _path()
    tau = np.einsum("nij,ni->nj", jac, force)  # tau = J^T F
    mask = np.zeros(tau.shape, dtype=bool)
    run = (t >= 0.8) & (t < 1.3)  # 0.5 s, the shoulder turns 0.75 rad under it
    for k in joints:
        mask[run, k] = True
    spoiled = force.copy()
    spoiled[run] = 50.0  # what the answered joints alone cannot say: replaced
    support = 0.05
    fs = force_space_bridge(t, jac, spoiled, tau, mask, longest=1.0, support=support)
    js = _joint_line(t, jac, tau, mask, support)
    err = lambda f: float(np.max(np.linalg.norm(f[run] - force[run], axis=1)))  # noqa: E731
    return err(fs), err(js)


@pytest.mark.parametrize(("joint", "off"), [(0, 0.015), (1, 0.1)])
def test_linear_force_one_joint_masked_is_exact(joint: int, off: float) -> None:
    # a force linear in time: the Cartesian line between the window means is exact (a linear
    # function's mean over a window is its value at the window's mean time), the correction
    # along the answered joint is then zero; the joint line misses J's turn (by 0.018 N with
    # the shoulder masked, 0.12 N with the elbow, under a 2.2 N force)
    force = np.column_stack([1.0 + 0.5 * _path()[0], -2.0 + 0.3 * _path()[0]])
    fs, js = _case(force, [joint])
    assert fs < 1e-9
    assert js > off


def test_both_joints_masked_gives_the_cartesian_line() -> None:
    force = np.column_stack([1.0 + 0.5 * _path()[0], -2.0 + 0.3 * _path()[0]])
    fs, js = _case(force, [0, 1])
    assert fs < 1e-9
    assert js > 0.05


def test_curved_force_within_the_line_bound_and_better_than_the_joint_line() -> None:
    # F'' bounded by M: a line through window means is off by at most M (T + w)^2 / 8 + M w^2 / 6
    # (T the run, w the window); the correction only removes the part joint b observes
    t = _path()[0]
    force = np.column_stack([1.0 + 0.4 * np.sin(3.0 * t), -2.0 + 0.3 * np.cos(2.0 * t)])
    m = np.hypot(0.4 * 9.0, 0.3 * 4.0)
    bound = m * (0.5 + 0.05) ** 2 / 8 + m * 0.05**2 / 6
    fs, js = _case(force, [0])
    assert fs <= bound
    assert fs < 0.5 * js


def test_two_answered_joints_give_the_force_back_and_one_gives_its_projection() -> None:
    # three joints on a planar force (a redundant arm): with two joints answered the force is
    # fixed by J^T F = tau alone (the batched pseudo-inverse), whatever the line; with one, the
    # line's error survives only across that joint's row of J^T (a closed form)
    rng = np.random.default_rng(4)
    n = 40
    t = np.arange(n) * 0.01
    jac = rng.normal(size=(n, 2, 3))
    f = np.column_stack([np.sin(t), 2.0 + t])
    tau = np.einsum("nij,ni->nj", jac, f)
    mask = np.zeros((n, 3), bool)
    mask[10:20, 0] = True
    mask[20:30, :2] = True
    wrong = f.copy()
    wrong[10:30] += 5.0
    got = force_space_bridge(t, jac, wrong, tau, mask, longest=1.0, support=0.05)
    np.testing.assert_allclose(got[:20], f[:20], atol=1e-9)  # joints 1 and 2 answered
    line = force_space_bridge(
        t, jac, wrong, np.full_like(tau, np.nan), mask, longest=1.0, support=0.05
    )
    row = jac[20:30, :, 2]  # joint 2 alone answered: the error left is orthogonal to its row
    err = got[20:30] - f[20:30]
    np.testing.assert_allclose(np.einsum("ka,ka->k", row, err), 0.0, atol=1e-9)
    start = line[20:30] - f[20:30]
    removed = np.einsum("ka,ka->k", row, start) / np.einsum("ka,ka->k", row, row)
    np.testing.assert_allclose(err, start - row * removed[:, None], atol=1e-9)
    assert np.allclose(got[30:], f[30:]) and np.allclose(got[:10], f[:10])


def test_the_logs_ends_hold_the_one_sides_force_only_when_asked() -> None:
    # a constant force, joint 0 bridged over the first 10 samples: held from the samples after
    # (corrected along joint 1's row, here exact), and left alone unless ends=True
    n = 30
    t = np.arange(n) * 0.01
    c, s = np.cos(0.1 * t), np.sin(0.1 * t)
    jac = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], 1)
    f = np.tile([1.0, -2.0], (n, 1))
    tau = np.einsum("nij,ni->nj", jac, f)
    mask = np.zeros((n, 2), bool)
    mask[:10, 0] = True
    wrong = f.copy()
    wrong[:10] = 7.0
    kept = force_space_bridge(t, jac, wrong, tau, mask, longest=1.0, support=0.05)
    np.testing.assert_array_equal(kept, wrong)
    held = force_space_bridge(t, jac, wrong, tau, mask, longest=1.0, support=0.05, ends=True)
    np.testing.assert_allclose(held, f, atol=1e-12)
