"""Kind ``"none"``: independent joints, no end effector and no rigid-body model."""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.robots import WrenchResult, register_arm


def as_joint_array(x: ArrayLike, nj: int, what: str = "q") -> NDArray[np.float64]:
    """``x`` as an (n, nj) float array (one sample may be given as (nj,))."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.shape[1] != nj:
        raise ValueError(f"{what} must have shape (n, {nj}), got {np.shape(x)}")
    return a


@register_arm
@dataclass(frozen=True, slots=True, eq=False)
class NoArm:
    """Joints with no kinematic chain between them (a motor on a bench, a conveyor).

    Inverse dynamics and the regressor are empty: each joint's inertia is the motor-side
    ``InertiaModel`` of the model file.

    Examples
    --------
    >>> NoArm(("m",)).inverse_dynamics([[0.0]], [[1.0]], [[2.0]])
    array([[0.]])
    """

    kind: ClassVar[str] = "none"
    head_keys: ClassVar[frozenset[str]] = frozenset()
    joint_names: tuple[str, ...]
    wrench_axes: tuple[str, ...] = ()
    parameter_names: tuple[str, ...] = ()

    @property
    def has_dynamics(self) -> bool:
        """Always False."""
        return False

    def forward_kinematics(self, q: ArrayLike) -> NDArray[np.float64]:
        """No end effector: NaN positions, shape (n, 3)."""
        a = as_joint_array(q, len(self.joint_names))
        return np.full((a.shape[0], 3), np.nan)

    def jacobian(self, q: ArrayLike) -> NDArray[np.float64]:
        """Empty, shape (n, 0, nj)."""
        a = as_joint_array(q, len(self.joint_names))
        return np.zeros((a.shape[0], 0, a.shape[1]))

    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Zero, shape (n, nj)."""
        return np.zeros_like(as_joint_array(q, len(self.joint_names)))

    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Empty, shape (n, nj, 0)."""
        a = as_joint_array(q, len(self.joint_names))
        return np.zeros((*a.shape, 0))

    def parameters(self) -> NDArray[np.float64]:
        """Empty."""
        return np.zeros(0)

    def with_parameters(self, values: ArrayLike) -> Self:
        """Itself (there are no parameters)."""
        if np.asarray(values).size:
            raise ValueError("kind 'none' has no inertial parameters")
        return self

    def inertia_modulation(self, q: ArrayLike) -> NDArray[np.float64]:
        """Zero, shape (n, nj)."""
        return np.zeros_like(as_joint_array(q, len(self.joint_names)))

    def wrench_from_joint_torque(
        self, q: ArrayLike, tau: ArrayLike, *, singular_threshold: float | None = None
    ) -> WrenchResult:
        """No end effector: an empty wrench, nothing singular."""
        a = as_joint_array(q, len(self.joint_names))
        return WrenchResult(
            wrench=np.zeros((a.shape[0], 0)), singular=np.zeros(a.shape[0], dtype=bool)
        )

    def to_dict(self) -> dict[str, Any]:
        """``{"kinematics": "none"}``."""
        return {"kinematics": self.kind}

    @classmethod
    def from_table(
        cls,
        head: Mapping[str, Any],
        joint_names: tuple[str, ...],
        *,
        path: str | os.PathLike[str] | None = None,
        base_dir: Path | None = None,
    ) -> NoArm:
        """From the ``[robot]`` table (nothing to read)."""
        if not joint_names:
            raise InputError("missing [joints.<name>] tables", path=path)
        return cls(joint_names=tuple(joint_names))
