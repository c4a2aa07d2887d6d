"""Planar two-link (SCARA A/B) kinematics, Jacobian and the force/torque maps.

Conventions (docs/conventions.md): angles counter-clockwise positive about +z; the external
force ``F`` is exerted BY the environment ON the end effector, in the base frame; the joint-side
external torque is ``tau_ext = J(q)^T F``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


def _q2(joint_angles: ArrayLike) -> NDArray[np.float64]:
    q = np.asarray(joint_angles, dtype=np.float64)
    if q.shape[-1] != 2:
        raise ValueError(f"joint_angles must have shape (..., 2), got {q.shape}")
    return q


def forward_kinematics(
    joint_angles: ArrayLike, link_lengths: tuple[float, float]
) -> NDArray[np.float64]:
    """End-effector position of a planar 2R arm (Eq 2 of Simpson, Cook & Li).

    Parameters
    ----------
    joint_angles
        Joint angles ``(q1, q2)`` [rad], shape (..., 2).
    link_lengths
        ``(l1, l2)`` [m].

    Returns
    -------
    ndarray
        ``(x, y)`` [m], shape (..., 2).

    Notes
    -----
    x = l1 cos q1 + l2 cos(q1 + q2), y = l1 sin q1 + l2 sin(q1 + q2).

    Examples
    --------
    >>> forward_kinematics([0.0, np.pi / 2], (0.3, 0.2)).round(6)
    array([0.3, 0.2])
    """
    q = _q2(joint_angles)
    l1, l2 = link_lengths
    q12 = q[..., 0] + q[..., 1]
    x = l1 * np.cos(q[..., 0]) + l2 * np.cos(q12)
    y = l1 * np.sin(q[..., 0]) + l2 * np.sin(q12)
    return np.stack([x, y], axis=-1)


def jacobian(joint_angles: ArrayLike, link_lengths: tuple[float, float]) -> NDArray[np.float64]:
    """Jacobian d(x, y)/d(q1, q2) of a planar 2R arm.

    Parameters
    ----------
    joint_angles
        Joint angles [rad], shape (..., 2).
    link_lengths
        ``(l1, l2)`` [m].

    Returns
    -------
    ndarray
        Shape (..., 2, 2), rows (x, y), columns (q1, q2) [m / rad].

    Examples
    --------
    >>> jacobian([0.0, 0.0], (1.0, 1.0)) + 0.0
    array([[0., 0.],
           [2., 1.]])
    """
    q = _q2(joint_angles)
    l1, l2 = link_lengths
    q12 = q[..., 0] + q[..., 1]
    s1, c1 = np.sin(q[..., 0]), np.cos(q[..., 0])
    s12, c12 = np.sin(q12), np.cos(q12)
    out = np.empty((*q.shape[:-1], 2, 2))
    out[..., 0, 0] = -l1 * s1 - l2 * s12
    out[..., 0, 1] = -l2 * s12
    out[..., 1, 0] = l1 * c1 + l2 * c12
    out[..., 1, 1] = l2 * c12
    return out


def joint_torque_from_force(
    joint_angles: ArrayLike, force: ArrayLike, link_lengths: tuple[float, float]
) -> NDArray[np.float64]:
    """Joint-side torques that an end-effector force produces, ``tau = J(q)^T F``.

    Parameters
    ----------
    joint_angles
        Joint angles [rad], shape (..., 2).
    force
        Force on the end effector [N], base frame, shape (..., 2).
    link_lengths
        ``(l1, l2)`` [m].

    Returns
    -------
    ndarray
        Joint torques [N m], shape (..., 2), counter-clockwise positive.

    Notes
    -----
    Equals Eq 3 of Simpson, Cook & Li: its matrix ``[[-y, x], [-r_b sin(qa+qb),
    r_b cos(qa+qb)]]`` is ``J(q)^T``.

    Examples
    --------
    >>> joint_torque_from_force([0.0, 0.0], [0.0, 1.0], (1.0, 1.0))
    array([2., 1.])
    """
    J = jacobian(joint_angles, link_lengths)
    F = np.asarray(force, dtype=np.float64)
    tau: NDArray[np.float64] = np.einsum("...ji,...j->...i", J, F)
    return tau


@dataclass(frozen=True, slots=True, eq=False)
class ForceFromTorque:
    """Cartesian force recovered from joint torques.

    Attributes
    ----------
    force
        Force on the end effector [N], base frame, shape (n, 2); NaN where ``singular``.
    singular
        True where the pose is too close to a singularity to invert ``J^T``, shape (n,).
    """

    force: NDArray[np.float64]
    singular: NDArray[np.bool_]


def force_from_joint_torque(
    joint_angles: ArrayLike,
    joint_torque: ArrayLike,
    link_lengths: tuple[float, float],
    *,
    min_sin_elbow: float = 0.05,
) -> ForceFromTorque:
    """End-effector force from joint-side torques, ``F = J(q)^-T tau``, guarded near singularities.

    Parameters
    ----------
    joint_angles
        Joint angles [rad], shape (n, 2).
    joint_torque
        Joint-side torques [N m], shape (n, 2).
    link_lengths
        ``(l1, l2)`` [m].
    min_sin_elbow
        Poses with ``|sin q2|`` below this are flagged singular [-]. ``det J = l1 l2 sin q2``,
        so the force error per torque error grows as ``1 / |sin q2|``.

    Returns
    -------
    ForceFromTorque
        Force [N] and the singular flag.

    Examples
    --------
    >>> r = force_from_joint_torque([[0.0, 1.0]], [[0.5, 0.2]], (0.3, 0.2))
    >>> bool(r.singular[0])
    False
    """
    q = np.atleast_2d(_q2(joint_angles))
    tau = np.atleast_2d(np.asarray(joint_torque, dtype=np.float64))
    # J^T F = tau by Cramer's rule, det J = l1 l2 sin q2 (batched linalg.solve costs 10x more):
    # with J = [[a, b], [c, d]], F = [d t0 - c t1, a t1 - b t0] / det
    a, b, c, d, inv_det, singular = _cramer(q, link_lengths, min_sin_elbow)
    force = np.empty_like(tau)
    force[:, 0] = (d * tau[:, 0] - c * tau[:, 1]) * inv_det
    force[:, 1] = (a * tau[:, 1] - b * tau[:, 0]) * inv_det
    return ForceFromTorque(force=force, singular=singular)


def _cramer(
    q: NDArray[np.float64], link_lengths: tuple[float, float], min_sin_elbow: float
) -> tuple[
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.bool_],
]:
    """``J = [[a, b], [c, d]]``, ``1 / det J`` (NaN where singular) and the singular mask."""
    l1, l2 = link_lengths
    singular = np.abs(np.sin(q[:, 1])) < min_sin_elbow
    q12 = q[:, 0] + q[:, 1]
    s12, c12 = np.sin(q12), np.cos(q12)
    a = -l1 * np.sin(q[:, 0]) - l2 * s12
    c = l1 * np.cos(q[:, 0]) + l2 * c12
    b, d = -l2 * s12, l2 * c12
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_det = np.asarray(np.where(singular, np.nan, 1.0 / (a * d - b * c)), dtype=np.float64)
    return a, b, c, d, inv_det, np.asarray(singular, dtype=np.bool_)


def force_map(
    joint_angles: ArrayLike, link_lengths: tuple[float, float], *, min_sin_elbow: float = 0.05
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The matrix ``J(q)^-T`` that maps joint torques to the end-effector force, per sample.

    The same closed form as :func:`force_from_joint_torque` (Cramer's rule, five sines and
    cosines per sample), as a matrix: for a force and its standard deviation from one set of
    sines, ``F = A tau`` and ``var F_i = sum_j A_ij^2 var tau_j``.

    Parameters
    ----------
    joint_angles
        Joint angles [rad], shape (n, 2).
    link_lengths
        ``(l1, l2)`` [m].
    min_sin_elbow
        Poses with ``|sin q2|`` below this are singular (their rows NaN).

    Returns
    -------
    (A, singular)
        ``A`` [1/m], shape (n, 2, 2), rows (fx, fy), columns (tau1, tau2); ``singular``,
        shape (n,).

    Examples
    --------
    >>> a, singular = force_map([[0.0, 1.0]], (0.3, 0.2))
    >>> f = force_from_joint_torque([[0.0, 1.0]], [[0.5, 0.2]], (0.3, 0.2)).force
    >>> bool(np.allclose(a[0] @ [0.5, 0.2], f[0]))
    True
    """
    q = np.atleast_2d(_q2(joint_angles))
    a, b, c, d, inv_det, singular = _cramer(q, link_lengths, min_sin_elbow)
    out = np.empty((q.shape[0], 2, 2))
    out[:, 0, 0] = d * inv_det
    out[:, 0, 1] = -c * inv_det
    out[:, 1, 0] = -b * inv_det
    out[:, 1, 1] = a * inv_det
    return out, singular


def force_and_sigma(
    joint_angles: ArrayLike,
    joint_torque: ArrayLike,
    torque_sigma: ArrayLike,
    link_lengths: tuple[float, float],
    *,
    min_sin_elbow: float = 0.05,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """The force ``F = J(q)^-T tau``, the singular mask and the force's standard deviation.

    :func:`force_map`'s ``A`` applied to the torques (NaN taken as 0) and to their standard
    deviations (``sigma F_i = sqrt(sum_j A_ij^2 sigma_j^2)``, independent joints), in one
    compiled pass (:func:`torquemap._kernels.planar_force`, five sines and cosines per
    sample and no temporary of the log's size).

    Parameters
    ----------
    joint_angles
        Joint angles [rad], shape (n, 2).
    joint_torque
        Joint-side torques [N m], shape (n, 2).
    torque_sigma
        Their standard deviations [N m], shape (n, 2).
    link_lengths
        ``(l1, l2)`` [m].
    min_sin_elbow
        Poses with ``|sin q2|`` below this are singular (force and sigma NaN).

    Returns
    -------
    (force, singular, sigma)
        Force [N], shape (n, 2); singular mask, shape (n,); sigma [N], shape (n, 2).

    Examples
    --------
    >>> f, singular, s = force_and_sigma([[0.0, 1.0]], [[0.5, 0.2]], [[0.1, 0.1]], (0.3, 0.2))
    >>> a, _ = force_map([[0.0, 1.0]], (0.3, 0.2))
    >>> bool(np.allclose(f[0], a[0] @ [0.5, 0.2]) and np.allclose(s[0], np.sqrt(a[0]**2 @ [0.01, 0.01])))
    True
    """
    from torquemap._kernels import planar_force

    q = np.ascontiguousarray(np.atleast_2d(_q2(joint_angles)), dtype=np.float64)
    tau = np.ascontiguousarray(np.atleast_2d(np.asarray(joint_torque)), dtype=np.float64)
    sig = np.ascontiguousarray(np.atleast_2d(np.asarray(torque_sigma)), dtype=np.float64)
    n = q.shape[0]
    force, sigma = np.empty((n, 2)), np.empty((n, 2))
    singular = np.empty(n, dtype=np.bool_)
    l1, l2 = (float(v) for v in link_lengths)
    planar_force(q, tau, sig, l1, l2, float(min_sin_elbow), force, sigma, singular)
    return force, singular, sigma


def inverse_kinematics(
    position: ArrayLike, link_lengths: tuple[float, float], *, elbow: int = 1
) -> NDArray[np.float64]:
    """Joint angles reaching ``position`` [m]; ``elbow=+1`` gives q2 > 0 (elbow left).

    Raises ValueError when a point is out of reach.

    Examples
    --------
    >>> q = inverse_kinematics([0.3, 0.2], (0.3, 0.2))
    >>> forward_kinematics(q, (0.3, 0.2)).round(6)
    array([0.3, 0.2])
    """
    p = np.asarray(position, dtype=np.float64)
    l1, l2 = link_lengths
    r2 = p[..., 0] ** 2 + p[..., 1] ** 2
    c2 = (r2 - l1**2 - l2**2) / (2 * l1 * l2)
    if np.any(np.abs(c2) > 1 + 1e-12):
        raise ValueError("point out of reach")
    q2 = elbow * np.arccos(np.clip(c2, -1.0, 1.0))
    q1 = np.arctan2(p[..., 1], p[..., 0]) - np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))
    return np.stack([q1, q2], axis=-1)
