"""Identify an arm with rigid-body dynamics from free-motion logs (docs/arm.md).

All joints at once, all samples at once: the motor-side equation of
:mod:`torquemap.arm_model` is linear in the arm's full inertial parameters ``pi`` (ten per
body), each joint's rotor inertia, friction-law parameters and PDTV lines. Only the base
combinations of ``pi`` show in joint torques; the rest are held by a Gaussian prior centred on
the URDF's values (ridge regression toward the prior, a maximum a posteriori estimate), so that

* a short log suffices: what the log does not excite stays at the URDF's value;
* a wrong or missing tool mass is found: the data moves the last bodies' parameters away from
  the prior where it speaks;
* the full parameter vector stays physical (positive masses, positive-definite inertias) unless
  the data insists, which is checked and reported.

Rows are weighted by each joint's residual noise (two passes: the first pass measures it). The
posterior covariance ``(A^T W A + P)^-1`` gives the sigmas of every parameter and, in
estimation, of the external torques.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from torquemap.arm_coarse import coarse_angle_note, output_counts_note
from torquemap.arm_lag import current_lag, lag_message
from torquemap.arm_misfit import (
    explained_share,
    misfit_is_noise,
    net_noise_levels,
    noise_misfit_message,
    upper_split,
)
from torquemap.arm_model import (
    ArmSignals,
    arm_signals,
    column_names,
    joint_columns,
    pdtv_lines,
)
from torquemap.arm_noise import arm_noise_levels, pooled_levels
from torquemap.arm_stribeck import BAND_SIGMAS, STRIBECK_LEVELS, refit_without_stribeck
from torquemap.arm_units import angles_beyond_limits
from torquemap.errors import InputError
from torquemap.friction_law import FrictionLaw, StribeckFriction, coulomb_levels_valid
from torquemap.io import Log
from torquemap.model import InertiaModel, JointModel, Model
from torquemap.robot import Robot
from torquemap.sanitize import max_gap_for, no_stretch_message

PRIOR_MASS_FRACTION = 0.3
"""Prior standard deviation of each body's mass, relative to the URDF's [-] ..."""
PRIOR_MASS_FLOOR = 0.5
"""... plus this [kg]: a tool of the order of a kilogram is not ruled out by the prior."""
PRIOR_LENGTH = 0.1
"""Lever [m] that turns the mass deviation into first-moment deviations [kg m] (plus 30 %)."""
PRIOR_INERTIA_FLOOR = 0.01
"""Absolute floor [kg m^2] of the prior deviation of inertias about the joint (plus 30 %)."""
PRIOR_JOINT = {"armature": 1e-2, "friction": 1.0, "pdtv": 1.0}
"""Weak prior deviations of the joint terms (motor side: kg m^2, N m or N m s/rad, N m)."""
RESIDUAL_CUTOFFS = (0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0)
"""Cut-offs [Hz] at which the residual's low-passed standard deviation is measured and kept in
the model (``[identification.arm] residual_sigma_lowpass``): the estimate's noise at its own
filter, measured rather than assumed white."""
RESIDUAL_SPAN = 8.0
"""Length [s] of the contiguous stretch of the first log on which that is measured."""
PDTV_SIGNIFICANCE = 5.0
"""A PDTV line is kept when its amplitude exceeds this many standard errors."""
CONTACT_THRESHOLD = 5.0
"""With ``exclude_contact``: a sample is contact when a joint's residual exceeds this many
robust standard deviations (1.4826 times the median absolute deviation) ..."""
CONTACT_MARGIN = 2.0
"""... and so are its neighbours within this many differentiator windows (the smoothing spreads
a contact, and a force rises from zero)."""
CONTACT_ITERATIONS = 12
"""At most this many fits while the set of contact samples changes."""
SHAPE_WIDTHS = np.geomspace(1e-3, 0.5, 10)
"""Transition widths searched, relative to the joint's observed motor speed range [-]."""
SHAPE_STRIBECK = np.geomspace(0.01, 2.0, 8)
"""Stribeck velocities searched, relative to the joint's observed motor speed range [-]."""
SHAPE_EXPONENTS = (1.0, 2.0)
"""Stribeck exponents searched (exponential and Gaussian forms)."""
SHAPE_ROWS = 2000
"""At most this many of the regression's rows enter the friction-shape search."""
SHAPE_KERNEL_POINTS = 12
"""The smoothing kernel is evaluated at this many points in the friction-shape search."""


@dataclass(frozen=True, slots=True, eq=False)
class BodyMass:
    """One body's mass, URDF against identified.

    Attributes
    ----------
    body
        Body name (the joint that moves it).
    urdf, identified, sigma
        Mass [kg]: the URDF's, the identified one and its standard deviation.
    """

    body: str
    urdf: float
    identified: float
    sigma: float


@dataclass(frozen=True, slots=True, eq=False)
class ArmIdentification:
    """Result of :func:`identify_arm`.

    Attributes
    ----------
    model
        The identified model: the arm with its identified inertial parameters (the model
        file's ``[robot.inertial]``), per joint armature (``[joints.<j>.inertia] constant``),
        friction and PDTV, and ``[identification.arm]`` with the covariance for sigmas.
    parameter_names
        Names of ``parameters``: the arm's base parameters, then each joint's terms.
    parameters
        Identified values, shape (p,).
    covariance
        Posterior covariance of ``parameters``, shape (p, p).
    full_parameters
        The identified full inertial parameters, shape (10 nb,) (``arm.full_parameter_names``).
    full_sigma
        Their posterior standard deviations (the prior's where the data says nothing).
    residual_sigma
        Per joint: standard deviation of the motor-side torque residual [N m].
    masses
        Each body's mass, URDF against identified.
    condition_number
        Of the weighted base-parameter part of the design matrix [-].
    samples
        Samples used (all logs).
    consistent
        True when every body has a positive mass and a positive-definite inertia about its
        centre of mass satisfying the triangle inequalities.
    warnings
        One line each.
    excluded
        Samples left out as contact (``exclude_contact``), of ``samples + excluded`` drawn.
    """

    model: Model
    parameter_names: tuple[str, ...]
    parameters: NDArray[np.float64]
    covariance: NDArray[np.float64]
    full_parameters: NDArray[np.float64]
    full_sigma: NDArray[np.float64]
    residual_sigma: NDArray[np.float64]
    masses: tuple[BodyMass, ...]
    condition_number: float
    samples: int
    consistent: bool
    warnings: tuple[str, ...] = ()
    excluded: int = 0


def _prior_sigma(pi0: NDArray[np.float64]) -> NDArray[np.float64]:
    out = np.empty_like(pi0)
    for b in range(pi0.size // 10):
        p = pi0[10 * b : 10 * b + 10]
        s_m = PRIOR_MASS_FRACTION * abs(p[0]) + PRIOR_MASS_FLOOR
        out[10 * b] = s_m
        out[10 * b + 1 : 10 * b + 4] = PRIOR_MASS_FRACTION * np.abs(p[1:4]) + s_m * PRIOR_LENGTH
        out[10 * b + 4 : 10 * b + 10] = (
            PRIOR_MASS_FRACTION * np.abs(p[4:]) + s_m * PRIOR_LENGTH**2 + PRIOR_INERTIA_FLOOR
        )
    return out


def body_consistency(full: NDArray[np.float64], body_names: Sequence[str]) -> list[str]:
    """Problems with the physical consistency of full inertial parameters (empty: consistent).

    Per body: mass > 0; the inertia about the centre of mass ``I_c = I_o - m [c]x^T [c]x``
    positive definite; its principal moments satisfy the triangle inequalities
    (Sousa & Cortesao 2014).
    """
    problems = []
    for b, name in enumerate(body_names):
        p = full[10 * b : 10 * b + 10]
        m = p[0]
        if not m > 0:
            problems.append(f"body {name}: mass {m:.4g} kg is not positive")
            continue
        c = p[1:4] / m
        Io = np.array([[p[4], p[5], p[7]], [p[5], p[6], p[8]], [p[7], p[8], p[9]]])
        cx = np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
        Ic = Io - m * cx.T @ cx
        ev = np.linalg.eigvalsh(Ic)
        if ev[0] <= 0:
            problems.append(
                f"body {name}: inertia about the centre of mass is not positive definite "
                f"(smallest principal moment {ev[0]:.3g} kg m^2)"
            )
        elif ev[2] > ev[0] + ev[1] + 1e-12 * ev[2]:
            problems.append(f"body {name}: principal moments violate the triangle inequality")
    return problems


def _pseudo_inertia(p: NDArray[np.float64]) -> NDArray[np.float64]:
    """The 4x4 pseudo-inertia ``[[Sigma, h], [h^T, m]]`` of one body's ten parameters."""
    inertia = np.array([[p[4], p[5], p[7]], [p[5], p[6], p[8]], [p[7], p[8], p[9]]])
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia
    J[:3, 3] = J[3, :3] = p[1:4]
    J[3, 3] = p[0]
    return J


def _from_log_cholesky(theta: NDArray[np.float64]) -> NDArray[np.float64]:
    """Ten inertial parameters of the log-Cholesky coordinates of Rucker & Wensing (2022):
    ``J = U U^T`` with ``U`` upper triangular of positive diagonal, so every ``theta`` gives a
    physically consistent body (positive mass, triangle inequalities)."""
    a, d1, d2, d3, s12, s23, s13, t1, t2, t3 = theta
    e = np.exp(np.clip([a, d1, d2, d3], -50.0, 50.0))
    U = e[0] * np.array(
        [
            [e[1], s12, s13, t1],
            [0.0, e[2], s23, t2],
            [0.0, 0.0, e[3], t3],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )
    J = U @ U.T
    sigma = J[:3, :3]
    inertia = np.trace(sigma) * np.eye(3) - sigma
    return np.array(
        [
            J[3, 3], J[0, 3], J[1, 3], J[2, 3],
            inertia[0, 0], inertia[0, 1], inertia[1, 1], inertia[0, 2], inertia[1, 2],
            inertia[2, 2],
        ]
    )  # fmt: skip


def _to_log_cholesky(p: NDArray[np.float64]) -> NDArray[np.float64]:
    J = _pseudo_inertia(p)
    ev = np.linalg.eigvalsh(J)
    if ev[0] <= 1e-9 * max(ev[-1], 1e-12):
        J = J + (1e-9 * max(ev[-1], 1e-12) - min(ev[0], 0.0)) * np.eye(4)
    rev = np.eye(4)[::-1]
    U = rev @ np.linalg.cholesky(rev @ J @ rev) @ rev
    a = math.log(U[3, 3])
    U = U / U[3, 3]
    return np.array(
        [a, math.log(U[0, 0]), math.log(U[1, 1]), math.log(U[2, 2]),
         U[0, 1], U[1, 2], U[0, 2], U[0, 3], U[1, 3], U[2, 3]]
    )  # fmt: skip


def consistent_parameters(
    estimate: NDArray[np.float64],
    covariance: NDArray[np.float64],
    start: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The physically consistent full parameters closest to ``estimate`` in its covariance.

    Minimises ``(pi - estimate)^T covariance^-1 (pi - estimate)`` over consistent ``pi``
    (every body's pseudo-inertia ``J_b(pi)`` positive semi-definite, Wensing, Kim & Slotine
    2017). The pseudo-inertia is linear in ``pi``, so this is a convex problem (a semidefinite
    program); it is solved by a primal barrier method: damped Newton steps on
    ``Q(pi) / 2 - mu sum_b log det J_b(pi)`` from ``start`` (the URDF's values, strictly
    consistent), ``mu`` divided by 10 until the duality gap ``4 nb mu`` is below 1e-6 (in units
    of the squared Mahalanobis distance). Directions the data pins down have small variance and
    stay; the others give way.
    """
    nb = estimate.size // 10
    n = estimate.size
    H = np.linalg.inv(covariance + 1e-15 * np.trace(covariance) * np.eye(n))
    H = 0.5 * (H + H.T)
    # basis: the pseudo-inertia of each unit parameter (linear map)
    A = np.array([_pseudo_inertia(np.eye(10)[i]) for i in range(10)])  # (10, 4, 4)

    def blocks(pi: NDArray[np.float64]) -> list[NDArray[np.float64]] | None:
        out = []
        for b in range(nb):
            J = np.einsum("i,ijk->jk", pi[10 * b : 10 * b + 10], A)
            try:
                np.linalg.cholesky(J)
            except np.linalg.LinAlgError:
                return None
            out.append(J)
        return out

    def phi(pi: NDArray[np.float64], mu: float) -> float:
        Js = blocks(pi)
        if Js is None:
            return math.inf
        d = pi - estimate
        return float(0.5 * d @ H @ d - mu * sum(np.linalg.slogdet(J)[1] for J in Js))

    pi = np.asarray(start, dtype=np.float64).copy()
    if blocks(pi) is None:  # the start must be strictly consistent: lift its eigenvalues
        pi = np.concatenate(
            [_from_log_cholesky(_to_log_cholesky(pi[10 * b : 10 * b + 10])) for b in range(nb)]
        )
    mu = max(1.0, 0.5 * float((pi - estimate) @ H @ (pi - estimate)) / (4 * nb))
    while 4 * nb * mu > 1e-6:
        for _ in range(50):
            Js = blocks(pi)
            assert Js is not None
            grad = H @ (pi - estimate)
            hess = H.copy()
            for b, J in enumerate(Js):
                Ji = np.linalg.inv(J)
                M = np.einsum("jk,ikl->ijl", Ji, A)  # J^-1 A_i
                sl = slice(10 * b, 10 * b + 10)
                grad[sl] -= mu * np.einsum("ijj->i", M)
                hess[sl, sl] += mu * np.einsum("ijk,lkj->il", M, M)
            step = -np.linalg.solve(hess, grad)
            decrement = float(-grad @ step)
            if decrement < 1e-10:
                break
            f0, alpha = phi(pi, mu), 1.0
            while alpha > 1e-12 and phi(pi + alpha * step, mu) > f0 - 0.25 * alpha * decrement:
                alpha *= 0.5
            if alpha <= 1e-12:
                break
            pi = pi + alpha * step
        mu *= 0.1
    return pi


def _rigid_rows(
    arm: Any, signals: Sequence[ArmSignals], picks: Sequence[NDArray[np.intp]]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The regressor over the gears (m, nj, P) and the smoothed motor torques (m, nj)."""
    ys, taus = [], []
    for sig, idx in zip(signals, picks, strict=True):
        Y = arm.full_regressor(sig.q[idx], sig.qd[idx], sig.qdd[idx])
        ys.append(Y / sig.gear[None, :, None])
        taus.append(sig.smooth(sig.motor_torque)[idx])
    return np.concatenate(ys, axis=0), np.concatenate(taus, axis=0)


def _joint_blocks(
    model: Model,
    signals: Sequence[ArmSignals],
    picks: Sequence[NDArray[np.intp]],
    orders: Sequence[tuple[float, ...]],
) -> list[NDArray[np.float64]]:
    """Per joint, the columns (m, c_j) of its motor-side terms at the picked samples."""
    out = []
    for k, joint in enumerate(model.robot.joints):
        parts = [
            joint_columns(model.joints[joint.name], sig, k, orders[k], smooth=True)[idx]
            for sig, idx in zip(signals, picks, strict=True)
        ]
        out.append(np.concatenate(parts, axis=0))
    return out


def _slices(P: int, blocks: Sequence[NDArray[np.float64]]) -> list[slice]:
    out, start = [], P
    for b in blocks:
        out.append(slice(start, start + b.shape[1]))
        start += b.shape[1]
    return out


def _predict(
    Y: NDArray[np.float64], blocks: Sequence[NDArray[np.float64]], x: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Motor torques (m, nj) of parameters ``x``."""
    P = Y.shape[2]
    out: NDArray[np.float64] = Y @ x[:P]
    for k, (b, sl) in enumerate(zip(blocks, _slices(P, blocks), strict=True)):
        out[:, k] += b @ x[sl]
    return out


def _refit_shift(
    Y: NDArray[np.float64],
    blocks: Sequence[NDArray[np.float64]],
    weight: NDArray[np.float64],
    cov: NDArray[np.float64],
    change: NDArray[np.float64],
) -> NDArray[np.float64]:
    """How :func:`_solve`'s estimate moves when the motor torques change by ``change`` (m, nj)
    [N m]: ``cov @ A^T W change``, the design ``A`` and weights ``W`` as there."""
    P = Y.shape[2]
    g = np.zeros(cov.shape[0])
    for k, (b, sl) in enumerate(zip(blocks, _slices(P, blocks), strict=True)):
        g[:P] += weight[k] * (Y[:, k, :].T @ change[:, k])
        g[sl] += weight[k] * (b.T @ change[:, k])
    out: NDArray[np.float64] = cov @ g
    return out


def _solve(
    Y: NDArray[np.float64],
    tau: NDArray[np.float64],
    blocks: Sequence[NDArray[np.float64]],
    weight: NDArray[np.float64],
    mean: NDArray[np.float64],
    sigma: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """MAP estimate and posterior covariance of the motor torques' regression, prior
    ``N(mean, sigma^2)``, joint ``j``'s rows of weight ``weight[j]``.

    The design is ``[Y_j | 0 .. B_j .. 0]`` per joint; its normal equations are assembled
    block by block (the joint blocks never meet), far cheaper than the dense product.
    """
    P = Y.shape[2]
    H = np.diag(1.0 / sigma**2)
    g = mean / sigma**2
    for k, (b, sl) in enumerate(zip(blocks, _slices(P, blocks), strict=True)):
        w = weight[k]
        Yk = Y[:, k, :]
        H[:P, :P] += w * Yk.T @ Yk
        cross = w * Yk.T @ b
        H[:P, sl] += cross
        H[sl, :P] += cross.T
        H[sl, sl] += w * b.T @ b
        g[:P] += w * Yk.T @ tau[:, k]
        g[sl] += w * b.T @ tau[:, k]
    # scaled for a well-conditioned inverse
    d = 1.0 / np.sqrt(np.diag(H))
    cov = np.linalg.inv(H * d[:, None] * d[None, :]) * d[:, None] * d[None, :]
    cov = 0.5 * (cov + cov.T)
    return cov @ g, cov


SCALE_LIMITS = (0.6, 1.6)
"""A joint's torque beyond these times the URDF's prediction is warned of (a gear ratio or
torque constant off by 2x: 1.75-2.8 on the UR10 bench; 1.02-1.16 with the true arm's 15 %
heavier links and a 0.8 kg tool)."""
FIT_SHARE = 0.9
"""A joint whose model explains less of its torque's variance than this is warned of (a robot
file without gravity: 7 %; else above 99.8 % on the benches)."""


#: A joint whose motor angle spans less than this [rad] in every log never moved there.
STILL_MOTOR_SPAN = 0.01
#: A joint whose angle spans less than this [rad, or m for a prismatic joint] in every log
#: only jittered about a held pose (a servo holding the arm still: 0.001-0.0035 rad at the
#: joints of a simulated 6-axis arm, 0.09-0.35 rad at the motors, which was refused as
#: "friction negative in both directions: check the robot file's gravity, gear ratios...").
STILL_JOINT_SPAN = 0.01


def scale_warnings(
    names: Sequence[str],
    Y: NDArray[np.float64],
    tau: NDArray[np.float64],
    blocks: Sequence[NDArray[np.float64]],
    slices: Sequence[slice],
    x: NDArray[np.float64],
    residual: NDArray[np.float64],
    pi0: NDArray[np.float64],
) -> list[tuple[str, str]]:
    """``(joint, warning)`` for joints the identified model does not fit (its residual's variance above
    ``1 - FIT_SHARE`` of the torque's), and for joints whose rigid-body torque is the URDF's
    (to at least 80 % of its variance) times a gain outside :data:`SCALE_LIMITS`: the signs of a
    robot file that is wrong (gravity, gear ratio, torque constant) rather than a URDF that is.

    ``Y`` (m, nj, P) is the regressor over the gears, ``tau`` (m, nj) the motor torques, ``x``
    the identified parameters (inertial first, then each joint's ``blocks`` at ``slices``),
    ``residual`` the fit's and ``pi0`` the URDF's inertial parameters.
    """
    out = []
    P = pi0.size
    gains: dict[int, float] = {}
    for k, name in enumerate(names):
        spread = float(np.sum((tau[:, k] - np.mean(tau[:, k])) ** 2))
        share = 1.0 - float(np.sum(residual[:, k] ** 2)) / max(spread, 1e-300)
        if share < FIT_SHARE:
            out.append(
                (
                    name,
                    f"joint {name}: the identified model explains only {max(share, 0.0):.0%} of its "
                    "torque's variation; check the robot file's gravity, gear ratios and torque "
                    "constants, and that the log is of this robot",
                )
            )
            continue
        urdf = Y[:, k, :P] @ pi0
        rigid = tau[:, k] - blocks[k] @ x[slices[k]]  # the joint's own terms removed
        norm = float(urdf @ urdf)
        if norm <= 0.0:
            continue
        gain = float(urdf @ rigid) / norm
        fit = 1.0 - float(np.sum((rigid - gain * urdf) ** 2)) / max(float(rigid @ rigid), 1e-300)
        if fit >= 0.8:
            gains[k] = gain
    # the bodies each joint carries: a joint nearer the base moves more of them
    carried = np.count_nonzero(np.abs(Y[:, :, :P]).max(axis=0) > 0, axis=1)
    for k, gain in gains.items():
        if gain < 0:
            # the URDF's torque turned over: gravity upside down (a UR3 bench with gravity +z
            # in its robot file: -1.10 and -1.23, warned as a gear ratio too small; QA, stop 37)
            cause = (
                "the opposite sign: does the robot file's gravity point up (it is the "
                "acceleration of gravity, [0, 0, -9.81] for a floor-mounted arm), or is the "
                "joint's direction or torque constant's sign reversed?"
            )
        elif gain < SCALE_LIMITS[0]:
            cause = (
                "a gear ratio or torque constant in the robot file is too small, or the URDF is "
                "not this arm's"
            )
        elif gain > SCALE_LIMITS[1]:
            # A load the URDF lacks raises the gains towards the tool; a wrong gear ratio or
            # torque constant raises one joint's (or all, from the base on)
            inner = [carried[i] for i in gains if carried[i] < carried[k]]
            nearest = [gains[i] for i in gains if inner and carried[i] == max(inner)]
            base = all(carried[i] <= carried[k] for i in gains)
            if not (base or (nearest and gain > 1.3 * max(nearest))):
                continue
            # a load the URDF lacks can do it too: a 3 kg payload on a UR3 doubled its
            # shoulder_pan_joint's (whose torque is all inertia), forces right (QA, stop 37)
            cause = (
                "a gear ratio or torque constant in the robot file is too large, or a load the "
                "URDF lacks (a tool, a payload) moves with the joint (which identification "
                "takes in)"
            )
        else:
            continue
        out.append(
            (
                names[k],
                f"joint {names[k]}: its rigid-body torque is {gain:.2f} times the URDF's: {cause}",
            )
        )
    return out


#: The friction band [N m] an identified band within its noise of zero is kept at (a model
#: file's law must dissipate: one Coulomb level may be negative only if their sum is positive).
ZERO_BAND = 1e-9


#: A joint whose identified friction (99th percentile of its magnitude over the logs' speeds)
#: is at most this share of its motor torque's (99th percentile) cannot have its friction told
#: from its rigid-body torque's error: a Coulomb band negative both ways is then refitted to
#: zero, not refused (a simulated direct-drive UR3 with 2^20-count encoders: 0.0 % and 0.5 % on
#: the two joints refused before; at 16384 counts its shoulder_pan_joint's -0.108 N m, against
#: a 0.41 N m torque, is still refused, as is tests/test_arm_qa37.py's wrong-sign friction).
FRICTION_SHARE = 0.01


def _law_of(
    law: FrictionLaw, parameters: NDArray[np.float64]
) -> tuple[FrictionLaw, tuple[float, float], tuple[float, float]]:
    """``law`` with the linear ``parameters``, its static levels and its Coulomb levels [N m]
    (positive, negative; 0 for a law without them)."""
    friction = law.with_linear_parameters(parameters)
    coulomb = (
        float(getattr(friction, "coulomb_positive", 0.0)),
        float(getattr(friction, "coulomb_negative", 0.0)),
    )
    return friction, friction.static_levels(), coulomb


def _friction_share(
    friction: Any,
    signals: Sequence[ArmSignals],
    picks: Sequence[NDArray[np.intp]],
    k: int,
    tau: NDArray[np.float64],
) -> float:
    """The 99th percentile of joint ``k``'s friction magnitude over the picked samples' motor
    speeds, over that of its motor torque ``tau`` (m,) [N m, motor side]."""
    w = np.concatenate(
        [sig.gear[k] * sig.qd[idx, k] for sig, idx in zip(signals, picks, strict=True)]
    )
    f = float(np.percentile(np.abs(friction.torque(w)), 99))
    scale = float(np.percentile(np.abs(tau), 99))
    return f / scale if scale > 0 else float("inf")


def _refit_without_band(
    block: NDArray[np.float64], target: NDArray[np.float64], positive: int, negative: int
) -> NDArray[np.float64]:
    """A joint's own parameters (armature, friction, PDTV: the columns of ``block``, (m, c))
    refitted by least squares to ``target`` (m,) [N m, motor side] with its two Coulomb levels
    (columns ``positive`` and ``negative``) summing to :data:`ZERO_BAND`: no band, an offset."""
    from scipy.linalg import null_space

    a = np.zeros(block.shape[1])
    a[[positive, negative]] = 1.0
    v0 = a * ZERO_BAND / 2.0
    basis = null_space(a[None, :])
    z = np.linalg.lstsq(block @ basis, target - block @ v0, rcond=None)[0]
    out: NDArray[np.float64] = v0 + basis @ z
    return out


def split_at_gaps(logs: Sequence[Log], window: float) -> tuple[list[Log], int]:
    """The logs cut at every gap in time longer than :func:`~torquemap.sanitize.max_gap_for`
    ``window`` (the differentiator would fit one parabola across it), stretches shorter than 4
    windows left out; and the number of gaps cut at."""
    out, cut = [], 0
    limit = max_gap_for(window)
    for log in logs:
        edges = np.flatnonzero(np.diff(log.t) > limit) + 1
        cut += edges.size
        for a, b in zip([0, *edges.tolist()], [*edges.tolist(), log.t.size], strict=True):
            if log.t[b - 1] - log.t[a] >= 4 * window:
                out.append(
                    dataclasses.replace(
                        log, t=log.t[a:b], q=log.q[a:b], motor_torque=log.motor_torque[a:b]
                    )
                    if edges.size
                    else log
                )
    return out, cut


def is_rigid_body_arm(arm: Any) -> bool:
    """True when ``arm`` models rigid-body dynamics in full (the ``urdf`` kind): the arm
    identification and estimation apply."""
    return bool(getattr(arm, "has_dynamics", False)) and all(
        hasattr(arm, name) for name in ("full_regressor", "mass_matrix", "wrench_map")
    )


def identify_arm(
    model: Model,
    logs: Sequence[Log],
    *,
    window: float = 0.05,
    max_samples: int = 6000,
    pdtv_max_order: int = 12,
    fit_friction_shape: bool = True,
    exclude_contact: bool = False,
    rng: np.random.Generator | int | None = 0,
) -> ArmIdentification:
    """Identify an arm's base inertial parameters and its joints from free-motion logs.

    Parameters
    ----------
    model
        A robot (or model) whose arm has rigid-body dynamics (``kinematics = "urdf"``). Its
        joints' friction laws give the laws' kinds and starting shapes.
    logs
        Free-motion logs (no contact): an exciting trajectory (``torquemap excite``).
    window
        Differentiator window [s].
    max_samples
        At most this many samples (drawn at random over all logs, the first and last window of
        each left out) enter the regression; more add time, not accuracy.
    pdtv_max_order
        PDTV lines of integer order 1 .. this [CPR] are searched per joint on the residual and
        kept when significant (0: none).
    fit_friction_shape
        Fit each joint's friction-law shape (transition width, Stribeck velocity and exponent,
        smooth transition) to the data (:func:`fit_friction_shapes`); False keeps the model
        file's shape and fits only the law's linear parameters.
    exclude_contact
        The logs may hold contact (a leg's stance phases, a bump): find the samples whose
        residual is an outlier (:func:`contact_free_rows`: iteratively, more than
        :data:`CONTACT_THRESHOLD` robust standard deviations on any joint, widened by
        :data:`CONTACT_MARGIN` differentiator windows on each side) and identify from the rest.
    rng
        Random generator or seed (for the sample draw).

    Returns
    -------
    ArmIdentification
        The model and the diagnostics.

    Raises
    ------
    InputError
        When the arm has no rigid-body dynamics, or the logs are too short.
    """
    arm: Any = model.robot.arm
    if not is_rigid_body_arm(arm):
        raise InputError(
            f"identify_arm needs an arm with rigid-body dynamics (kinematics = 'urdf'), "
            f"not {model.robot.kinematics!r}"
        )
    if not logs:
        raise InputError("no logs given")
    gen = np.random.default_rng(rng)
    robot = model.robot
    nj = len(robot.joints)
    warnings: list[str] = []
    given = list(logs)
    for log in given:
        problem = angles_beyond_limits(log.q, arm)
        if problem is not None:
            raise InputError(problem, path=log.path)
    logs, cut = split_at_gaps(logs, window)
    if cut:
        warnings.append(
            f"{cut} gaps in time longer than {max_gap_for(window):.3g} s: the logs are "
            "identified as separate stretches (stretches shorter than 4 windows are left out)"
        )
    if not logs:
        # a log stamped in ns or ms looks sparse: say so, naming it (no_stretch_message)
        first = given[0]
        raise InputError(
            no_stretch_message(first.t, window).replace(
                f"lasts the {window:.3g} s differentiator window",
                f"lasts 4 differentiator windows ({4 * window:.3g} s)",
            ),
            path=first.path,
        )
    signals = [arm_signals(log, robot, window=window) for log in logs]
    # a joint held still throughout (a brake, a disabled drive) was refused as "friction is
    # negative in both directions: check the robot file's gravity, gear ratios..." or kept with
    # "the model explains 0% of its torque", by the rounding of a friction it cannot show
    travels = [max(float(np.ptp(log.q[:, k])) for log in logs) for k in range(nj)]
    for k, joint in enumerate(robot.joints):
        travel = travels[k]
        span = joint.gear_ratio * travel
        if span < STILL_MOTOR_SPAN or travel < STILL_JOINT_SPAN:
            paths = ", ".join(dict.fromkeys(str(log.path) for log in logs if log.path))
            moves = (
                f"never moves in the logs (its motor angle spans {span:.3g} rad)"
                if span < STILL_MOTOR_SPAN
                else f"only jitters about a held pose in the logs (it spans {travel:.3g} "
                f"{'m' if np.isinf(arm.angle_period[k]) else 'rad'}, under "
                f"{STILL_JOINT_SPAN:g})"
            )
            counts = (
                output_counts_note(robot, travels, STILL_JOINT_SPAN)
                if span >= STILL_MOTOR_SPAN
                else None
            )
            raise InputError(
                f"joint {joint.name} {moves}: its friction and rotor inertia cannot be "
                "identified; excite it (torquemap excite), or, if it is locked, leave it out of "
                "the robot file (locked at zero) or make it fixed in the URDF at its angle"
                + (f"; {counts}" if counts is not None else ""),
                path=paths or None,
            )
    inner = []
    for sig in signals:
        keep = np.flatnonzero((sig.t >= sig.t[0] + window) & (sig.t <= sig.t[-1] - window))
        inner.append(keep)
    total = sum(k.size for k in inner)
    if total < 10 * nj:
        raise InputError(f"logs hold {total} usable samples; record a longer exciting motion")
    share = min(1.0, max_samples / total)
    picks = [
        np.sort(gen.choice(k, size=max(1, round(k.size * share)), replace=False)) for k in inner
    ]
    m = sum(p.size for p in picks)

    pi0 = np.asarray(arm.nominal_parameters, dtype=np.float64)
    P = pi0.size

    current = model

    def fit(
        orders: Sequence[tuple[float, ...]],
        noise: NDArray[np.float64],
        rows: NDArray[np.bool_] | None = None,
        given: list[NDArray[np.float64]] | None = None,
    ) -> tuple[
        NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], list[NDArray[np.float64]]
    ]:
        """Fit on ``rows`` (default all); the residual is returned for every row. ``given``:
        the joints' columns, when already computed for these orders and laws."""
        model = current
        blocks = given if given is not None else _joint_blocks(model, signals, picks, orders)
        slices = _slices(P, blocks)
        n_all = P + sum(b.shape[1] for b in blocks)
        mean = np.zeros(n_all)
        mean[:P] = pi0
        sd = np.empty(n_all)
        sd[:P] = _prior_sigma(pi0)
        for k, joint in enumerate(robot.joints):
            names = column_names(joint.name, model.joints[joint.name], orders[k])
            for i, name in zip(range(slices[k].start, slices[k].stop), names, strict=True):
                sd[i] = PRIOR_JOINT.get(name.split(".")[1], 1.0)
        if rows is None:
            x, cov = _solve(Y, tau, blocks, 1.0 / (noise**2 * inflation), mean, sd)
        else:
            x, cov = _solve(Y[rows], tau[rows], [b[rows] for b in blocks], 1.0 / noise**2, mean, sd)
        return x, cov, tau - _predict(Y, blocks, x), blocks

    # The smoothed torques' noise is correlated over the window: a parabolic kernel of width w
    # passes white noise as 1.2 D / w independent samples over a duration D. Rows closer than
    # that count less (else the covariance would claim more than the data holds).
    duration = sum(float(s.t[k[-1]] - s.t[k[0]]) for s, k in zip(signals, inner, strict=True))
    inflation = np.full(nj, max(1.0, m * window / (1.2 * max(duration, 1e-12))))
    Y, tau = _rigid_rows(arm, signals, picks)
    no_lines: list[tuple[float, ...]] = [() for _ in range(nj)]
    noise = 0.1 * np.std(tau, axis=0) + 1e-9
    excluded = 0
    if exclude_contact:
        columns = _joint_blocks(current, signals, picks, no_lines)
        start = _trimmed_start(
            lambda rows: fit(no_lines, noise, rows, columns)[2], signals, picks, rng=gen
        )
        if fit_friction_shape:  # the friction's shape from the trimmed rows, before rejecting
            x0 = fit(no_lines, noise, start, columns)[0]
            parts0 = np.split(start, np.cumsum([p.size for p in picks])[:-1])
            others0 = []
            for k, joint in enumerate(robot.joints):
                nf = len(current.joints[joint.name].friction.linear_parameter_names)
                others0.append(np.delete(columns[k], np.s_[1 : 1 + nf], axis=1)[start])
            current = dataclasses.replace(
                current,
                joints=fit_friction_shapes(
                    current,
                    signals,
                    [p[k] for p, k in zip(picks, parts0, strict=True)],
                    (tau - Y @ x0[:P])[start],
                    others0,
                    rng=gen,
                ),
            )
            columns = _joint_blocks(current, signals, picks, no_lines)
        free = contact_free_rows(
            lambda rows: fit(no_lines, noise, rows, columns)[2], signals, picks, start=start
        )
        excluded = int(np.count_nonzero(~free))
        if np.count_nonzero(free) < 10 * nj:
            raise InputError(
                f"only {np.count_nonzero(free)} samples are free of contact; record more "
                "motion without contact"
            )
        parts = np.split(free, np.cumsum([p.size for p in picks])[:-1])
        picks = [p[k] for p, k in zip(picks, parts, strict=True)]
        Y, tau = Y[free], tau[free]
        duration *= float(np.count_nonzero(free)) / m
        m = int(np.count_nonzero(free))
        inflation = np.full(nj, max(1.0, m * window / (1.2 * max(duration, 1e-12))))
        if excluded:
            warnings.append(
                f"{excluded} of {excluded + m} samples excluded as contact (residual outliers)"
            )
    x, cov, residual, blocks = fit(no_lines, noise)

    def reshape(
        x: NDArray[np.float64], blocks: Sequence[NDArray[np.float64]]
    ) -> dict[str, JointModel]:
        target = tau - Y @ x[:P]
        others = []
        for k, joint in enumerate(robot.joints):
            nf = len(current.joints[joint.name].friction.linear_parameter_names)
            others.append(np.delete(blocks[k], np.s_[1 : 1 + nf], axis=1))
        return fit_friction_shapes(current, signals, picks, target, others, rng=gen)

    if fit_friction_shape:
        current = dataclasses.replace(current, joints=reshape(x, blocks))
        x, cov, residual, blocks = fit(no_lines, noise)
    noise = np.sqrt(np.mean(residual**2, axis=0)) + 1e-12
    orders = no_lines
    if pdtv_max_order > 0:
        orders = _pick_pdtv(
            signals, picks, residual, pdtv_max_order, inflation=float(np.max(inflation))
        )
    x, cov, residual, blocks = fit(orders, noise)
    if fit_friction_shape:  # again, with the PDTV lines and the refitted bodies
        current = dataclasses.replace(current, joints=reshape(x, blocks))
        x, cov, residual, blocks = fit(orders, noise)
    noise = np.sqrt(np.mean(residual**2, axis=0)) + 1e-12
    # rows count less where the residual stays correlated beyond the window (model error):
    # the measured long-run variance ratio, where it exceeds the window's own correlation
    inflation = np.maximum(inflation, long_run_ratio(residual, signals, picks))
    x, cov, residual, blocks = fit(orders, noise)
    model = dataclasses.replace(model, joints=current.joints)
    slices = _slices(P, blocks)
    weight = 1.0 / (noise**2 * inflation)
    residual_sigma = np.sqrt(np.mean(residual**2, axis=0))
    lowpassed = _lowpassed_residual(model, arm, signals[0], inner[0], orders, x)

    scale = scale_warnings(
        [joint.name for joint in robot.joints], Y, tau, blocks, slices, x, residual, pi0
    )
    warnings += [text for _, text in scale]

    # the currents read late against the angles (a current loop's filter, a bus polling late):
    # silent before, or refused blaming the robot file (new-user QA, stop 37)
    def residual_for(target: NDArray[np.float64]) -> NDArray[np.float64]:
        """The final fit's residual had the logs' motor torques been ``target`` (the fit is
        linear in them: the same normal matrix, the right-hand side moved)."""
        moved = x + _refit_shift(Y, blocks, weight, cov, target - tau)
        return target - _predict(Y, blocks, moved)

    lag, lag_gain, lag_removed = current_lag(signals, picks, residual_for, weight)
    lagged = (
        None
        if scale
        else lag_message(
            lag, lag_gain, lag_removed, max(float(np.median(np.diff(s.t))) for s in signals)
        )
    )
    if lagged is not None:
        warnings.append(lagged)

    if body_consistency(x[:P], arm.body_names):
        # project onto physically consistent bodies, and move the joint terms with them
        # (the Gaussian conditional of the joint terms given the inertial parameters)
        target = consistent_parameters(x[:P], cov[:P, :P], pi0)
        shift = target - x[:P]
        x = x.copy()
        x[P:] += cov[P:, :P] @ np.linalg.solve(cov[:P, :P], shift)
        x[:P] = target
        residual = tau - _predict(Y, blocks, x)
    full = x[:P]
    full_sigma = np.sqrt(np.diag(cov)[:P])
    base = arm.base
    B = base.matrix(P)
    n_joint = x.size - P
    T = np.zeros((B.shape[0] + n_joint, x.size))
    T[: B.shape[0], :P] = B
    T[B.shape[0] :, P:] = np.eye(n_joint)
    theta = T @ x
    theta_cov = T @ cov @ T.T
    names: list[str] = list(arm.parameter_names)

    joints: dict[str, JointModel] = {}
    for k, joint in enumerate(robot.joints):
        jm = model.joints[joint.name]
        names += column_names(joint.name, jm, orders[k])
        v = x[slices[k]]
        nf = len(jm.friction.linear_parameter_names)
        armature = float(v[0])
        if armature < 0:
            warnings.append(
                f"joint {joint.name}: identified rotor inertia {armature:.3g} kg m^2 < 0 "
                "(not excited enough); kept as identified"
            )
        friction, levels, coulomb = _law_of(jm.friction, v[1 : 1 + nf])
        share = _friction_share(friction, signals, picks, k, tau[:, k])
        if not coulomb_levels_valid(*coulomb) and share <= FRICTION_SHARE:
            # friction too small a share of the joint's torque to be resolved (a direct drive:
            # refused before as a robot file at odds with the log; new-user QA, stop 37)
            warnings.append(
                f"joint {joint.name}: its identified friction is {share:.1%} of its torque, too "
                f"small to resolve (Coulomb {coulomb[0]:.3g}, {coulomb[1]:.3g} N m, negative "
                "in both directions; a direct drive, a low gear ratio): refitted with no "
                "Coulomb band"
            )
            names_k = list(jm.friction.linear_parameter_names)
            v = _refit_without_band(
                blocks[k],
                residual[:, k] + blocks[k] @ v,
                1 + names_k.index("coulomb_positive"),
                1 + names_k.index("coulomb_negative"),
            )
            armature = float(v[0])
            friction, levels, coulomb = _law_of(jm.friction, v[1 : 1 + nf])
            x = x.copy()
            x[slices[k]] = v
            theta = T @ x  # the parameters kept are the law's
        if not coulomb_levels_valid(*coulomb):
            # a Coulomb level beyond the speeds the logs reach (new-user QA, stop 38, Q46)
            speeds = np.concatenate(
                [sig.gear[k] * sig.qd[idx, k] for sig, idx in zip(signals, picks, strict=True)]
            )
            target = residual[:, k] + blocks[k] @ v
            refit = refit_without_stribeck(
                friction, blocks[k], target, speeds, 1.0 / float(weight[k])
            )
            # only for a model that otherwise fits: not where a torque is unexplained or the
            # currents lag (a 30 ms lag and a UR3 at gear 1 with 16384-count encoders, whose
            # refusals name their cause, were kept with forces 10x off)
            sound = lagged is None and _misfits_are_noise(
                scale, robot, model.joints, signals, residual_sigma, window
            )
            if sound and refit is not None and refit.band >= -BAND_SIGMAS * refit.band_sigma:
                old = coulomb
                v = refit.parameters
                note = ""
                if refit.band <= 0:
                    names_k = list(jm.friction.linear_parameter_names)
                    mask = np.ones(blocks[k].shape[1])
                    mask[[1 + names_k.index(s) for s in STRIBECK_LEVELS]] = 0.0
                    v = _refit_without_band(
                        blocks[k] * mask,
                        target,
                        1 + names_k.index("coulomb_positive"),
                        1 + names_k.index("coulomb_negative"),
                    )
                    note = (
                        f"its band ({refit.band:.3g} +- {refit.band_sigma:.2g} N m) within its "
                        "uncertainty of zero, kept at zero"
                    )
                armature = float(v[0])
                friction, levels, coulomb = _law_of(jm.friction, v[1 : 1 + nf])
                if refit.band > 0:
                    note = f"Coulomb {coulomb[0]:.3g}, {coulomb[1]:.3g} N m"
                warnings.append(
                    f"joint {joint.name}: its identified Coulomb friction ({old[0]:.3g}, "
                    f"{old[1]:.3g} N m, negative in both directions) lies beyond the speeds "
                    f"the logs reach (its Stribeck term keeps {refit.remaining:.0%} of its "
                    f"level at {refit.speed:.3g} rad/s, the motor's 99th-percentile speed): "
                    f"refitted with no Stribeck term ({note}); record faster motions "
                    "(torquemap excite) to resolve it"
                )
                x = x.copy()
                x[slices[k]] = v
                theta = T @ x
        if not coulomb_levels_valid(*coulomb):
            flagged = [name for name, _ in scale]
            coarse = coarse_angle_note(
                robot,
                logs,
                [
                    np.concatenate(
                        [
                            sig.gear[i] * sig.qd[idx, i]
                            for sig, idx in zip(signals, picks, strict=True)
                        ]
                    )
                    for i in range(nj)
                ],
                window,
            )
            raise InputError(
                f"joint {joint.name}: the identified friction is negative in both directions "
                f"(Coulomb {coulomb[0]:.3g}, {coulomb[1]:.3g} N m): the model does not fit the "
                "log; "
                + (f"{coarse}; else " if coarse is not None else "")
                + "check the robot file's gravity, gear ratios and torque constants, and that "
                "the log is of this robot"
                + (
                    f" (a torque that the URDF does not explain: {', '.join(flagged)}; a "
                    "current logged with its sign flipped against the joint's angle reads so)"
                    if flagged
                    else ""
                )
                + (f"; {lagged}" if lagged is not None else ""),
                # the log, named as every refusal names its file (before, stop 39: none)
                path=logs[0].path if len(logs) == 1 else None,
            )
        if min(levels) < 0:
            warnings.append(
                f"joint {joint.name}: identified friction at rest is negative ({levels[0]:.3g}, "
                f"{levels[1]:.3g} N m); the motion may not have reversed slowly enough, or "
                "a constant load the URDF lacks (gravity on a vertical prismatic joint, a "
                "spring) reads as friction one way"
            )
        joints[joint.name] = dataclasses.replace(
            jm,
            inertia=InertiaModel(constant=armature, cos_elbow=0.0),
            friction=friction,
            pdtv=pdtv_lines(orders[k], v[1 + nf :]),
        )

    weights = [float(sig.t.size) for sig in signals]
    noise_levels = pooled_levels([arm_noise_levels(robot, joints, sig) for sig in signals], weights)
    warnings = _noise_misfits(
        warnings, scale, robot, joints, signals, weights, noise_levels, residual_sigma, window
    )

    problems = body_consistency(full, arm.body_names)
    for p in problems:
        warnings.append(f"not physically consistent: {p}")
    masses = tuple(
        BodyMass(
            body=name,
            urdf=float(pi0[10 * b]),
            identified=float(full[10 * b]),
            sigma=float(full_sigma[10 * b]),
        )
        for b, name in enumerate(arm.body_names)
    )
    Yb = Y[:, :, base.independent]
    gram = np.einsum("mki,mkj,k->ij", Yb, Yb, weight)
    ev = np.linalg.eigvalsh(gram)
    condition = float(np.sqrt(ev[-1] / ev[0])) if ev[0] > 0 else math.inf

    new_arm = arm.with_full_parameters(full)
    new_robot = dataclasses.replace(robot, arm=new_arm)
    notes: dict[str, Any] = dict(model.notes)
    notes["arm"] = {
        "method": "MAP regression of all joints on the URDF prior (docs/arm.md)",
        "window": window,
        "samples": m,
        "excluded_as_contact": excluded,
        "logs": [log.path for log in logs],
        "condition_number": condition,
        "residual_sigma": [float(s) for s in residual_sigma],
        "residual_lowpass_hz": list(RESIDUAL_CUTOFFS),
        "residual_sigma_lowpass": [[float(v) for v in row] for row in lowpassed],
        "parameter_names": names,
        "parameters": [float(v) for v in theta],
        "covariance": [[float(v) for v in row] for row in theta_cov],
        "masses": {
            bm.body: {"urdf": bm.urdf, "identified": bm.identified, "sigma": bm.sigma}
            for bm in masses
        },
        **visited_region(signals, picks),
        "noise_high_psd": noise_levels,
        "current_lag": float(f"{lag:.4g}"),
        "current_lag_gain": float(f"{lag_gain:.4g}"),
        "current_lag_removed": float(f"{lag_removed:.4g}"),
        "motor_torque_p99": [
            float(f"{v:.4g}")
            for v in np.percentile(
                np.abs(np.concatenate([sig.motor_torque for sig in signals])), 99, axis=0
            )
        ],
        "warnings": list(warnings),
    }
    out_model = dataclasses.replace(model, robot=new_robot, joints=joints, notes=notes)
    return ArmIdentification(
        model=out_model,
        parameter_names=tuple(names),
        parameters=theta,
        covariance=theta_cov,
        full_parameters=full,
        full_sigma=full_sigma,
        residual_sigma=residual_sigma,
        masses=masses,
        condition_number=condition,
        samples=m,
        consistent=not problems,
        warnings=tuple(warnings),
        excluded=excluded,
    )


def _misfits_are_noise(
    scale: Sequence[tuple[str, str]],
    robot: Robot,
    joints: Mapping[str, JointModel],
    signals: Sequence[ArmSignals],
    residual_sigma: NDArray[np.float64],
    window: float,
) -> bool:
    """Whether every warning of :func:`scale_warnings` is an "explains only" warning of a
    joint whose misfit is its logs' white torque noise (as :func:`_noise_misfits` tells, on
    the joint models ``joints``): none says the URDF or the robot file is at odds."""
    if not scale:
        return True
    if any(explained_share(text) is None for _, text in scale):
        return False
    weights = [float(sig.t.size) for sig in signals]
    levels = pooled_levels([arm_noise_levels(robot, joints, sig) for sig in signals], weights)
    upper = pooled_levels(
        [net_noise_levels(robot, joints, sig, upper_split(sig)) for sig in signals], weights
    )
    names = [joint.name for joint in robot.joints]
    return all(
        misfit_is_noise(
            float(residual_sigma[names.index(name)]),
            levels[names.index(name)],
            upper[names.index(name)],
            window,
        )
        for name, _ in scale
    )


def _noise_misfits(
    warnings: list[str],
    scale: Sequence[tuple[str, str]],
    robot: Robot,
    joints: Mapping[str, JointModel],
    signals: Sequence[ArmSignals],
    weights: Sequence[float],
    levels: Sequence[float],
    residual_sigma: NDArray[np.float64],
    window: float,
) -> list[str]:
    """``warnings`` with each "explains only" warning of a joint whose misfit is its logs'
    white torque noise reworded to say so (:mod:`torquemap.arm_misfit`; it blamed the robot
    file: new-user QA, stop 38)."""
    if not any(explained_share(text) is not None for _, text in scale):
        return warnings
    upper = pooled_levels(
        [net_noise_levels(robot, joints, sig, upper_split(sig)) for sig in signals], weights
    )
    out = list(warnings)
    names = [joint.name for joint in robot.joints]
    for name, text in scale:
        share = explained_share(text)
        if share is None or text not in out:
            continue
        k = names.index(name)
        sigma = float(residual_sigma[k])
        if misfit_is_noise(sigma, levels[k], upper[k], window):
            out[out.index(text)] = noise_misfit_message(name, share, sigma)
    return out


SPEED_LEVELS = (0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.99, 1.0)
"""Levels of the quantiles of each joint's motor speed that the model keeps
(``motor_speed_quantiles``): the distribution of speeds the identification saw."""


def visited_region(
    signals: Sequence[ArmSignals], picks: Sequence[NDArray[np.intp]]
) -> dict[str, Any]:
    """What the identification saw, per joint: ``position_range`` ``[lowest, highest]``
    joint angle [rad] and ``motor_speed_quantiles``, the quantiles of ``|N qd|`` [rad/s] at
    :data:`SPEED_LEVELS`. Estimation compares a log with it: outside, the model extrapolates
    (:mod:`torquemap.estimate_arm`)."""
    q = np.concatenate([sig.q[idx] for sig, idx in zip(signals, picks, strict=True)])
    w = np.abs(
        np.concatenate([sig.gear * sig.qd[idx] for sig, idx in zip(signals, picks, strict=True)])
    )
    quantiles = np.quantile(w, SPEED_LEVELS, axis=0)  # (levels, nj)
    return {
        "position_range": [[float(a), float(b)] for a, b in zip(q.min(0), q.max(0), strict=True)],
        "motor_speed_levels": list(SPEED_LEVELS),
        "motor_speed_quantiles": [[float(v) for v in col] for col in quantiles.T],
    }


CORRELATION_SPAN = 1.0
"""Length [s] of the stretches over which :func:`long_run_ratio` sums the residual."""


def long_run_ratio(
    residual: NDArray[np.float64],
    signals: Sequence[ArmSignals],
    picks: Sequence[NDArray[np.intp]],
    *,
    span: float = CORRELATION_SPAN,
) -> NDArray[np.float64]:
    """Per joint, how much more the residual's sums over stretches of ``span`` vary than
    independent rows would: ``sum_b (sum_{i in b} r_i)^2 / sum_b sum_{i in b} r_i^2`` (1 for
    white rows; the number of rows a correlated stretch is worth less than its count).

    The rows' weights in the regression are divided by it, so that the covariance counts the
    independent information in the residual (a long-run variance, as in Newey & West 1987)
    rather than the rows: model error that persists over a second is not averaged away by
    more rows in that second.

    Returns
    -------
    ndarray
        Shape (nj,), at least 1; 1 where fewer than 8 stretches.
    """
    labels, offset = [], 0
    for sig, idx in zip(signals, picks, strict=True):
        seg = np.floor((sig.t[idx] - sig.t[0]) / span).astype(np.intp)
        _, seg = np.unique(seg, return_inverse=True)
        labels.append(seg + offset)
        offset += int(seg.max()) + 1 if seg.size else 0
    label = np.concatenate(labels)
    if offset < 8:
        return np.ones(residual.shape[1])
    out = np.empty(residual.shape[1])
    for k in range(residual.shape[1]):
        sums = np.bincount(label, weights=residual[:, k], minlength=offset)
        squares = float(np.sum(residual[:, k] ** 2))
        out[k] = float(np.sum(sums**2)) / squares if squares > 0 else 1.0
    return np.maximum(out, 1.0)


def _lowpassed_residual(
    model: Model,
    arm: Any,
    signal: ArmSignals,
    inner: NDArray[np.intp],
    orders: Sequence[tuple[float, ...]],
    x: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Standard deviation (len(RESIDUAL_CUTOFFS), nj) of the motor-side residual on a
    contiguous stretch, after a zero-phase low-pass at each cut-off (NaN where the stretch is
    too short or the cut-off above Nyquist)."""
    from torquemap.filters import lowpass

    t = signal.t
    stop = int(np.searchsorted(t, t[inner[0]] + RESIDUAL_SPAN))
    idx = np.arange(inner[0], min(max(stop, inner[0] + 3), inner[-1] + 1))
    Y = arm.full_regressor(signal.q[idx], signal.qd[idx], signal.qdd[idx])
    Y = Y / signal.gear[None, :, None]
    blocks = [
        joint_columns(model.joints[j.name], signal, k, orders[k], smooth=True)[idx]
        for k, j in enumerate(model.robot.joints)
    ]
    resid = signal.smooth(signal.motor_torque)[idx] - _predict(Y, blocks, x)
    out = np.full((len(RESIDUAL_CUTOFFS), resid.shape[1]), np.nan)
    for i, fc in enumerate(RESIDUAL_CUTOFFS):
        for k in range(resid.shape[1]):
            try:
                out[i, k] = float(np.std(lowpass(t[idx], resid[:, k], cutoff=fc)))
            except InputError:
                break
    return out


def _pick_pdtv(
    signals: Sequence[ArmSignals],
    picks: Sequence[NDArray[np.intp]],
    residual: NDArray[np.float64],
    max_order: int,
    *,
    inflation: float = 1.0,
) -> list[tuple[float, ...]]:
    """Per joint, the integer orders whose cos/sin fit of the residual is significant.

    ``inflation`` multiplies the coefficients' variance: the smoothed residual is correlated
    over the differentiator's window, so rows closer than that count less (as in the
    identification's covariance); without it a slow log shows spurious lines."""
    nj = residual.shape[1]
    out: list[tuple[float, ...]] = []
    orders = np.arange(1, max_order + 1, dtype=float)
    for k in range(nj):
        theta = np.concatenate(
            [s.gear[k] * s.q_measured[idx, k] for s, idx in zip(signals, picks, strict=True)]
        )
        X = np.concatenate(
            [np.cos(np.outer(theta, orders)), np.sin(np.outer(theta, orders))], axis=1
        )
        coef, *_ = np.linalg.lstsq(X, residual[:, k], rcond=None)
        dof = max(X.shape[0] - X.shape[1], 1)
        s2 = float(np.sum((residual[:, k] - X @ coef) ** 2) / dof)
        try:
            cov = s2 * np.linalg.inv(X.T @ X)
        except np.linalg.LinAlgError:
            out.append(())
            continue
        keep = []
        for i, order in enumerate(orders):
            c, s = coef[i], coef[max_order + i]
            amp = math.hypot(c, s)
            var = inflation * max(cov[i, i], cov[max_order + i, max_order + i])
            if not (math.isfinite(var) and var > 0):
                continue  # the orders are not separable on these samples
            if amp > PDTV_SIGNIFICANCE * math.sqrt(var):
                keep.append(float(order))
        out.append(tuple(keep))
    return out


def masses_table(result: ArmIdentification) -> Mapping[str, tuple[float, float, float]]:
    """``{body: (urdf, identified, sigma)}`` masses [kg], for printing."""
    return {m.body: (m.urdf, m.identified, m.sigma) for m in result.masses}


def _kernel(t: NDArray[np.float64], window: float) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Offsets (L,) [samples] and weights (L,) of :func:`smooth_as_acceleration`'s kernel on a
    uniform grid at the log's median step: its response to an impulse."""
    from torquemap.filters import smooth_as_acceleration, uniform_step

    dt = uniform_step(t)
    half = math.ceil(window / dt) + 2
    grid = np.arange(4 * half + 1, dtype=np.float64) * dt
    impulse = np.zeros(grid.size)
    impulse[2 * half] = 1.0
    response = smooth_as_acceleration(grid, impulse, window=window)
    response -= smooth_as_acceleration(grid, np.zeros(grid.size), window=window)
    keep = np.flatnonzero(np.abs(response) > 1e-9 * np.max(np.abs(response)))
    # y[i] = sum_j K[j] x[i + j]: the response at i to an impulse at c is K[c - i]
    offsets = (2 * half - keep)[::-1].astype(np.intp)
    weights = response[keep][::-1].copy()
    if offsets.size > SHAPE_KERNEL_POINTS:  # coarser: every stride-th sample, weights summed
        stride = math.ceil(offsets.size / SHAPE_KERNEL_POINTS)
        groups = np.arange(offsets.size) // stride
        summed = np.asarray(np.bincount(groups, weights=weights), dtype=np.float64)
        centre = np.bincount(groups, weights=weights * offsets) / summed
        return np.round(centre).astype(np.intp), summed
    return offsets, weights


def _shape_of(law: StribeckFriction, params: NDArray[np.float64]) -> StribeckFriction:
    width, stribeck, exponent = (float(v) for v in params)
    return dataclasses.replace(
        law,
        zero_velocity=width,
        stribeck_velocity=stribeck,
        stribeck_exponent=exponent,
        transition="smooth",
    )


class _ShapeProblem:
    """One joint's friction-shape search: the motor velocities around each row (m, L), the
    smoothing weights (L,), the joint's other columns (m, c) and the target (m,).

    The other columns are projected out once (QR); each trial then costs one evaluation of
    the law's columns and a 5 x 5 solve (small products by ``einsum``: many small LAPACK
    calls on a loaded machine with threaded BLAS were the search's cost)."""

    def __init__(
        self,
        law: StribeckFriction,
        velocity: NDArray[np.float64],
        weights: NDArray[np.float64],
        other: NDArray[np.float64],
        y: NDArray[np.float64],
    ) -> None:
        self.law = law
        self.velocity = velocity
        self.weights = weights
        self.q, _ = np.linalg.qr(other)
        self.y = y - self.q @ (self.q.T @ y)
        self.yy = float(np.einsum("m,m->", self.y, self.y))

    def rss(self, params: NDArray[np.float64]) -> float:
        """Residual sum of squares [N^2 m^2] of the best linear fit with shape ``params``."""
        trial = _shape_of(self.law, params)
        cols = trial.basis(self.velocity.reshape(-1)).reshape(*self.velocity.shape, -1)
        F = np.einsum("mlc,l->mc", cols, self.weights)
        F = F - self.q @ np.einsum("mk,mc->kc", self.q, F)
        scale = np.sqrt(np.einsum("mc,mc->c", F, F)) + 1e-300
        F = F / scale
        G = np.einsum("mi,mj->ij", F, F)
        g = np.einsum("mi,m->i", F, self.y)
        coef = np.linalg.lstsq(G, g, rcond=1e-10)[0]
        return max(self.yy - float(g @ coef), 0.0)


def fit_friction_shapes(
    model: Model,
    signals: Sequence[ArmSignals],
    picks: Sequence[NDArray[np.intp]],
    target: NDArray[np.float64],
    others: Sequence[NDArray[np.float64]],
    *,
    rows: int = SHAPE_ROWS,
    rng: np.random.Generator | None = None,
) -> dict[str, JointModel]:
    """Per joint, the nonlinear shape of its friction law, by variable projection.

    For joint ``k`` the motor torque left once the rigid bodies are taken out, ``target[:, k]``
    (smoothed, at the picked samples), is regressed on the friction law's linear columns
    (smoothed alike) and the joint's other columns ``others[k]`` (rotor inertia, PDTV); the
    law's transition width ``zero_velocity``, Stribeck velocity and exponent are chosen for the
    smallest residual: a log-spaced grid scaled by the joint's observed motor speed range (the
    99th percentile of ``|N qd|``: :data:`SHAPE_WIDTHS`, :data:`SHAPE_STRIBECK`, for each of
    :data:`SHAPE_EXPONENTS`), refined by Nelder-Mead on the logarithms of the two velocities.
    The smooth (``tanh``) transition is fitted. Only :class:`StribeckFriction` laws are
    shaped; other laws are returned unchanged.

    The smoothing of the friction columns is approximated, for the search only, by the
    differentiator's kernel on a uniform grid at the log's median step (gathered around each
    picked sample); the caller refits with the exact columns.

    Returns
    -------
    dict
        The joint models with their friction laws' shapes replaced.
    """
    from scipy.optimize import minimize

    gen = rng if rng is not None else np.random.default_rng(0)
    m = target.shape[0]
    sub = np.sort(gen.choice(m, size=min(rows, m), replace=False))
    kernels = [_kernel(sig.t, sig.window) for sig in signals]
    out = dict(model.joints)
    for k, joint in enumerate(model.robot.joints):
        jm = model.joints[joint.name]
        law = jm.friction
        if not isinstance(law, StribeckFriction):
            continue
        gear = float(signals[0].gear[k])
        windows = []
        for sig, idx, (offsets, _) in zip(signals, picks, kernels, strict=True):
            at = np.clip(idx[:, None] + offsets[None, :], 0, sig.t.size - 1)
            windows.append(gear * sig.qd[at, k])
        if len({w.shape[1] for w in windows}) != 1:
            continue  # logs at different rates: keep the law as given
        weights = kernels[0][1]
        velocity = np.concatenate(windows, axis=0)[sub]
        y = target[sub, k]
        other = others[k][sub]
        scale = float(np.percentile(np.abs(velocity[:, velocity.shape[1] // 2]), 99))
        if not scale > 0:
            continue

        problem = _ShapeProblem(law, velocity, weights, other, y)
        rss = problem.rss

        best = (math.inf, np.array([law.zero_velocity, law.stribeck_velocity, 1.0]))
        for exponent in SHAPE_EXPONENTS:
            for wr in SHAPE_WIDTHS:
                for sr in SHAPE_STRIBECK:
                    params = np.array([wr * scale, sr * scale, exponent])
                    value = rss(params)
                    if value < best[0]:
                        best = (value, params)
        exponent = float(best[1][2])

        lo = np.log([SHAPE_WIDTHS[0] * scale, SHAPE_STRIBECK[0] * scale])
        hi = np.log([SHAPE_WIDTHS[-1] * scale, SHAPE_STRIBECK[-1] * scale])

        def rss_log(
            z: NDArray[np.float64],
            exponent: float = exponent,
            rss: Any = rss,
            lo: NDArray[np.float64] = lo,
            hi: NDArray[np.float64] = hi,
        ) -> float:
            w, v = np.exp(np.clip(z, lo, hi))  # within the searched grid's bounds
            return float(rss(np.array([w, v, exponent])))

        start = np.log(best[1][:2])
        refined = minimize(
            rss_log,
            start,
            method="Nelder-Mead",
            options={"xatol": 0.02, "fatol": 1e-12, "maxfev": 60, "initial_simplex": None},
        )
        z = np.clip(refined.x, lo, hi) if refined.fun < best[0] else start
        params = np.array([math.exp(z[0]), math.exp(z[1]), exponent])
        out[joint.name] = dataclasses.replace(jm, friction=_shape_of(law, params))
    return out


CONTACT_SEGMENT = 4.0
"""With ``exclude_contact``: the trimmed start works on stretches of this many differentiator
windows ..."""
CONTACT_STARTS = 6
"""... from this many random halves of the stretches ..."""
CONTACT_CSTEPS = 5
"""... each improved by at most this many concentration steps."""


def _trimmed_start(
    residual_of: Any,
    signals: Sequence[ArmSignals],
    picks: Sequence[NDArray[np.intp]],
    *,
    rng: np.random.Generator | None = None,
) -> NDArray[np.bool_]:
    """Rows of the half of the logs' stretches best fitted: least trimmed squares over time.

    The logs are cut into stretches of :data:`CONTACT_SEGMENT` differentiator windows. From
    each of :data:`CONTACT_STARTS` random halves of the stretches, concentration steps
    (Rousseeuw & Van Driessen 2006): fit on the half, score every stretch by the median over
    its rows of the largest joint residual (in each joint's robust standard deviation of the
    all-rows fit), keep the best-scored half, until it no longer changes. The half with the
    smallest total score wins.
    """
    gen = rng if rng is not None else np.random.default_rng(0)
    labels = []
    offset = 0
    for sig, idx in zip(signals, picks, strict=True):
        span = CONTACT_SEGMENT * sig.window
        seg = np.floor((sig.t[idx] - sig.t[0]) / span).astype(np.intp)
        _, seg = np.unique(seg, return_inverse=True)
        labels.append(seg + offset)
        offset += int(seg.max()) + 1 if seg.size else 0
    label = np.concatenate(labels)
    n_seg = offset
    h = max(1, n_seg // 2)
    if n_seg < 4:
        return np.ones(label.size, dtype=bool)
    counts = np.bincount(label, minlength=n_seg)

    # one scale per joint for every start (the all-rows fit's), so that totals compare
    r_all = residual_of(np.ones(label.size, dtype=bool))
    scale = 1.4826 * np.median(np.abs(r_all - np.median(r_all, axis=0)), axis=0) + 1e-300

    def scores(r: NDArray[np.float64], rows: NDArray[np.bool_]) -> NDArray[np.float64]:
        centre = np.median(r[rows], axis=0)
        z = np.max(np.abs(r - centre) / scale, axis=1)
        out = np.full(n_seg, np.inf)
        order = np.argsort(label, kind="stable")
        bounds = np.concatenate([[0], np.cumsum(counts)])
        zs = z[order]
        for k in range(n_seg):
            if counts[k]:
                out[k] = float(np.median(zs[bounds[k] : bounds[k + 1]]))
        return out

    best_total, best_rows = math.inf, np.ones(label.size, dtype=bool)
    for _ in range(CONTACT_STARTS):
        chosen = np.sort(gen.choice(n_seg, size=h, replace=False))
        for _ in range(CONTACT_CSTEPS):
            rows = np.isin(label, chosen)
            sc = scores(residual_of(rows), rows)
            new = np.sort(np.argsort(sc, kind="stable")[:h])
            if np.array_equal(new, chosen):
                break
            chosen = new
        rows = np.isin(label, chosen)
        total = float(np.sum(np.sort(scores(residual_of(rows), rows))[:h]))
        if total < best_total:
            best_total, best_rows = total, rows
    return best_rows


def contact_free_rows(
    residual_of: Any,
    signals: Sequence[ArmSignals],
    picks: Sequence[NDArray[np.intp]],
    *,
    threshold: float = CONTACT_THRESHOLD,
    margin: float = CONTACT_MARGIN,
    iterations: int = CONTACT_ITERATIONS,
    rng: np.random.Generator | None = None,
    start: NDArray[np.bool_] | None = None,
) -> NDArray[np.bool_]:
    """Rows free of contact, by a trimmed fit and iterated residual-based rejection.

    ``residual_of(rows)`` fits the model on the rows marked True and returns the residual
    (m, nj) of every row. A least-squares fit on all rows would absorb much of a contact that
    recurs with the same motion (a leg's stance phases, always while the foot moves backwards,
    look like friction asymmetry and gravity) and hide it; so the start is a least trimmed
    squares fit over stretches of time (:func:`_trimmed_start`: the half of the log's
    stretches that the model fits best). From there a row is rejected when any joint's residual
    exceeds ``threshold`` robust standard deviations of the trimmed fit's residuals (1.4826
    times their median absolute deviation; held fixed, since refits on fewer rows fit tighter
    and would reject ever more), and so is every row within ``margin`` differentiator windows
    of a rejected one in time (contact lasts, and its onset is small); refit on the rest and
    repeat until the set no longer changes (at most ``iterations`` fits, never below a tenth
    of the rows).

    ``start`` replaces the trimmed start (rows to fit first).

    Returns
    -------
    ndarray of bool
        Shape (m,), True for the rows to identify from.
    """
    m = sum(p.size for p in picks)
    keep = _trimmed_start(residual_of, signals, picks, rng=rng) if start is None else start
    scale = None
    for _ in range(iterations):
        r = residual_of(keep)
        centre = np.median(r[keep], axis=0)
        if scale is None:  # the trimmed fit's: held, or refits on ever fewer rows spiral down
            scale = 1.4826 * np.median(np.abs(r[keep] - centre), axis=0) + 1e-300
        bad = np.any(np.abs(r - centre) > threshold * scale, axis=1)
        new = np.ones(m, dtype=bool)
        offset = 0
        for sig, idx in zip(signals, picks, strict=True):
            rows = slice(offset, offset + idx.size)
            offset += idx.size
            hit = idx[bad[rows]]
            if hit.size == 0:
                continue
            # every picked sample within margin * window of a rejected one
            t_hit = sig.t[hit]
            t_idx = sig.t[idx]
            pos = np.searchsorted(t_hit, t_idx)
            before = np.abs(t_idx - t_hit[np.clip(pos - 1, 0, hit.size - 1)])
            after = np.abs(t_hit[np.clip(pos, 0, hit.size - 1)] - t_idx)
            near = np.minimum(before, after) <= margin * sig.window
            new[rows] = ~near
        if np.array_equal(new, keep) or np.count_nonzero(new) < 0.1 * m:
            break
        keep = new
    return keep
