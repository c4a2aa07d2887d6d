"""The robot file: joints, gear ratios, torque constants and kinematics (docs/formats.md)."""

from __future__ import annotations

import math
import os
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import Any, Literal

from torquemap.errors import InputError
from torquemap.robots import Arm, arm_from_kind, arm_from_table, arm_head_keys, known_kinds
from torquemap.tomlfile import read_toml

Kinematics = str
PositionUnit = Literal["rad", "counts", "turns"]
POSITION_UNITS: tuple[PositionUnit, ...] = ("rad", "counts", "turns")

_ROBOT_KEYS = {"name", "kinematics"}
#: Plausible ranges of a robot file's numbers: outside them a value is a typo, not a robot.
GEAR_RATIO_RANGE = (1e-3, 1e5)
TORQUE_CONSTANT_RANGE = (1e-6, 1e3)
MAX_COUNTS_PER_REV = 2**32
_JOINT_KEYS = {"gear_ratio", "torque_constant", "encoder_counts_per_rev", "position_unit"}


@dataclass(frozen=True, slots=True, eq=False)
class Joint:
    """One joint and its motor.

    Attributes
    ----------
    name
        Joint name, the ``<j>`` of the log columns ``q_<j>``, ``i_<j>``, ``tau_<j>``.
    gear_ratio
        Motor revolutions per joint revolution [-]; motor angle = gear_ratio * joint angle.
    torque_constant
        Motor torque per motor current [N m / A], motor side.
    encoder_counts_per_rev
        Encoder counts per motor revolution, or None when unknown.
    position_unit
        ``"rad"`` when the log's ``q_<j>`` holds the joint angle [rad]; ``"counts"`` when it
        holds raw motor encoder counts that may wrap once per motor revolution; ``"turns"``
        when it holds motor turns [rev], continuous (ODrive's ``pos_estimate``).

    Raises
    ------
    InputError
        On a gear ratio, torque constant or encoder resolution outside its plausible range
        (``GEAR_RATIO_RANGE``, ``TORQUE_CONSTANT_RANGE``, ``MAX_COUNTS_PER_REV``), or an unknown
        position unit.
    """

    name: str
    gear_ratio: float
    torque_constant: float
    encoder_counts_per_rev: int | None = None
    position_unit: PositionUnit = "rad"

    def __post_init__(self) -> None:
        where = f"joint {self.name!r}:"
        _in_range(self.gear_ratio, GEAR_RATIO_RANGE, f"{where} gear_ratio", None)
        _in_range(self.torque_constant, TORQUE_CONSTANT_RANGE, f"{where} torque_constant", None)
        cpr = self.encoder_counts_per_rev
        if cpr is not None and (
            isinstance(cpr, bool) or not isinstance(cpr, int) or not 0 < cpr <= MAX_COUNTS_PER_REV
        ):
            raise InputError(
                f"{where} encoder_counts_per_rev must be an integer in 1..{MAX_COUNTS_PER_REV}, "
                f"got {cpr!r}"
            )
        if self.position_unit not in POSITION_UNITS:
            raise InputError(
                f"{where} position_unit must be one of {', '.join(POSITION_UNITS)}, "
                f"got {self.position_unit!r}"
            )
        if self.position_unit == "counts" and cpr is None:
            raise InputError(f"{where} position_unit = 'counts' needs encoder_counts_per_rev")


@dataclass(frozen=True, slots=True, eq=False)
class Robot:
    """A robot: its joints in kinematic order and the model of its arm.

    Attributes
    ----------
    name
        Free-form name.
    kinematics
        The robot file's kind of robot (``"none"``, ``"planar2r"``, ``"urdf"``; see
        :mod:`torquemap.robots`), for files and messages only: code asks ``arm``.
    link_lengths
        ``(l1, l2)`` [m] for planar2r, empty otherwise.
    joints
        The joints in kinematic order.
    arm
        The arm's kinematics and dynamics (:class:`torquemap.robots.Arm`); built from
        ``kinematics`` and ``link_lengths`` when not given.
    """

    name: str
    kinematics: Kinematics
    link_lengths: tuple[float, ...]
    joints: tuple[Joint, ...]
    arm: Arm = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        names = [j.name for j in self.joints]
        if len(set(names)) != len(names):
            raise InputError(f"joint names must be unique, got {', '.join(names)}")
        if self.arm is None:
            arm = arm_from_kind(self.kinematics, names, link_lengths=self.link_lengths)
            object.__setattr__(self, "arm", arm)
        elif tuple(self.arm.joint_names) != tuple(names):
            raise InputError(
                f"the arm's joints ({', '.join(self.arm.joint_names)}) are not the robot's "
                f"({', '.join(names)})"
            )

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Joint names in kinematic order."""
        return tuple(j.name for j in self.joints)

    def joint(self, name: str) -> Joint:
        """The joint called ``name``; InputError naming the known joints otherwise."""
        for j in self.joints:
            if j.name == name:
                return j
        raise InputError(f"unknown joint {name!r}; the robot has {', '.join(self.joint_names)}")


def _positive(value: Any, what: str, path: str | None) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{what} must be a number, got {value!r}", path=path)
    x = float(value)
    if not math.isfinite(x) or x <= 0:
        hint = ""
        if x < 0 and what.endswith(("gear_ratio", "torque_constant")):
            # a motor wired or geared against its joint: torquemap's convention is that positive
            # motor torque turns the joint positive
            hint = (
                ": for a motor that turns against its joint, give the magnitude and negate the "
                "joint's current or torque column (i_<j> or tau_<j>) in the logs"
            )
        raise InputError(f"{what} must be positive and finite, got {value!r}{hint}", path=path)
    return x


def _in_range(value: Any, bounds: tuple[float, float], what: str, path: str | None) -> float:
    x = _positive(value, what, path)
    if not bounds[0] <= x <= bounds[1]:
        raise InputError(
            f"{what} must lie in [{bounds[0]:g}, {bounds[1]:g}], got {value!r}", path=path
        )
    return x


def _check_keys(
    table: Mapping[str, Any], allowed: Collection[str], where: str, path: str | None
) -> None:
    for key in table:
        if key not in allowed:
            raise InputError(
                f"unknown key {key!r} in {where} (allowed: {', '.join(sorted(allowed))})", path=path
            )


def robot_from_dict(
    document: Mapping[str, Any],
    *,
    path: str | os.PathLike[str] | None = None,
    extra_tables: Collection[str] = (),
    extra_joint_tables: Collection[str] = (),
) -> Robot:
    """Build a :class:`Robot` from a parsed robot (or model) TOML document.

    Parameters
    ----------
    document
        The parsed TOML.
    path
        File the document came from, for error messages.
    extra_tables
        Top-level tables allowed besides ``robot`` and ``joints`` (a model file's additions).
    extra_joint_tables
        Sub-tables allowed inside each ``[joints.<j>]`` (for example ``friction``, ``pdtv``).

    Returns
    -------
    Robot
        The robot.

    Raises
    ------
    InputError
        On a missing or unknown key, a wrong type, or an inconsistent value.

    Examples
    --------
    >>> doc = {"robot": {"name": "r", "kinematics": "none"},
    ...        "joints": {"a": {"gear_ratio": 100, "torque_constant": 0.1}}}
    >>> robot_from_dict(doc).joints[0].gear_ratio
    100.0
    """
    p = None if path is None else os.fspath(path)
    _check_keys(document, {"robot", "joints", *extra_tables}, "the file", p)
    if "robot" not in document:
        raise InputError("missing table [robot]", path=p)
    head = document["robot"]
    if not isinstance(head, Mapping):
        raise InputError("[robot] must be a table", path=p)
    name = head.get("name", "")
    if not isinstance(name, str):
        raise InputError(f"[robot] name must be a string, got {name!r}", path=p)
    kinematics = head.get("kinematics", "none")
    own = _ROBOT_KEYS | arm_head_keys_or_error(kinematics, p)
    for key in head:
        if key in own:
            continue
        kinds_known = known_kinds()  # every kind's keys, the optional engines' too
        owners = [k for k in sorted(kinds_known) if key in kinds_known[k].head_keys]
        if owners:
            kinds = " or ".join(repr(k) for k in owners)
            raise InputError(f"[robot] {key} is only for kinematics = {kinds}", path=p)
    _check_keys(head, own, "[robot]", p)

    tables = document.get("joints")
    if not isinstance(tables, Mapping) or not tables:
        raise InputError("missing [joints.<name>] tables", path=p)
    joints = []
    for jname, spec in tables.items():
        where = f"[joints.{jname}]"
        if not str(jname).strip():
            raise InputError(
                f"[joints.{jname!r}] a joint needs a name (the <j> of the log's columns)", path=p
            )
        if not isinstance(spec, Mapping):
            raise InputError(f"{where} must be a table", path=p)
        _check_keys(spec, {*_JOINT_KEYS, *extra_joint_tables}, where, p)
        for key in ("gear_ratio", "torque_constant"):
            if key not in spec:
                raise InputError(f"{where} is missing {key}", path=p)
        cpr_raw = spec.get("encoder_counts_per_rev")
        cpr: int | None = None
        if cpr_raw is not None:
            if (
                isinstance(cpr_raw, bool)
                or not isinstance(cpr_raw, int)
                or not 0 <= cpr_raw <= MAX_COUNTS_PER_REV
            ):
                raise InputError(
                    f"{where} encoder_counts_per_rev must be an integer in "
                    f"0..{MAX_COUNTS_PER_REV} (0: unknown)",
                    path=p,
                )
            cpr = cpr_raw or None
        unit = spec.get("position_unit", "rad")
        if unit not in POSITION_UNITS:
            raise InputError(
                f"{where} position_unit must be one of {', '.join(POSITION_UNITS)}, got {unit!r}",
                path=p,
            )
        if unit == "counts" and cpr is None:
            raise InputError(
                f"{where} position_unit = 'counts' needs encoder_counts_per_rev", path=p
            )
        joints.append(
            Joint(
                name=str(jname),
                gear_ratio=_in_range(
                    spec["gear_ratio"], GEAR_RATIO_RANGE, f"{where} gear_ratio", p
                ),
                torque_constant=_in_range(
                    spec["torque_constant"], TORQUE_CONSTANT_RANGE, f"{where} torque_constant", p
                ),
                encoder_counts_per_rev=cpr,
                position_unit=unit,
            )
        )
    arm = arm_from_table(head, [j.name for j in joints], path=p)
    link_lengths = tuple(getattr(arm, "link_lengths", ()))
    return Robot(
        name=name,
        kinematics=str(kinematics),
        link_lengths=link_lengths,
        joints=tuple(joints),
        arm=arm,
    )


def arm_head_keys_or_error(kinematics: Any, path: str | None) -> frozenset[str]:
    """The ``[robot]`` keys of a kind, InputError naming ``path`` on an unknown kind."""
    try:
        return arm_head_keys(kinematics)
    except InputError as exc:
        raise InputError(exc.message, path=path) from None


def load_robot(path: str | os.PathLike[str]) -> Robot:
    """Read a robot file (docs/formats.md).

    Parameters
    ----------
    path
        The TOML file.

    Returns
    -------
    Robot
        The robot.

    Raises
    ------
    InputError
        On a missing, empty or malformed file, or a missing or unknown key.
    """
    return robot_from_dict(read_toml(path), path=path)


def robot_to_dict(robot: Robot) -> dict[str, Any]:
    """The TOML document of a robot file, ready for ``tomli_w``; inverse of robot_from_dict."""
    head: dict[str, Any] = {"name": robot.name, **robot.arm.to_dict()}
    joints: dict[str, Any] = {}
    for j in robot.joints:
        spec: dict[str, Any] = {"gear_ratio": j.gear_ratio, "torque_constant": j.torque_constant}
        if j.encoder_counts_per_rev is not None:
            spec["encoder_counts_per_rev"] = j.encoder_counts_per_rev
        if j.position_unit != "rad":
            spec["position_unit"] = j.position_unit
        joints[j.name] = spec
    return {"robot": head, "joints": joints}
