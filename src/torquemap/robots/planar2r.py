"""Kind ``"planar2r"``: two revolute joints in a horizontal plane (a SCARA's A and B axes).

Kinematics and the force map are :mod:`torquemap.kinematics` (Eqs 2-3 of Simpson et al.). The
rigid-body dynamics use the three base parameters of a planar two-link arm without gravity::

    M = [[a1 + 2 a2 cos q2, a3 + a2 cos q2], [a3 + a2 cos q2, a3]]
    C qd = a2 sin q2 [-(2 qd1 qd2 + qd2^2), qd1^2]

whose values a robot file does not give: they are zero, and the SCARA keeps its motor-side
per-joint inertia (``InertiaModel``: constant plus ``cos_elbow * cos q2`` on the first joint).
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.kinematics import (
    force_from_joint_torque,
    force_map,
    forward_kinematics,
    jacobian,
)
from torquemap.robots import WrenchResult, register_arm
from torquemap.robots.none import as_joint_array


@register_arm
@dataclass(frozen=True, slots=True, eq=False)
class Planar2R:
    """A planar two-link arm (gravity free).

    Attributes
    ----------
    joint_names
        The two joints (shoulder, elbow).
    link_lengths
        ``(l1, l2)`` [m].
    base_parameters
        ``(a1, a2, a3)`` [kg m^2] of the module docstring; zero when unknown.
    min_sin_elbow
        Poses with ``|sin q2|`` below it are singular [-].

    Examples
    --------
    >>> arm = Planar2R(("a", "b"), (0.3, 0.2))
    >>> arm.forward_kinematics([0.0, np.pi / 2]).round(6)
    array([[0.3, 0.2, 0. ]])
    """

    kind: ClassVar[str] = "planar2r"
    head_keys: ClassVar[frozenset[str]] = frozenset({"link_lengths"})
    joint_names: tuple[str, ...]
    link_lengths: tuple[float, float]
    base_parameters: tuple[float, float, float] = (0.0, 0.0, 0.0)
    min_sin_elbow: float = 0.05
    wrench_axes: tuple[str, ...] = ("fx", "fy")
    parameter_names: tuple[str, ...] = ("a1", "a2", "a3")

    def __post_init__(self) -> None:
        if len(self.joint_names) != 2:
            raise InputError(f"planar2r needs exactly 2 joints, got {len(self.joint_names)}")

    @property
    def has_dynamics(self) -> bool:
        """True when any base parameter is nonzero."""
        return any(self.base_parameters)

    def _q(self, q: ArrayLike) -> NDArray[np.float64]:
        return as_joint_array(q, 2)

    def forward_kinematics(self, q: ArrayLike) -> NDArray[np.float64]:
        """End-effector position [m], shape (n, 3) with z = 0 (Eq 2)."""
        xy = forward_kinematics(self._q(q), self.link_lengths)
        return np.concatenate([xy, np.zeros((xy.shape[0], 1))], axis=1)

    def jacobian(self, q: ArrayLike) -> NDArray[np.float64]:
        """Shape (n, 2, 2), rows (fx, fy) (Eq 3)."""
        return jacobian(self._q(q), self.link_lengths)

    def regressor(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """Shape (n, 2, 3) for ``(a1, a2, a3)``."""
        q_, qd_, qdd_ = self._q(q), self._q(qd), self._q(qdd)
        c, s = np.cos(q_[:, 1]), np.sin(q_[:, 1])
        w1, w2 = qd_[:, 0], qd_[:, 1]
        a1, a2 = qdd_[:, 0], qdd_[:, 1]
        y = np.zeros((q_.shape[0], 2, 3))
        y[:, 0, 0] = a1
        y[:, 0, 1] = c * (2.0 * a1 + a2) - s * (2.0 * w1 * w2 + w2**2)
        y[:, 0, 2] = a2
        y[:, 1, 1] = c * a1 + s * w1**2
        y[:, 1, 2] = a1 + a2
        return y

    def inverse_dynamics(self, q: ArrayLike, qd: ArrayLike, qdd: ArrayLike) -> NDArray[np.float64]:
        """``M qdd + C qd`` [N m], shape (n, 2)."""
        out: NDArray[np.float64] = self.regressor(q, qd, qdd) @ self.parameters()
        return out

    def parameters(self) -> NDArray[np.float64]:
        """``(a1, a2, a3)`` [kg m^2]."""
        return np.array(self.base_parameters, dtype=np.float64)

    def with_parameters(self, values: ArrayLike) -> Self:
        """A copy with other base parameters."""
        v = np.asarray(values, dtype=np.float64).reshape(-1)
        if v.size != 3:
            raise ValueError(f"planar2r has 3 base parameters, got {v.size}")
        return dataclasses.replace(self, base_parameters=(float(v[0]), float(v[1]), float(v[2])))

    def inertia_modulation(self, q: ArrayLike) -> NDArray[np.float64]:
        """``cos q2`` for the first joint, 0 for the second, shape (n, 2)."""
        q_ = self._q(q)
        out = np.zeros_like(q_)
        out[:, 0] = np.cos(q_[:, 1])
        return out

    def wrench_from_joint_torque(
        self, q: ArrayLike, tau: ArrayLike, *, singular_threshold: float | None = None
    ) -> WrenchResult:
        """``F = J^-T tau`` [N]; singular where ``|sin q2|`` < the threshold."""
        guard = self.min_sin_elbow if singular_threshold is None else singular_threshold
        r = force_from_joint_torque(self._q(q), tau, self.link_lengths, min_sin_elbow=guard)
        return WrenchResult(wrench=r.force, singular=r.singular)

    def wrench_map(
        self, q: ArrayLike, *, singular_threshold: float | None = None
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """``A = J^-T`` (n, 2, 2) with ``F = A tau`` [N], NaN rows where singular, and the
        singular mask (:func:`torquemap.kinematics.force_map`)."""
        guard = self.min_sin_elbow if singular_threshold is None else singular_threshold
        return force_map(self._q(q), self.link_lengths, min_sin_elbow=guard)

    def to_dict(self) -> dict[str, Any]:
        """``kinematics`` and ``link_lengths``."""
        return {"kinematics": self.kind, "link_lengths": list(self.link_lengths)}

    @classmethod
    def from_table(
        cls,
        head: Mapping[str, Any],
        joint_names: tuple[str, ...],
        *,
        path: str | os.PathLike[str] | None = None,
        base_dir: Path | None = None,
    ) -> Planar2R:
        """From the ``[robot]`` table: ``link_lengths = [l1, l2]`` [m], two joints."""
        raw = head.get("link_lengths")
        if not isinstance(raw, list) or len(raw) != 2:
            raise InputError("[robot] link_lengths must be [l1, l2] for planar2r", path=path)
        lengths = []
        for v in raw:
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise InputError(f"[robot] link_lengths must be numbers, got {v!r}", path=path)
            if not (math.isfinite(v) and 1e-6 <= v <= 1e3):
                raise InputError(
                    f"[robot] link_lengths must be positive and finite, in [1e-6, 1000] m, got {v!r}",
                    path=path,
                )
            lengths.append(float(v))
        if len(joint_names) != 2:
            raise InputError(
                f"planar2r needs exactly 2 joints, the file has {len(joint_names)}", path=path
            )
        return cls(joint_names=tuple(joint_names), link_lengths=(lengths[0], lengths[1]))
