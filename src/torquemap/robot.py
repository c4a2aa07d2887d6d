"""The robot file: joints, gear ratios, torque constants and kinematics (docs/formats.md)."""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from torquemap.errors import InputError

Kinematics = Literal["planar2r", "none"]
PositionUnit = Literal["rad", "counts"]

_ROBOT_KEYS = {"name", "kinematics", "link_lengths"}
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
        holds raw motor encoder counts that may wrap once per motor revolution.
    """

    name: str
    gear_ratio: float
    torque_constant: float
    encoder_counts_per_rev: int | None = None
    position_unit: PositionUnit = "rad"

    def __post_init__(self) -> None:
        """Refuse values no log could be read with (the robot file's checks, for code).

        Raises
        ------
        InputError
            On a gear ratio or torque constant that is not positive and finite, counts per
            revolution that are not a positive integer, or an unknown position unit.

        Examples
        --------
        >>> Joint(name="a", gear_ratio=-1.0, torque_constant=0.1)
        Traceback (most recent call last):
        ...
        torquemap.errors.InputError: joint 'a': gear_ratio must be positive and finite, got -1.0
        """
        import typing

        for key in ("gear_ratio", "torque_constant"):
            value = getattr(self, key)
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            if not ok or not math.isfinite(value) or value <= 0:
                raise InputError(
                    f"joint {self.name!r}: {key} must be positive and finite, got {value!r}"
                )
        cpr = self.encoder_counts_per_rev
        if cpr is not None and (isinstance(cpr, bool) or not isinstance(cpr, int) or cpr <= 0):
            raise InputError(
                f"joint {self.name!r}: encoder_counts_per_rev must be a positive integer, "
                f"got {cpr!r}"
            )
        units = typing.get_args(PositionUnit)
        if self.position_unit not in units:
            raise InputError(
                f"joint {self.name!r}: position_unit must be one of {', '.join(units)}, "
                f"got {self.position_unit!r}"
            )


@dataclass(frozen=True, slots=True, eq=False)
class Robot:
    """A robot: its joints in kinematic order and its kinematics.

    Attributes
    ----------
    name
        Free-form name.
    kinematics
        ``"planar2r"`` (two revolute joints in a plane, a SCARA's A and B axes) or ``"none"``.
    link_lengths
        ``(l1, l2)`` [m] for planar2r, empty otherwise.
    joints
        The joints in kinematic order.
    """

    name: str
    kinematics: Kinematics
    link_lengths: tuple[float, ...]
    joints: tuple[Joint, ...]

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
        raise InputError(f"{what} must be positive and finite, got {value!r}", path=path)
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
    _check_keys(head, _ROBOT_KEYS, "[robot]", p)
    name = str(head.get("name", ""))
    kinematics = head.get("kinematics", "none")
    if kinematics not in ("planar2r", "none"):
        raise InputError(
            f"[robot] kinematics must be 'planar2r' or 'none', got {kinematics!r}", path=p
        )
    link_lengths: tuple[float, ...] = ()
    if kinematics == "planar2r":
        raw = head.get("link_lengths")
        if not isinstance(raw, list) or len(raw) != 2:
            raise InputError("[robot] link_lengths must be [l1, l2] for planar2r", path=p)
        link_lengths = tuple(_positive(v, "[robot] link_lengths", p) for v in raw)
    elif "link_lengths" in head:
        raise InputError("[robot] link_lengths is only for kinematics = 'planar2r'", path=p)

    tables = document.get("joints")
    if not isinstance(tables, Mapping) or not tables:
        raise InputError("missing [joints.<name>] tables", path=p)
    joints = []
    for jname, spec in tables.items():
        where = f"[joints.{jname}]"
        if not isinstance(spec, Mapping):
            raise InputError(f"{where} must be a table", path=p)
        _check_keys(spec, {*_JOINT_KEYS, *extra_joint_tables}, where, p)
        for key in ("gear_ratio", "torque_constant"):
            if key not in spec:
                raise InputError(f"{where} is missing {key}", path=p)
        cpr_raw = spec.get("encoder_counts_per_rev")
        cpr: int | None = None
        if cpr_raw is not None:
            if isinstance(cpr_raw, bool) or not isinstance(cpr_raw, int) or cpr_raw <= 0:
                raise InputError(
                    f"{where} encoder_counts_per_rev must be a positive integer", path=p
                )
            cpr = cpr_raw
        unit = spec.get("position_unit", "rad")
        if unit not in ("rad", "counts"):
            raise InputError(
                f"{where} position_unit must be 'rad' or 'counts', got {unit!r}", path=p
            )
        if unit == "counts" and cpr is None:
            raise InputError(
                f"{where} position_unit = 'counts' needs encoder_counts_per_rev", path=p
            )
        joints.append(
            Joint(
                name=str(jname),
                gear_ratio=_positive(spec["gear_ratio"], f"{where} gear_ratio", p),
                torque_constant=_positive(spec["torque_constant"], f"{where} torque_constant", p),
                encoder_counts_per_rev=cpr,
                position_unit=unit,
            )
        )
    if kinematics == "planar2r" and len(joints) != 2:
        raise InputError(f"planar2r needs exactly 2 joints, the file has {len(joints)}", path=p)
    return Robot(name=name, kinematics=kinematics, link_lengths=link_lengths, joints=tuple(joints))


def read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Parse a TOML file; InputError naming the file on a missing, empty or malformed file."""
    p = Path(path)
    try:
        text = p.read_bytes()
    except FileNotFoundError:
        raise InputError("file not found", path=p) from None
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror}", path=p) from None
    if not text.strip():
        raise InputError("file is empty", path=p)
    try:
        return tomllib.loads(text.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"not valid TOML ({exc})", path=p) from None


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
    head: dict[str, Any] = {"name": robot.name, "kinematics": robot.kinematics}
    if robot.kinematics == "planar2r":
        head["link_lengths"] = list(robot.link_lengths)
    joints: dict[str, Any] = {}
    for j in robot.joints:
        spec: dict[str, Any] = {"gear_ratio": j.gear_ratio, "torque_constant": j.torque_constant}
        if j.encoder_counts_per_rev is not None:
            spec["encoder_counts_per_rev"] = j.encoder_counts_per_rev
        if j.position_unit != "rad":
            spec["position_unit"] = j.position_unit
        joints[j.name] = spec
    return {"robot": head, "joints": joints}
