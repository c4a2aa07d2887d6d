"""Planar 2R kinematics: round trips, finite differences, and Eq 3 of Simpson, Cook & Li."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from torquemap.kinematics import (
    force_from_joint_torque,
    forward_kinematics,
    inverse_kinematics,
    jacobian,
    joint_torque_from_force,
)

LINKS = (0.25, 0.20)
angle = st.floats(-np.pi, np.pi)
elbow = st.floats(0.1, np.pi - 0.1)  # |sin q2| >= 0.0998: away from both singularities
newtons = st.floats(-50.0, 50.0)


@settings(max_examples=200, deadline=None)
@given(q1=angle, q2=elbow, sign=st.sampled_from([1, -1]))
def test_inverse_kinematics_inverts_forward(q1: float, q2: float, sign: int) -> None:
    q = np.array([q1, sign * q2])
    p = forward_kinematics(q, LINKS)
    back = inverse_kinematics(p, LINKS, elbow=sign)
    # Same pose up to 2 pi on q1; arccos near its ends loses ~sqrt(eps) -> 1e-7 rad.
    assert_allclose(np.angle(np.exp(1j * (back - q))), 0.0, atol=1e-6)
    assert_allclose(forward_kinematics(back, LINKS), p, atol=1e-12)


def test_inverse_kinematics_out_of_reach() -> None:
    with pytest.raises(ValueError, match="out of reach"):
        inverse_kinematics([0.5, 0.0], LINKS)
    with pytest.raises(ValueError, match="out of reach"):
        inverse_kinematics([0.01, 0.0], LINKS)


def test_forward_kinematics_is_eq_2() -> None:
    qa, qb = 0.3, 1.1
    ra, rb = LINKS
    expected = [
        ra * np.cos(qa) + rb * np.cos(qa + qb),
        ra * np.sin(qa) + rb * np.sin(qa + qb),
    ]
    assert_allclose(forward_kinematics([qa, qb], LINKS), expected, rtol=1e-15)


@settings(max_examples=50, deadline=None)
@given(q1=angle, q2=angle)
def test_jacobian_matches_central_differences(q1: float, q2: float) -> None:
    q = np.array([q1, q2])
    h = 1e-6
    fd = np.stack(
        [
            (forward_kinematics(q + h * e, LINKS) - forward_kinematics(q - h * e, LINKS)) / (2 * h)
            for e in np.eye(2)
        ],
        axis=-1,
    )
    # Central differences: truncation ~h^2 * 0.45 m, rounding ~eps * 0.45 / h: both < 1e-9.
    assert_allclose(jacobian(q, LINKS), fd, atol=1e-9)


@settings(max_examples=50, deadline=None)
@given(q1=angle, q2=angle, fx=newtons, fy=newtons)
def test_eq3_matrix_is_the_jacobian_transpose(q1: float, q2: float, fx: float, fy: float) -> None:
    x, y = forward_kinematics([q1, q2], LINKS)
    rb = LINKS[1]
    eq3 = np.array([[-y, x], [-rb * np.sin(q1 + q2), rb * np.cos(q1 + q2)]])
    # Simpson et al. state Eq 3 with clockwise positive, yet its matrix is J^T exactly for
    # counter-clockwise angles and torques: the two conventions agree term by term.
    assert_allclose(eq3, jacobian([q1, q2], LINKS).T, atol=1e-15)
    assert_allclose(joint_torque_from_force([q1, q2], [fx, fy], LINKS), eq3 @ [fx, fy], atol=1e-12)


def test_joint_torque_from_force_vectorised_and_by_hand() -> None:
    # Arm straight along x, pulling +y with 1 N: tau = (l1 + l2, l2) N m.
    assert_allclose(joint_torque_from_force([0.0, 0.0], [0.0, 1.0], LINKS), [0.45, 0.20])
    q = np.random.default_rng(0).uniform(-3, 3, size=(10, 2))
    f = np.random.default_rng(1).normal(size=(10, 2))
    one_by_one = [joint_torque_from_force(qi, fi, LINKS) for qi, fi in zip(q, f, strict=True)]
    assert_allclose(joint_torque_from_force(q, f, LINKS), one_by_one, rtol=1e-14)


@settings(max_examples=200, deadline=None)
@given(q1=angle, q2=elbow, sign=st.sampled_from([1, -1]), fx=newtons, fy=newtons)
def test_force_from_joint_torque_inverts(
    q1: float, q2: float, sign: int, fx: float, fy: float
) -> None:
    q = np.array([[q1, sign * q2]])
    tau = joint_torque_from_force(q, [[fx, fy]], LINKS)
    r = force_from_joint_torque(q, tau, LINKS)
    assert not r.singular[0]
    # cond(J^T) <= ~ (l1 + l2)^2 / (l1 l2 |sin q2|) ~ 40: a 2x2 solve loses < 1e-13 N here.
    assert_allclose(r.force[0], [fx, fy], atol=1e-9)


def test_singular_flag_near_straight_and_folded_arm() -> None:
    q = np.array([[0.3, 0.0], [0.3, 0.01], [0.3, np.pi - 0.01], [0.3, 0.06], [0.3, 1.0]])
    r = force_from_joint_torque(q, np.ones((5, 2)), LINKS)
    assert r.singular.tolist() == [True, True, True, False, False]
    assert np.all(np.isnan(r.force[:3]))
    assert np.all(np.isfinite(r.force[3:]))
    strict = force_from_joint_torque(q, np.ones((5, 2)), LINKS, min_sin_elbow=0.5)
    assert strict.singular.tolist() == [True, True, True, True, False]


def test_shape_errors() -> None:
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 2\)"):
        forward_kinematics([0.1, 0.2, 0.3], LINKS)
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 2\)"):
        jacobian(np.zeros((4, 3)), LINKS)


def test_force_map_inverts_the_jacobian_transpose() -> None:
    # A = J^-T: A @ J^T is the identity, A @ tau is the force of Cramer's rule, and the
    # singular poses are the same (NaN rows)
    from torquemap.kinematics import force_from_joint_torque, force_map, jacobian

    rng = np.random.default_rng(3)
    q = rng.uniform(-3.0, 3.0, (500, 2))
    q[:5, 1] = 0.01  # near the straight arm: singular under the 0.05 guard
    tau = rng.normal(size=(500, 2))
    a, singular = force_map(q, (0.3, 0.2))
    ref = force_from_joint_torque(q, tau, (0.3, 0.2))
    np.testing.assert_array_equal(singular, ref.singular)
    ok = ~singular
    jt = np.swapaxes(jacobian(q, (0.3, 0.2)), 1, 2)
    # the inverse of matrices whose determinant is at least 0.05 l1 l2: 1e-12 is rounding
    np.testing.assert_allclose(
        (a @ jt)[ok], np.broadcast_to(np.eye(2), (ok.sum(), 2, 2)), atol=1e-12
    )
    np.testing.assert_allclose(np.einsum("nij,nj->ni", a, tau)[ok], ref.force[ok], rtol=1e-12)
    assert np.isnan(a[singular]).all()
