"""Robots as models of their kinematics and dynamics: one small protocol, several kinds.

Every kind of robot implements :class:`Arm`: joint names, forward kinematics of the end
effector, its Jacobian, inverse dynamics ``M(q) qdd + C(q, qd) qd + g(q)`` and the regressor
that is linear in the inertial parameters, and the map from joint torques to the wrench on the
end effector. Kinds register under the ``kinematics`` value of a robot file: ``"none"``
(independent joints), ``"planar2r"`` (the SCARA's two arms in a plane, gravity free) and
``"urdf"`` (any serial robot, through Pinocchio). Nothing outside this package compares
kinematics strings: estimation, identification, model files and plots talk to the protocol.
All angles and torques here are joint side [rad, N m]; the motors' gears are the robot file's.
"""

from __future__ import annotations

import os
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Protocol, Self, TypeVar, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError


@dataclass(frozen=True, slots=True, eq=False)
class WrenchResult:
    """The wrench on the end effector recovered from joint torques.

    Attributes
    ----------
    wrench
        Force [N] (and moment [N m]) exerted by the environment on the end effector, base
        frame, shape (n, len(arm.wrench_axes)); NaN where ``singular``.
    singular
        True where the pose is too close to a singularity to invert ``J^T``, shape (n,).
    """

    wrench: NDArray[np.float64]
    singular: NDArray[np.bool_]


@runtime_checkable
class Arm(Protocol):
    """What every kind of robot offers (joint side; shapes ``(n, nj)`` for n samples).

    Attributes
    ----------
    kind
        The robot file's ``kinematics`` value.
    head_keys
        Keys of the ``[robot]`` table this kind reads besides ``name`` and ``kinematics``.
    joint_names
        Actuated joints, in the robot file's order.
    wrench_axes
        Names of the wrench components (the estimate's output columns): ``()`` when the kind
        has no end effector, ``("fx", "fy")`` in a plane, ``("fx", "fy", "fz")`` or
        ``("fx", "fy", "fz", "mx", "my", "mz")`` in space.
    parameter_names
        The (base) inertial parameters the regressor is linear in.
    """

    kind: ClassVar[str]
    head_keys: ClassVar[frozenset[str]]
    joint_names: tuple[str, ...]
    wrench_axes: tuple[str, ...]
    parameter_names: tuple[str, ...]

    @property
    def has_dynamics(self) -> bool:
        """True when the rigid bodies' dynamics are modelled (not identically zero)."""
        ...

    def forward_kinematics(self, q: ArrayLike) -> NDArray[np.float64]:
        """End-effector position [m], base frame, shape (n, 3)."""
        ...

    def jacobian(self, q: ArrayLike) -> NDArray[np.float64]:
        """Jacobian, shape (n, len(wrench_axes), nj): rows in ``wrench_axes`` order."""
        ...

    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Joint torques [N m] of the rigid bodies, ``M qdd + C qd + g``, shape (n, nj)."""
        ...

    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Shape (n, nj, p) with ``inverse_dynamics == regressor @ parameters()``."""
        ...

    def parameters(self) -> NDArray[np.float64]:
        """Nominal values (p,) of ``parameter_names`` (the robot description's)."""
        ...

    def with_parameters(self, values: ArrayLike) -> Self:
        """A copy whose inertial parameters are ``values`` (p,)."""
        ...

    def inertia_modulation(self, q: ArrayLike) -> NDArray[np.float64]:
        """Multiplier (n, nj) of each joint's ``InertiaModel.cos_elbow`` term (0 when unused)."""
        ...

    def wrench_from_joint_torque(
        self, q: ArrayLike, tau: ArrayLike, *, singular_threshold: float | None = None
    ) -> WrenchResult:
        """Wrench exerted by the environment on the end effector from joint torques [N m].

        ``singular_threshold``: the kind's guard (default its own), below which a pose is
        flagged singular.
        """
        ...

    def to_dict(self) -> dict[str, Any]:
        """The ``[robot]`` table entries this kind owns (``kinematics`` included)."""
        ...


_A = TypeVar("_A", bound=type)

ARM_KINDS: dict[str, Any] = {}
"""Registered kinds by ``kinematics`` value; each class has ``from_table``."""


def register_arm(cls: _A) -> _A:
    """Class decorator: make a kind of robot readable from robot files."""
    ARM_KINDS[cls.kind] = cls  # type: ignore[attr-defined]
    return cls


def arm_head_keys(kind: str) -> frozenset[str]:
    """The ``[robot]`` keys of ``kind`` (InputError on an unknown kind)."""
    return _kind(kind, None).head_keys  # type: ignore[no-any-return]


def _kind(kind: Any, path: str | None) -> Any:
    _load_builtin_kinds(kind if isinstance(kind, str) else None)
    cls = ARM_KINDS.get(kind) if isinstance(kind, str) else None
    if cls is None:
        known = ", ".join(repr(k) for k in sorted(ARM_KINDS))
        raise InputError(f"[robot] kinematics must be one of {known}, got {kind!r}", path=path)
    return cls


def arm_from_table(
    head: Mapping[str, Any],
    joint_names: Collection[str],
    *,
    path: str | os.PathLike[str] | None = None,
) -> Arm:
    """Build the arm of a robot file from its ``[robot]`` table.

    Parameters
    ----------
    head
        The ``[robot]`` table (``kinematics`` defaults to ``"none"``).
    joint_names
        The robot file's joints, in its order.
    path
        The robot file (files such as a URDF are relative to its folder; errors name it).

    Raises
    ------
    InputError
        On an unknown kind or what the kind finds wrong.

    Examples
    --------
    >>> arm = arm_from_table({"kinematics": "planar2r", "link_lengths": [0.3, 0.2]}, ["a", "b"])
    >>> arm.wrench_axes
    ('fx', 'fy')
    """
    p = None if path is None else os.fspath(path)
    cls = _kind(head.get("kinematics", "none"), p)
    base = Path(p).parent if p is not None else Path.cwd()
    arm: Arm = cls.from_table(head, tuple(joint_names), path=p, base_dir=base)
    return arm


def arm_from_kind(
    kind: str, joint_names: Collection[str], *, link_lengths: tuple[float, ...] = ()
) -> Arm:
    """The arm of the built-in kinds that need no file (``"none"``, ``"planar2r"``)."""
    head: dict[str, Any] = {"kinematics": kind}
    if link_lengths:
        head["link_lengths"] = list(link_lengths)
    return arm_from_table(head, joint_names)


def known_kinds() -> dict[str, Any]:
    """Every kind of robot readable from robot files (:data:`ARM_KINDS`, the optional
    engines' kinds loaded first)."""
    _load_builtin_kinds()
    return ARM_KINDS


def _load_builtin_kinds(kind: str | None = None) -> None:
    # Imported here, not at module import, so that the optional heavy engines of some kinds
    # (Pinocchio) load only when a robot file asks for them: ``kind``, when given, is the one
    # asked for, and the URDF kind (Pinocchio's import costs a fifth of a second) loads only
    # when it is not a built-in light kind.
    from torquemap.robots import none, planar2r  # noqa: F401

    if kind is not None and kind in ARM_KINDS:
        return
    if "urdf" not in ARM_KINDS:
        import importlib.util

        if importlib.util.find_spec("torquemap.robots.urdf") is not None:
            importlib.import_module("torquemap.robots.urdf")


__all__ = [
    "ARM_KINDS",
    "Arm",
    "WrenchResult",
    "arm_from_kind",
    "arm_from_table",
    "arm_head_keys",
    "known_kinds",
    "register_arm",
]
