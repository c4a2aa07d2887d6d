"""The identified model of a robot's joints: inertia, friction and PDTV, and its TOML file.

A model file is a robot file plus, per joint, optional ``[joints.<j>.inertia]``,
``[joints.<j>.friction]`` and ``[[joints.<j>.pdtv]]`` tables, and an optional top-level
``[identification]`` table of free-form notes. A plain robot file is a valid model with no
friction and no PDTV. All torques and inertias are motor side (docs/conventions.md).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.friction_law import FrictionLaw, StribeckFriction, friction_law_from_dict
from torquemap.pdtv import POWER_ORDERS
from torquemap.robot import Robot, robot_from_dict, robot_to_dict
from torquemap.tomlfile import read_toml

Direction = Literal["both", "positive", "negative"]

#: Highest PDTV order a model file may hold [CPR]: finer than any encoder resolves (identify
#: --max-order stops there too); a larger one is a typo or a corrupt file.
MAX_PDTV_ORDER = 1e6
#: Largest motor-side inertia magnitude a model file may hold [kg m^2]: a million times a
#: large servo motor's rotor with its reflected load; beyond it, a typo or a corrupt file.
#: Negative values are allowed (identify writes a negative armature when the data want it).
MAX_INERTIA = 1e6
#: Largest PDTV line amplitude a model file may hold [N m, motor side]: far beyond any
#: actuator's torque; beyond it, a typo or a corrupt file.
MAX_PDTV_AMPLITUDE = 1e6


@dataclass(frozen=True, slots=True, eq=False)
class InertiaModel:
    """Motor-side inertia of one joint.

    ``J(q) = constant + cos_elbow * cos(q_2)``: for the first joint of a planar2r arm the
    reflected link inertia depends on the elbow angle ``q_2`` (Simpson et al.: "the B axis
    position affects the A axis inertia"); ``cos_elbow`` is 0 for every other joint.

    Attributes
    ----------
    constant
        [kg m^2], motor side.
    cos_elbow
        [kg m^2], motor side.
    """

    constant: float = 0.0
    cos_elbow: float = 0.0


FrictionModel = StribeckFriction
"""Today's friction law under its earlier name (:class:`torquemap.friction_law.StribeckFriction`)."""


@dataclass(frozen=True, slots=True, eq=False)
class PdtvLine:
    """One PDTV line: ``amplitude * cos(order * motor_angle + phase)``.

    Attributes
    ----------
    order
        Position frequency in cycles per motor revolution (CPR, Eq 4 of Simpson et al.).
    amplitude
        [N m], motor side, >= 0.
    phase
        [rad].
    direction
        ``"both"``, or the direction of motion in which this line applies.
    """

    order: float
    amplitude: float
    phase: float
    direction: Direction = "both"


@dataclass(frozen=True, slots=True, eq=False)
class JointModel:
    """Everything identified for one joint (motor side)."""

    inertia: InertiaModel = field(default_factory=InertiaModel)
    friction: FrictionLaw = field(default_factory=StribeckFriction)
    pdtv: tuple[PdtvLine, ...] = ()


@dataclass(frozen=True, slots=True, eq=False)
class Model:
    """A robot and its identified joints.

    Attributes
    ----------
    robot
        The robot file's content.
    joints
        Joint name to :class:`JointModel`, for every joint of the robot.
    notes
        Free-form ``[identification]`` table (logs used, warnings, ...).
    """

    robot: Robot
    joints: Mapping[str, JointModel]
    notes: Mapping[str, Any] = field(default_factory=dict)


def friction_torque(velocity: ArrayLike, friction: FrictionLaw) -> NDArray[np.float64]:
    """Friction torque [N m] at motor velocity ``velocity`` [rad/s]: ``friction.torque(velocity)``.

    Examples
    --------
    >>> f = FrictionModel(coulomb_positive=0.1, coulomb_negative=0.2, viscous=0.01)
    >>> friction_torque([2.0, -2.0], f).round(6)
    array([ 0.12, -0.22])
    """
    return friction.torque(velocity)


def pdtv_summary(lines: Sequence[PdtvLine], top: int = 3) -> str:
    """The ``top`` largest lines as one phrase, a directional line marked ``(+)`` or ``(-)``.

    >>> pdtv_summary([PdtvLine(order=2.0, amplitude=0.004, phase=0.0),
    ...               PdtvLine(order=2.0, amplitude=0.003, phase=0.0, direction="negative")])
    '2 CPR 0.004 N m, 2 CPR (-) 0.003 N m'
    >>> pdtv_summary([])
    'none'
    """
    mark = {"both": "", "positive": " (+)", "negative": " (-)"}
    best = sorted(lines, key=lambda ln: -ln.amplitude)[:top]
    return (
        ", ".join(f"{ln.order:g} CPR{mark[ln.direction]} {ln.amplitude:.3g} N m" for ln in best)
        or "none"
    )


def pdtv_torque(
    motor_angle: ArrayLike,
    lines: tuple[PdtvLine, ...],
    *,
    velocity: ArrayLike | None = None,
    phasor: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> NDArray[np.float64]:
    """PDTV torque [N m] at motor angle ``motor_angle`` [rad].

    Lines with ``direction="both"`` always apply; directional lines apply where the sign of
    ``velocity`` [rad/s] matches (and are skipped when ``velocity`` is None). ``phasor``:
    ``(cos, sin)`` of ``motor_angle`` when the caller has them (the same numbers).

    Examples
    --------
    >>> pdtv_torque([0.0, np.pi / 2], (PdtvLine(order=2, amplitude=0.5, phase=0.0),)).round(6)
    array([ 0.5, -0.5])
    """
    theta = np.asarray(motor_angle, dtype=np.float64)
    out = np.zeros_like(theta)
    w = None if velocity is None else np.asarray(velocity, dtype=np.float64)
    flat_theta, flat_out = theta.reshape(-1), out.reshape(-1)
    flat_w = None if w is None else np.broadcast_to(w, theta.shape).reshape(-1)
    used = [line for line in lines if line.direction == "both" or flat_w is not None]
    # integer orders (a motor-angle PDTV's) as powers of exp(i theta), by the compiled kernel:
    # one sine and one cosine per sample instead of one cosine per line
    powers = [line for line in used if _power_order(line.order)]
    if len(powers) > 1 and flat_theta.size:
        from torquemap._kernels import phasor_lines

        directions = {"both": 0, "positive": 1, "negative": -1}
        phase = np.array([line.phase for line in powers])
        amplitude = np.array([line.amplitude for line in powers])
        phasor_lines(
            np.cos(flat_theta) if phasor is None else np.ascontiguousarray(phasor[0]).reshape(-1),
            np.sin(flat_theta) if phasor is None else np.ascontiguousarray(phasor[1]).reshape(-1),
            np.zeros(1) if flat_w is None else np.ascontiguousarray(flat_w),
            np.array([int(line.order) for line in powers], dtype=np.int64),
            amplitude * np.cos(phase),
            amplitude * np.sin(phase),
            np.array([directions[line.direction] for line in powers], dtype=np.int64),
            flat_out,
        )
        used = [line for line in used if line not in powers]
    # in place, a cache-sized stretch at a time: the same operations as
    # ``out += amplitude * cos(order * theta + phase)``, without a temporary of the log's size
    step = 1 << 15
    buf = np.empty(min(step, flat_theta.size))
    for a in range(0, flat_theta.size, step):
        th, acc = flat_theta[a : a + step], flat_out[a : a + step]
        b = buf[: th.size]
        for line in used:
            np.multiply(line.order, th, out=b)
            b += line.phase
            np.cos(b, out=b)
            np.multiply(line.amplitude, b, out=b)
            if line.direction == "both":
                acc += b
            else:
                assert flat_w is not None
                wv = flat_w[a : a + step]
                np.add(acc, b, out=acc, where=wv > 0 if line.direction == "positive" else wv < 0)
    return out


def _power_order(order: float) -> bool:
    """Whether a line's order is a positive integer taken as a power of ``exp(i theta)``
    (:data:`torquemap.pdtv.POWER_ORDERS`, as :func:`torquemap.pdtv.phasors` does)."""
    return order == round(order) and 1 <= order <= POWER_ORDERS


def inertia_at(joint: JointModel, elbow_angle: ArrayLike) -> NDArray[np.float64]:
    """Motor-side inertia [kg m^2] at elbow (second joint) angle ``elbow_angle`` [rad]."""
    q2 = np.asarray(elbow_angle, dtype=np.float64)
    out: NDArray[np.float64] = joint.inertia.constant + joint.inertia.cos_elbow * np.cos(q2)
    return out


def _floats(table: Mapping[str, Any], cls: type, where: str, path: str | None) -> dict[str, float]:
    allowed = set(cls.__dataclass_fields__)  # type: ignore[attr-defined]
    out: dict[str, float] = {}
    for key, value in table.items():
        if key not in allowed:
            raise InputError(
                f"unknown key {key!r} in {where} (allowed: {', '.join(sorted(allowed))})", path=path
            )
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
        ):
            raise InputError(f"{where} {key} must be a finite number, got {value!r}", path=path)
        out[key] = float(value)
    return out


def _pdtv_lines(raw: Any, where: str, path: str | None) -> tuple[PdtvLine, ...]:
    if not isinstance(raw, list):
        raise InputError(f"{where} must be an array of tables [[...pdtv]]", path=path)
    lines = []
    for k, item in enumerate(raw):
        w = f"{where}[{k}]"
        if not isinstance(item, Mapping):
            raise InputError(f"{w} must be a table", path=path)
        direction = item.get("direction", "both")
        if direction not in ("both", "positive", "negative"):
            raise InputError(
                f"{w} direction must be 'both', 'positive' or 'negative', got {direction!r}",
                path=path,
            )
        nums = _floats({k2: v for k2, v in item.items() if k2 != "direction"}, PdtvLine, w, path)
        for key in ("order", "amplitude", "phase"):
            if key not in nums:
                raise InputError(f"{w} is missing {key}", path=path)
        if nums["order"] <= 0:
            raise InputError(f"{w} order must be positive", path=path)
        if nums["order"] > MAX_PDTV_ORDER:
            raise InputError(
                f"{w} order must be at most {MAX_PDTV_ORDER:g} CPR (cycles per motor "
                f"revolution), got {nums['order']:g}",
                path=path,
            )
        if abs(nums["amplitude"]) > MAX_PDTV_AMPLITUDE:
            raise InputError(
                f"{w} amplitude must lie in +-{MAX_PDTV_AMPLITUDE:g} N m (motor side), got "
                f"{nums['amplitude']:g}",
                path=path,
            )
        lines.append(PdtvLine(direction=direction, **nums))
    return tuple(lines)


def model_from_dict(
    document: Mapping[str, Any], *, path: str | os.PathLike[str] | None = None
) -> Model:
    """Build a :class:`Model` from a parsed model (or plain robot) TOML document."""
    p = None if path is None else os.fspath(path)
    robot = robot_from_dict(
        document,
        path=p,
        extra_tables=("identification",),
        extra_joint_tables=("inertia", "friction", "pdtv"),
    )
    joints: dict[str, JointModel] = {}
    for name, spec in document["joints"].items():
        where = f"[joints.{name}"
        values = _floats(spec.get("inertia", {}), InertiaModel, where + ".inertia]", p)
        for key, value in values.items():
            if abs(value) > MAX_INERTIA:
                raise InputError(
                    f"{where}.inertia] {key} must lie in +-{MAX_INERTIA:g} kg m^2 (motor side), "
                    f"got {value:g}",
                    path=p,
                )
        inertia = InertiaModel(**values)
        friction = friction_law_from_dict(
            spec.get("friction", {}), where=where + ".friction]", path=p
        )
        lines = _pdtv_lines(spec.get("pdtv", []), where + ".pdtv]", p)
        joints[str(name)] = JointModel(inertia=inertia, friction=friction, pdtv=lines)
    notes = document.get("identification", {})
    if not isinstance(notes, Mapping):
        raise InputError("[identification] must be a table", path=p)
    window = notes.get("differentiation_window")
    if window is not None and not (
        isinstance(window, int | float)
        and not isinstance(window, bool)
        and math.isfinite(window)
        and 0 < window <= 10
    ):
        # estimate, spectrum and report default to it: a bad value is refused, not skipped
        raise InputError(
            f"[identification] differentiation_window must be a number in (0, 10] s, got {window!r}",
            path=p,
        )
    _check_identified_tables(document["joints"], notes, p)
    return Model(robot=robot, joints=joints, notes=dict(notes))


def _check_identified_tables(
    specs: Mapping[str, Any], notes: Mapping[str, Any], path: str | None
) -> None:
    """Refuse a model whose ``[identification.joints.<j>]`` says the joint was identified
    while its ``[joints.<j>.friction]`` or ``[joints.<j>.inertia]`` table is gone, or whose
    ``torque_constant`` is not the one identification read the currents with.

    Identification writes both tables for every joint it identified; a table missing is one
    deleted or misnamed by hand, and would be read as no friction (or no inertia): before
    (new-user QA, stop 39) the real ODrive sweep's model without its friction table gave
    exit 0, every sample sound and ``tau_ext_a`` off by the friction (-13.2 mN m in the
    mean, RMS 13.4 mN m against 1.7 mN m), no word. A robot file, or a model without
    ``[identification]``, still reads as no friction. A torque constant edited after
    identification (0.04 -> 0.4 N m/A on the ODrive model) gave exit 0 and ``tau_ext_a`` RMS
    0.28 N m against 1.7 mN m: the model's N m are those of the old constant; models written
    before 2026-11-28 do not record it.
    """
    joints = notes.get("joints")
    if not isinstance(joints, Mapping):
        return
    for name, spec in specs.items():
        entry = joints.get(name)
        if not isinstance(entry, Mapping) or not isinstance(spec, Mapping):
            continue
        passes = entry.get("passes")
        steady = isinstance(passes, int) and not isinstance(passes, bool) and passes > 0
        if not (steady or entry.get("friction_fit") == "whole"):
            continue  # never identified: the robot file's joint, no tables to lose
        used = entry.get("torque_constant")
        given = spec.get("torque_constant")
        if (
            isinstance(used, int | float)
            and isinstance(given, int | float)
            and not isinstance(used, bool)
            and used > 0
            and abs(given / used - 1.0) > 1e-9
        ):
            raise InputError(
                f"[joints.{name}] torque_constant {given:g} N m/A is not the {used:g} N m/A "
                f"identification read the currents with ([identification.joints.{name}] "
                f"torque_constant): its friction, inertia and PDTV are N m of that constant, "
                f"and the task logs' currents would be read {given / used:.4g} times as large; "
                "identify again with the new constant",
                path=path,
            )
        missing = [table for table in ("friction", "inertia") if table not in spec]
        if missing:
            tables = " and ".join(f"[joints.{name}.{table}]" for table in missing)
            raise InputError(
                f"{tables} missing, though [identification.joints.{name}] says the joint was "
                f"identified: deleted or renamed by hand? It would be read as zero and stay in "
                f"tau_ext_{name}; restore it from the identified model, or identify again",
                path=path,
            )


def load_model(path: str | os.PathLike[str]) -> Model:
    """Read a model file (or a plain robot file, which gives no friction and no PDTV).

    Raises
    ------
    InputError
        On a missing, empty or malformed file, or a missing or unknown key.
    """
    return model_from_dict(read_toml(path), path=path)


def model_to_dict(model: Model) -> dict[str, Any]:
    """The TOML document of a model, ready for ``tomli_w``; inverse of :func:`model_from_dict`."""
    doc = robot_to_dict(model.robot)
    for name, jm in model.joints.items():
        spec = doc["joints"][name]
        spec["inertia"] = {"constant": jm.inertia.constant, "cos_elbow": jm.inertia.cos_elbow}
        spec["friction"] = jm.friction.to_dict()
        if jm.pdtv:
            spec["pdtv"] = [
                {
                    "order": ln.order,
                    "amplitude": ln.amplitude,
                    "phase": ln.phase,
                    "direction": ln.direction,
                }
                for ln in jm.pdtv
            ]
    if model.notes:
        doc["identification"] = dict(model.notes)
    return doc


def save_model(path: str | os.PathLike[str], model: Model) -> None:
    """Write a model file atomically (the inverse of :func:`load_model`).

    Parameters
    ----------
    path
        The TOML file to write; it appears whole or not at all.
    model
        The model, for example ``torquemap.identify(robot, log).model``.

    Raises
    ------
    InputError
        When the output folder does not exist.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"kinematics": "none"},
    ...                       "joints": {"m": {"gear_ratio": 2, "torque_constant": 0.1}}})
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "model.toml"
    >>> save_model(path, Model(robot=rb, joints={"m": JointModel()}))
    >>> load_model(path).robot.joints[0].gear_ratio
    2.0
    """
    from torquemap.io import write_toml

    write_toml(path, model_to_dict(model))
