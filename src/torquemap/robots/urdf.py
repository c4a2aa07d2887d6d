"""Serial robots described by a URDF: kinematics and rigid-body dynamics through Pinocchio.

The robot file (docs/formats.md) names the URDF, the end-effector frame, the gravity vector and
the actuated joints; every other movable joint of the URDF is locked at zero
(``pinocchio.buildReducedModel``). All arrays are in the robot file's joint order, joint side.

Inertial parameters follow Pinocchio's convention: per moving body (one per actuated joint, the
links rigidly fixed to it merged in), ten values in the joint's frame,
``[m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]`` with the inertia about the joint
frame's origin (Atkeson, An and Hollerbach 1986). Inverse dynamics is linear in them,
``tau = Y(q, qd, qdd) pi``. Only a few combinations (the *base* parameters) are identifiable from
joint torques; they are found once per arm by a QR decomposition with column pivoting of the
regressor stacked over random states (Gautier 1990), ``beta = pi_b + K pi_d``.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.robots import WrenchResult, register_arm

PARAMETER_SUFFIXES: tuple[str, ...] = (
    "m",
    "mx",
    "my",
    "mz",
    "Ixx",
    "Ixy",
    "Iyy",
    "Ixz",
    "Iyz",
    "Izz",
)
"""Names of the ten inertial parameters of one body, in Pinocchio's order."""

_MOVABLE = {"revolute", "continuous", "prismatic"}
_BASE_SAMPLES = 60
_RANK_TOLERANCE = 1e-8
DAMPING = 1e-3
"""Default damping of the pseudo-inverse of ``J^T`` [m]."""
SINGULAR_THRESHOLD = 0.02
"""Default smallest singular value of the end-effector Jacobian [m] below which a pose is
flagged singular (a 1 N m joint-torque error then maps to 50 N or more)."""


def _urdf_error(message: str, path: Path) -> InputError:
    return InputError(message, path=path)


def check_urdf(path: Path) -> ET.Element:
    """Parse and check a URDF: one tree of links with a fixed base and no closed chains.

    Parameters
    ----------
    path
        The URDF file.

    Returns
    -------
    xml.etree.ElementTree.Element
        The ``<robot>`` element.

    Raises
    ------
    InputError
        Naming the file: missing, not XML, not a ``<robot>``, a joint without parent or child,
        a joint name used twice, a link with two parents (closed chain), a floating or planar
        joint (a fixed base is needed), several root links.
    """
    if not path.exists():
        raise _urdf_error("URDF file not found", path)
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise _urdf_error(f"not a valid URDF (XML error: {exc})", path) from None
    except OSError as exc:
        raise _urdf_error(f"cannot read URDF: {exc.strerror}", path) from None
    if root.tag != "robot":
        raise _urdf_error(f"not a URDF: the root element is <{root.tag}>, not <robot>", path)
    links = [e.get("name") for e in root.findall("link")]
    if not links or any(not name for name in links):
        raise _urdf_error("URDF has no links, or a link without a name", path)
    if len(set(links)) != len(links):
        dup = next(n for n in links if links.count(n) > 1)
        raise _urdf_error(f"URDF link {dup!r} is defined twice", path)
    parent_of: dict[str, str] = {}
    seen: set[str] = set()
    unlimited: list[tuple[str, str]] = []
    for joint in root.findall("joint"):
        name = joint.get("name") or ""
        kind = joint.get("type") or ""
        if not name:
            raise _urdf_error("URDF has a joint without a name", path)
        if name in seen:
            raise _urdf_error(f"URDF joint {name!r} is defined twice", path)
        seen.add(name)
        parent = joint.find("parent")
        child = joint.find("child")
        p = None if parent is None else parent.get("link")
        c = None if child is None else child.get("link")
        if not p or not c:
            raise _urdf_error(f"URDF joint {name!r} lacks a parent or child link", path)
        for link in (p, c):
            if link not in links:
                raise _urdf_error(f"URDF joint {name!r} refers to undefined link {link!r}", path)
        if kind in ("floating", "planar"):
            raise _urdf_error(
                f"URDF joint {name!r} is {kind}: torquemap needs a fixed-base arm", path
            )
        if kind not in (*_MOVABLE, "fixed"):
            raise _urdf_error(f"URDF joint {name!r} has unknown type {kind!r}", path)
        if kind in ("revolute", "prismatic") and joint.find("limit") is None:
            unlimited.append((name, kind))
        limit = joint.find("limit")
        if kind in ("revolute", "prismatic") and limit is not None:
            # urdfdom refuses it with C++ lines on stderr, then Pinocchio with "The XML stream
            # does not contain a valid URDF model" (new-user QA, stop 37)
            missing = [key for key in ("effort", "velocity") if limit.get(key) is None]
            if missing:
                raise _urdf_error(
                    f"URDF joint {name!r} has a <limit> without {' or '.join(missing)} "
                    "(both are required for a revolute or prismatic joint)",
                    path,
                )
        if c in parent_of:
            raise _urdf_error(
                f"closed chain: link {c!r} has two parent joints ({parent_of[c]!r} and "
                f"{name!r}); torquemap needs a serial chain or tree",
                path,
            )
        parent_of[c] = name
    roots = [n for n in links if n not in parent_of]
    if len(roots) != 1:
        raise _urdf_error(
            f"URDF links form {len(roots)} separate trees (roots {', '.join(map(str, roots))});"
            " torquemap needs one",
            path,
        )
    if unlimited:
        # urdfdom refuses it with C++ lines on stderr and Pinocchio with "The XML stream does
        # not contain a valid URDF model"
        name, kind = unlimited[0]
        raise _urdf_error(
            f"URDF joint {name!r} is {kind} but has no <limit> (lower, upper, effort, "
            'velocity); one that turns without limits is type "continuous"',
            path,
        )
    return root


@dataclass(frozen=True, slots=True)
class _Index:
    """Where file joint k sits in the reduced Pinocchio model."""

    joint_id: int
    idx_q: int
    nq: int
    idx_v: int
    turns: bool = True  # revolute or continuous, not prismatic


@dataclass(frozen=True, slots=True, eq=False)
class BaseParameters:
    """The identifiable combinations of an arm's inertial parameters.

    ``beta = pi[independent] + combination @ pi[dependent]`` and
    ``Y(q, qd, qdd) @ pi == Y[:, independent] @ beta`` for every state.

    Attributes
    ----------
    independent
        Indices into the full parameter vector of the columns kept, shape (p,).
    dependent
        Indices of the other columns, shape (10 nb - p,).
    combination
        Shape (p, 10 nb - p) [-, or m, m^2 between mass and moment columns].
    """

    independent: NDArray[np.intp]
    dependent: NDArray[np.intp]
    combination: NDArray[np.float64]

    def project(self, full: ArrayLike) -> NDArray[np.float64]:
        """Base parameters of a full parameter vector ``full``, shape (..., 10 nb) -> (..., p)."""
        pi = np.asarray(full, dtype=np.float64)
        out: NDArray[np.float64] = (
            pi[..., self.independent] + pi[..., self.dependent] @ self.combination.T
        )
        return out

    def matrix(self, n_full: int) -> NDArray[np.float64]:
        """The (p, 10 nb) matrix ``B`` with ``beta = B @ pi``."""
        b = np.zeros((self.independent.size, n_full))
        b[np.arange(self.independent.size), self.independent] = 1.0
        b[:, self.dependent] = self.combination
        return b


@register_arm
@dataclass(frozen=True, slots=True, eq=False)
class UrdfArm:
    """An arm read from a URDF (the ``urdf`` kind of ``torquemap.robots``).

    Build with :func:`urdf_arm` or :func:`arm_from_table`. ``full_parameters`` holds the ten
    inertial parameters of every moving body; it starts as the URDF's and
    :meth:`with_full_parameters` / :meth:`with_parameters` return an arm with identified ones.

    Attributes
    ----------
    urdf
        The URDF path as written in the robot file (relative to it, or absolute).
    urdf_path
        The resolved URDF path.
    end_effector
        Name of the end-effector frame (a URDF link or joint).
    gravity
        Gravity acceleration in the base frame [m/s^2].
    joint_names
        Actuated joints, in the robot file's order.
    full_parameters
        Shape (10 nb,), Pinocchio's order (bodies in the order of ``body_names``).
    nominal_parameters
        The URDF's values of ``full_parameters``.
    body_names
        The moving bodies, named by the joint that moves each one, in Pinocchio's order.
    base
        The base-parameter reduction.
    """

    kind: ClassVar[str] = "urdf"
    head_keys: ClassVar[frozenset[str]] = frozenset({"urdf", "end_effector", "gravity", "inertial"})

    urdf: str
    urdf_path: Path
    end_effector: str
    gravity: tuple[float, float, float]
    joint_names: tuple[str, ...]
    full_parameters: NDArray[np.float64]
    nominal_parameters: NDArray[np.float64]
    body_names: tuple[str, ...]
    base: BaseParameters
    _model: Any = field(repr=False)
    _frame: int = field(repr=False)
    _index: tuple[_Index, ...] = field(repr=False)

    # ---------------------------------------------------------------- description
    @property
    def has_dynamics(self) -> bool:
        """True: the URDF's rigid bodies are modelled."""
        return True

    @classmethod
    def from_table(
        cls,
        head: Mapping[str, Any],
        joint_names: tuple[str, ...],
        *,
        path: str | os.PathLike[str] | None = None,
        base_dir: str | os.PathLike[str] | None = None,
    ) -> UrdfArm:
        """From the ``[robot]`` table of a robot file (see :func:`arm_from_table`)."""
        return arm_from_table(head, joint_names, path=path, base_dir=base_dir)

    @property
    def wrench_axes(self) -> tuple[str, ...]:
        """``("fx", "fy", "fz")``, and ``("mx", "my", "mz")`` too with six or more joints."""
        if len(self.joint_names) >= 6:
            return ("fx", "fy", "fz", "mx", "my", "mz")
        return ("fx", "fy", "fz")

    @property
    def full_parameter_names(self) -> tuple[str, ...]:
        """``<body>.<m|mx|...|Izz>`` for every entry of ``full_parameters``."""
        return tuple(f"{b}.{s}" for b in self.body_names for s in PARAMETER_SUFFIXES)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Base parameters, each named after the full parameter it is built on."""
        names = self.full_parameter_names
        return tuple(names[i] for i in self.base.independent)

    @property
    def position_limits(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(lower, upper) joint limits [rad or m] from the URDF, file order (±inf if none)."""
        lo = np.empty(len(self._index))
        hi = np.empty(len(self._index))
        m = self._model
        for k, ix in enumerate(self._index):
            if ix.nq == 2:
                lo[k], hi[k] = -np.inf, np.inf
            else:
                lo[k] = m.lowerPositionLimit[ix.idx_q]
                hi[k] = m.upperPositionLimit[ix.idx_q]
        return lo, hi

    @property
    def angle_period(self) -> NDArray[np.float64]:
        """Shape (nj,): the travel after which each joint's pose repeats, ``2 pi`` [rad] for
        a revolute or continuous joint (its kinematics and dynamics are ``2 pi``-periodic,
        whatever its limits), ``inf`` for a prismatic one."""
        return np.array([2.0 * np.pi if ix.turns else np.inf for ix in self._index])

    @property
    def velocity_limits(self) -> NDArray[np.float64]:
        """Joint speed limits [rad/s or m/s] from the URDF, file order (inf if none)."""
        v = np.array([self._model.velocityLimit[ix.idx_v] for ix in self._index], dtype=float)
        return np.where(v > 0, v, np.inf)

    def parameters(self) -> NDArray[np.float64]:
        """Base parameters of the current full parameters, shape (p,)."""
        return self.base.project(self.full_parameters)

    def with_full_parameters(self, values: ArrayLike) -> UrdfArm:
        """The same arm with full inertial parameters ``values``, shape (10 nb,)."""
        pi = np.array(values, dtype=np.float64)
        if pi.shape != self.full_parameters.shape:
            raise ValueError(f"expected {self.full_parameters.size} parameters, got {pi.shape}")
        model = self._model.copy()
        for b in range(len(self.body_names)):
            model.inertias[b + 1] = pin.Inertia.FromDynamicParameters(pi[10 * b : 10 * b + 10])
        return replace(self, full_parameters=pi, _model=model)

    def with_parameters(self, values: ArrayLike) -> UrdfArm:
        """The same arm with base parameters ``values``, shape (p,).

        The full vector keeps the current dependent parameters and moves the independent ones
        so that its base parameters are ``values`` (the dynamics are then exactly those of
        ``values``; the full vector is one of many that give them).
        """
        beta = np.asarray(values, dtype=np.float64)
        if beta.shape != (self.base.independent.size,):
            raise ValueError(f"expected {self.base.independent.size} base parameters")
        pi = self.full_parameters.copy()
        pi[self.base.independent] += beta - self.parameters()
        return self.with_full_parameters(pi)

    # ---------------------------------------------------------------- helpers
    def _configs(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """Pinocchio configurations (n, nq) of joint positions (n, nj); locked joints at 0."""
        cfg = np.tile(pin.neutral(self._model), (q.shape[0], 1))
        for k, ix in enumerate(self._index):
            if ix.nq == 2:
                cfg[:, ix.idx_q] = np.cos(q[:, k])
                cfg[:, ix.idx_q + 1] = np.sin(q[:, k])
            else:
                cfg[:, ix.idx_q] = q[:, k]
        return cfg

    def _tangents(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        v = np.zeros((x.shape[0], self._model.nv))
        v[:, self._order()] = x
        return v

    def _order(self) -> NDArray[np.intp]:
        return np.array([ix.idx_v for ix in self._index], dtype=np.intp)

    def _rows(self, *arrays: ArrayLike) -> list[NDArray[np.float64]]:
        nj = len(self.joint_names)
        out = []
        for a in arrays:
            x = np.atleast_2d(np.asarray(a, dtype=np.float64))
            if x.shape[-1] != nj:
                raise ValueError(f"expected shape (n, {nj}), got {np.shape(a)}")
            out.append(x)
        return out

    # ---------------------------------------------------------------- kinematics
    def forward_kinematics(self, q: ArrayLike) -> NDArray[np.float64]:
        """End-effector position [m] in the base frame, shape (n, 3) for ``q`` (n, nj) [rad]."""
        (qq,) = self._rows(q)
        data = self._model.createData()
        out = np.empty((qq.shape[0], 3))
        for i, row in enumerate(self._configs(qq)):
            pin.framesForwardKinematics(self._model, data, row)
            out[i] = data.oMf[self._frame].translation
        return out

    def end_effector_rotation(self, q: ArrayLike) -> NDArray[np.float64]:
        """End-effector orientation in the base frame, shape (n, 3, 3)."""
        (qq,) = self._rows(q)
        data = self._model.createData()
        out = np.empty((qq.shape[0], 3, 3))
        for i, row in enumerate(self._configs(qq)):
            pin.framesForwardKinematics(self._model, data, row)
            out[i] = data.oMf[self._frame].rotation
        return out

    def spatial_jacobian(self, q: ArrayLike) -> NDArray[np.float64]:
        """Shape (n, 6, nj): rows (vx, vy, vz, wx, wy, wz) of the end-effector origin, base axes."""
        (qq,) = self._rows(q)
        data = self._model.createData()
        order = self._order()
        out = np.empty((qq.shape[0], 6, len(self.joint_names)))
        for i, row in enumerate(self._configs(qq)):
            J = pin.computeFrameJacobian(
                self._model, data, row, self._frame, pin.LOCAL_WORLD_ALIGNED
            )
            # Pinocchio hands a one-joint model's (6, 1) Jacobian back as shape (6,)
            out[i] = np.reshape(J, (6, self._model.nv))[:, order]
        return out

    def jacobian(self, q: ArrayLike) -> NDArray[np.float64]:
        """Shape (n, len(wrench_axes), nj): the rows of :meth:`spatial_jacobian` for the axes."""
        return self.spatial_jacobian(q)[:, : len(self.wrench_axes), :]

    def inertia_modulation(self, q: ArrayLike) -> NDArray[np.float64]:
        """Zeros, shape (n, nj): the arm's link inertia is in its rigid-body dynamics."""
        (qq,) = self._rows(q)
        return np.zeros_like(qq)

    # ---------------------------------------------------------------- dynamics
    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Joint torque ``M(q) qdd + C(q, qd) qd + g(q)`` [N m], shape (n, nj) (RNEA)."""
        qq, vv, aa = self._rows(q, qd, qdd)
        data = self._model.createData()
        order = self._order()
        out = np.empty_like(qq)
        cq, cv, ca = self._configs(qq), self._tangents(vv), self._tangents(aa)
        for i in range(qq.shape[0]):
            tau = pin.rnea(self._model, data, cq[i], cv[i], ca[i])
            out[i] = tau[order]
        return out

    def full_regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Shape (n, nj, 10 nb): ``inverse_dynamics == full_regressor @ full_parameters``."""
        qq, vv, aa = self._rows(q, qd, qdd)
        data = self._model.createData()
        order = self._order()
        out = np.empty((qq.shape[0], len(order), self.full_parameters.size))
        cq, cv, ca = self._configs(qq), self._tangents(vv), self._tangents(aa)
        for i in range(qq.shape[0]):
            Y = pin.computeJointTorqueRegressor(self._model, data, cq[i], cv[i], ca[i])
            # a one-joint model's (1, 10) regressor comes back as shape (10,)
            out[i] = np.reshape(Y, (self._model.nv, -1))[order]
        return out

    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Shape (n, nj, p): ``inverse_dynamics == regressor @ parameters()`` (base parameters)."""
        return self.full_regressor(q, qd, qdd)[:, :, self.base.independent]

    def mass_matrix(self, q: ArrayLike) -> NDArray[np.float64]:
        """Joint-space inertia ``M(q)`` [kg m^2], shape (n, nj, nj) (CRBA)."""
        (qq,) = self._rows(q)
        data = self._model.createData()
        order = self._order()
        nv = self._model.nv
        raw = np.empty((qq.shape[0], nv, nv))
        for i, row in enumerate(self._configs(qq)):
            raw[i] = pin.crba(self._model, data, row)
        upper = np.triu(np.ones((nv, nv), dtype=bool))
        full = np.where(upper, raw, np.swapaxes(raw, 1, 2))  # CRBA fills the upper triangle
        out: NDArray[np.float64] = full[:, order][:, :, order]
        return out

    def coriolis_matrix(self, q: ArrayLike, qd: ArrayLike) -> NDArray[np.float64]:
        """``C(q, qd)`` [N m s], shape (n, nj, nj), with ``dM/dt = C + C^T``."""
        qq, vv = self._rows(q, qd)
        data = self._model.createData()
        order = self._order()
        nv = self._model.nv
        raw = np.empty((qq.shape[0], nv, nv))
        cq, cv = self._configs(qq), self._tangents(vv)
        for i in range(qq.shape[0]):
            raw[i] = pin.computeCoriolisMatrix(self._model, data, cq[i], cv[i])
        out: NDArray[np.float64] = raw[:, order][:, :, order]
        return out

    def gravity_torque(self, q: ArrayLike) -> NDArray[np.float64]:
        """``g(q)`` [N m], shape (n, nj)."""
        (qq,) = self._rows(q)
        data = self._model.createData()
        order = self._order()
        out = np.empty_like(qq)
        for i, row in enumerate(self._configs(qq)):
            out[i] = pin.computeGeneralizedGravity(self._model, data, row)[order]
        return out

    # ---------------------------------------------------------------- wrench
    def wrench_map(
        self,
        q: ArrayLike,
        *,
        damping: float = DAMPING,
        singular_threshold: float | None = None,
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """The damped pseudo-inverse of ``J^T`` and the singular-pose mask.

        Parameters
        ----------
        q
            Joint positions [rad], shape (n, nj).
        damping
            ``lambda`` in ``A = (J J^T + lambda^2 I)^-1 J`` [m, the force rows' unit].
        singular_threshold
            Poses whose Jacobian's smallest singular value is below this [m] are singular
            (default :data:`SINGULAR_THRESHOLD`).

        Returns
        -------
        (A, singular)
            ``A`` of shape (n, len(wrench_axes), nj) with ``wrench = A @ tau``; ``singular``
            of shape (n,).
        """
        (qq,) = self._rows(q)
        J = self.jacobian(qq)
        m = J.shape[1]
        gram = J @ np.swapaxes(J, 1, 2) + damping**2 * np.eye(m)
        A = np.asarray(np.linalg.solve(gram, J), dtype=np.float64)
        guard = SINGULAR_THRESHOLD if singular_threshold is None else singular_threshold
        s = np.linalg.svd(J, compute_uv=False)
        return A, s[:, -1] < guard

    def wrench_from_joint_torque(
        self,
        q: ArrayLike,
        tau: ArrayLike,
        *,
        singular_threshold: float | None = None,
        damping: float = DAMPING,
    ) -> WrenchResult:
        """Wrench exerted by the environment on the end effector from joint torques.

        Solves ``J(q)^T w = tau`` through the damped pseudo-inverse of :meth:`wrench_map`
        (least squares with seven or more joints, the smallest wrench with fewer than the
        wrench's components).

        Parameters
        ----------
        q
            Joint positions [rad], shape (n, nj).
        tau
            External joint torques [N m] (exerted by the environment), shape (n, nj).
        singular_threshold
            Smallest singular value of the Jacobian [m] below which a pose is flagged
            singular (default :data:`SINGULAR_THRESHOLD`); the wrench there is NaN.
        damping
            Damping of the pseudo-inverse [m].

        Returns
        -------
        WrenchResult
            Wrench rows in the order of :attr:`wrench_axes` [N, N m] and the singular mask.
        """
        qq, tt = self._rows(q, tau)
        A, singular = self.wrench_map(qq, damping=damping, singular_threshold=singular_threshold)
        w = np.einsum("nij,nj->ni", A, tt)
        w[singular] = np.nan
        return WrenchResult(wrench=w, singular=singular)

    # ---------------------------------------------------------------- files
    def inertial_table(self) -> dict[str, dict[str, Any]]:
        """``{body: {mass, com, inertia}}`` of the current parameters (the URDF's convention:
        centre of mass [m] in the joint frame, inertia about it ``[ixx, ixy, ixz, iyy, iyz, izz]``
        [kg m^2])."""
        out: dict[str, dict[str, Any]] = {}
        for b, name in enumerate(self.body_names):
            inertia = pin.Inertia.FromDynamicParameters(self.full_parameters[10 * b : 10 * b + 10])
            inertia_matrix = inertia.inertia
            out[name] = {
                "mass": float(inertia.mass),
                "com": [float(x) for x in inertia.lever],
                "inertia": [
                    float(inertia_matrix[0, 0]),
                    float(inertia_matrix[0, 1]),
                    float(inertia_matrix[0, 2]),
                    float(inertia_matrix[1, 1]),
                    float(inertia_matrix[1, 2]),
                    float(inertia_matrix[2, 2]),
                ],
            }
        return out

    def to_dict(self) -> dict[str, Any]:
        """The ``[robot]`` entries of this kind (with ``[robot.inertial]`` when identified)."""
        out: dict[str, Any] = {
            "kinematics": "urdf",
            "urdf": self.urdf,
            "end_effector": self.end_effector,
            "gravity": list(self.gravity),
        }
        if not np.array_equal(self.full_parameters, self.nominal_parameters):
            out["inertial"] = self.inertial_table()
        return out


def _body_parameters(spec: Any, where: str, path: str | None) -> NDArray[np.float64]:
    if not isinstance(spec, Mapping):
        raise InputError(f"{where} must be a table", path=path)
    allowed = {"mass", "com", "inertia"}
    for key in spec:
        if key not in allowed:
            raise InputError(
                f"unknown key {key!r} in {where} (allowed: {', '.join(sorted(allowed))})",
                path=path,
            )
    for key, size in (("mass", 0), ("com", 3), ("inertia", 6)):
        if key not in spec:
            raise InputError(f"{where} is missing {key}", path=path)
        value = spec[key]
        values = [value] if size == 0 else value
        if (
            (size and (not isinstance(value, list) or len(value) != size))
            or any(isinstance(v, bool) or not isinstance(v, int | float) for v in values)
            or not all(math.isfinite(v) for v in values)
        ):
            shape = "a finite number" if size == 0 else f"a list of {size} finite numbers"
            raise InputError(f"{where} {key} must be {shape}", path=path)
    ixx, ixy, ixz, iyy, iyz, izz = (float(v) for v in spec["inertia"])
    inertia = pin.Inertia(
        float(spec["mass"]),
        np.array(spec["com"], dtype=float),
        np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]),
    )
    out: NDArray[np.float64] = np.asarray(inertia.toDynamicParameters(), dtype=np.float64)
    return out


def urdf_arm(
    urdf_path: str | os.PathLike[str],
    joint_names: Sequence[str],
    *,
    end_effector: str,
    gravity: Sequence[float] = (0.0, 0.0, -9.81),
    urdf: str | None = None,
    inertial: Mapping[str, Any] | None = None,
    path: str | os.PathLike[str] | None = None,
) -> UrdfArm:
    """Build a :class:`UrdfArm`.

    Parameters
    ----------
    urdf_path
        The URDF file.
    joint_names
        The actuated URDF joints, in the order the logs and outputs use.
    end_effector
        A URDF link or joint name: the frame whose origin is the end effector.
    gravity
        Gravity acceleration in the base frame [m/s^2].
    urdf
        The path as written in the robot file (defaults to ``urdf_path``).
    inertial
        Optional ``{joint: {mass, com, inertia}}`` overriding the URDF's inertial parameters
        of the bodies (an identified model's ``[robot.inertial]``).
    path
        The robot file, for error messages.

    Returns
    -------
    UrdfArm
        The arm.

    Raises
    ------
    InputError
        On a bad URDF (see :func:`check_urdf`), a joint the URDF lacks or that is fixed, a joint
        listed twice, an unknown end effector, a bad gravity or inertial table.
    """
    file = Path(urdf_path)
    p = None if path is None else os.fspath(path)
    root = check_urdf(file)
    joint_types = {j.get("name"): j.get("type") for j in root.findall("joint")}
    try:
        full = pin.buildModelFromXML(file.read_text())
    except (ValueError, RuntimeError) as exc:
        raise InputError(f"Pinocchio cannot read the URDF ({exc})", path=file) from None
    names = [full.names[i] for i in range(full.njoints)]
    if len(set(joint_names)) != len(joint_names):
        dup = next(n for n in joint_names if list(joint_names).count(n) > 1)
        raise InputError(f"joint {dup!r} is listed twice", path=p)
    for j in joint_names:
        if j not in names:
            fixed = [f.name for f in full.frames if f.type == pin.FrameType.FIXED_JOINT]
            if j in fixed:
                raise InputError(
                    f"joint {j!r} is fixed in {file.name}; it cannot be actuated", path=p
                )
            raise InputError(
                f"joint {j!r} is not a movable joint of {file.name} (it has "
                f"{', '.join(names[1:]) or 'none'})",
                path=p,
            )
    if len(gravity) != 3 or not all(
        isinstance(g, int | float) and not isinstance(g, bool) and math.isfinite(g) for g in gravity
    ):
        raise InputError("[robot] gravity must be [gx, gy, gz], finite numbers [m/s^2]", path=p)
    # Pinocchio reads a <mimic> joint as a free one: listed, it would be driven on its own
    mimics = {
        j.get("name"): m.get("joint")
        for j in root.findall("joint")
        if (m := j.find("mimic")) is not None
    }
    for j in joint_names:
        if j in mimics:
            raise InputError(
                f"joint {j!r} follows {mimics[j]!r} in {file.name} (<mimic>): it is not driven "
                "on its own; leave it out of the robot file (it is then locked at zero)",
                path=p,
            )
    locked = [i for i in range(1, full.njoints) if names[i] not in joint_names]
    model = _locked(full, locked, root, joint_names) if locked else full
    model.gravity = pin.Motion(np.array(gravity, dtype=float), np.zeros(3))
    if not model.existFrame(end_effector):
        links = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
        raise InputError(
            f"end_effector {end_effector!r} is not a link or joint of {file.name} (links: "
            f"{', '.join(links)})",
            path=p,
        )
    # a URDF may give a link and a joint one name (Unitree's Z1: the link and the fixed joint
    # above it; the SO-100's gripper link and the jaw's joint on it): the name is the link's
    kinds = [f.type for f in model.frames if f.name == end_effector]
    kind = pin.FrameType.BODY if pin.FrameType.BODY in kinds else kinds[0]
    frame = model.getFrameId(end_effector, kind)
    index = []
    for j in joint_names:
        jid = model.getJointId(j)
        jm = model.joints[jid]
        if jm.nv != 1:
            raise InputError(
                f"joint {j!r} has {jm.nv} degrees of freedom; torquemap needs 1", path=p
            )
        turns = joint_types.get(j) != "prismatic"
        index.append(_Index(joint_id=jid, idx_q=jm.idx_q, nq=jm.nq, idx_v=jm.idx_v, turns=turns))
    body_names = tuple(model.names[i] for i in range(1, model.njoints))
    nominal = np.concatenate(
        [np.asarray(model.inertias[i].toDynamicParameters()) for i in range(1, model.njoints)]
    )
    arm = UrdfArm(
        urdf=os.fspath(file) if urdf is None else urdf,
        urdf_path=file,
        end_effector=end_effector,
        gravity=(float(gravity[0]), float(gravity[1]), float(gravity[2])),
        joint_names=tuple(joint_names),
        full_parameters=nominal.copy(),
        nominal_parameters=nominal,
        body_names=body_names,
        base=BaseParameters(np.arange(0), np.arange(0), np.zeros((0, 0))),
        _model=model,
        _frame=frame,
        _index=tuple(index),
    )
    arm = replace(arm, base=_base_parameters(arm))
    if inertial:
        pi = nominal.copy()
        for body, spec in inertial.items():
            where = f"[robot.inertial.{body}]"
            if body not in body_names:
                raise InputError(
                    f"{where}: no moving body {body!r} (bodies: {', '.join(body_names)})", path=p
                )
            b = body_names.index(body)
            pi[10 * b : 10 * b + 10] = _body_parameters(spec, where, p)
        arm = replace(arm.with_full_parameters(pi), nominal_parameters=nominal)
    return arm


def _locked(full: Any, locked: list[int], root: ET.Element, joint_names: Sequence[str]) -> Any:
    """``full`` with the joints ``locked`` fixed at zero (Pinocchio's neutral pose)."""
    try:
        return pin.buildReducedModel(full, locked, pin.neutral(full))
    except ValueError:
        # Pinocchio cannot lock a joint that shares its name with a link (the SO-100's
        # gripper); the same model from the URDF with those joints made fixed (at zero)
        copy = ET.fromstring(ET.tostring(root))
        for joint in copy.findall("joint"):
            if joint.get("type") in _MOVABLE and joint.get("name") not in joint_names:
                joint.set("type", "fixed")
        return pin.buildModelFromXML(ET.tostring(copy, encoding="unicode"))


def _random_states(
    arm: UrdfArm, count: int, rng: np.random.Generator
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    lo, hi = arm.position_limits
    lo = np.where(np.isfinite(lo), lo, -np.pi)
    hi = np.where(np.isfinite(hi), hi, np.pi)
    nj = len(arm.joint_names)
    q = lo + (hi - lo) * rng.random((count, nj))
    return q, rng.standard_normal((count, nj)), rng.standard_normal((count, nj))


def _base_parameters(arm: UrdfArm) -> BaseParameters:
    import scipy.linalg

    rng = np.random.default_rng(20240613)
    q, qd, qdd = _random_states(arm, _BASE_SAMPLES, rng)
    W = arm.full_regressor(q, qd, qdd).reshape(-1, arm.full_parameters.size)
    _, R, perm = scipy.linalg.qr(W, mode="economic", pivoting=True)
    diag = np.abs(np.diag(R))
    rank = int(np.sum(diag > _RANK_TOLERANCE * max(diag[0], 1e-300)))
    independent = np.sort(perm[:rank])
    dependent = np.setdiff1d(np.arange(W.shape[1]), independent)
    if dependent.size:
        solved, *_ = np.linalg.lstsq(W[:, independent], W[:, dependent], rcond=None)
        combination = np.asarray(solved, dtype=np.float64)
        combination[np.abs(combination) < 1e-10] = 0.0
    else:
        combination = np.zeros((rank, 0))
    return BaseParameters(independent=independent, dependent=dependent, combination=combination)


def arm_from_table(
    head: Mapping[str, Any],
    joint_names: Sequence[str],
    *,
    path: str | os.PathLike[str] | None,
    base_dir: str | os.PathLike[str] | None,
) -> UrdfArm:
    """Parse the ``[robot]`` table of a ``kinematics = "urdf"`` robot file (docs/formats.md).

    Parameters
    ----------
    head
        The ``[robot]`` table: ``urdf``, ``end_effector``, optional ``gravity``
        (default ``[0, 0, -9.81]``) and optional ``inertial``; ``name`` and ``kinematics``
        are allowed and ignored here.
    joint_names
        The ``[joints.<j>]`` names, in file order.
    path
        The robot file, for messages.
    base_dir
        Folder a relative ``urdf`` path is taken from (the robot file's).
    """
    p = None if path is None else os.fspath(path)
    allowed = {"name", "kinematics", "urdf", "end_effector", "gravity", "inertial"}
    for key in head:
        if key not in allowed:
            raise InputError(
                f"unknown key {key!r} in [robot] (allowed: {', '.join(sorted(allowed))})", path=p
            )
    for key in ("urdf", "end_effector"):
        if not isinstance(head.get(key), str) or not head[key]:
            raise InputError(f"[robot] {key} is missing (kinematics = 'urdf' needs it)", path=p)
    gravity = head.get("gravity", [0.0, 0.0, -9.81])
    if not isinstance(gravity, list):
        raise InputError("[robot] gravity must be [gx, gy, gz], finite numbers [m/s^2]", path=p)
    inertial = head.get("inertial", {})
    if not isinstance(inertial, Mapping):
        raise InputError("[robot.inertial] must be a table", path=p)
    rel = Path(head["urdf"])
    file = rel if rel.is_absolute() or base_dir is None else Path(base_dir) / rel
    return urdf_arm(
        file,
        joint_names,
        end_effector=head["end_effector"],
        gravity=gravity,
        urdf=head["urdf"],
        inertial=inertial,
        path=p,
    )
