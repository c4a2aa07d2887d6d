"""The identified PDTV over one motor revolution: the anti-cogging feed-forward table.

Firmware such as ODrive (3600 floats) or moteus (1024 int8 with a scale) loads a table of the
current to add at each motor angle. :func:`pdtv_map` evaluates the model's PDTV lines there;
:func:`write_pdtv_map` exports it as CSV, JSON or a C header (atomically).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap._callable import make_callable as _make_callable
from torquemap.ctext import c_comment, c_float, c_identifier
from torquemap.errors import InputError
from torquemap.io import atomic_output, write_table
from torquemap.model import Model, PdtvLine, pdtv_torque

TWO_PI = 2.0 * math.pi
#: Most bins a map may have (2**20; firmware tables hold 1024 to 3600).
MAX_BINS = 1 << 20


@dataclass(frozen=True, slots=True, eq=False)
class PdtvMap:
    """PDTV of one joint tabulated over motor angle.

    Attributes
    ----------
    joint
        Joint name.
    motor_angle
        Motor angle [rad] (bin centres, 0 = encoder zero), shape (nb,).
    torque
        PDTV torque [N m], motor side, shape (nb,).
    current
        ``torque / torque_constant`` [A], shape (nb,).
    """

    joint: str
    motor_angle: NDArray[np.float64]
    torque: NDArray[np.float64]
    current: NDArray[np.float64]


def _mean_direction(lines: tuple[PdtvLine, ...], theta: NDArray[np.float64]) -> NDArray[np.float64]:
    both = tuple(ln for ln in lines if ln.direction == "both")
    directional = tuple(ln for ln in lines if ln.direction != "both")
    out = pdtv_torque(theta, both)
    if directional:
        up = pdtv_torque(theta, directional, velocity=np.ones_like(theta))
        down = pdtv_torque(theta, directional, velocity=-np.ones_like(theta))
        out = out + 0.5 * (up + down)
    return out


def pdtv_map(
    model: Model,
    joint: str,
    *,
    bins: int = 1024,
    motor_angle: ArrayLike | None = None,
    direction: Literal["mean", "positive", "negative"] = "mean",
    table_lines: bool | None = None,
) -> PdtvMap:
    """Tabulate a joint's PDTV over one motor revolution.

    Parameters
    ----------
    model
        The identified model.
    joint
        Joint name.
    bins
        Number of bins over one revolution; bin ``k`` is centred at ``(k + 0.5) 2 pi / bins``.
        Lines of non-integer order are left out of the bins (they do not repeat every
        revolution; :func:`fractional_orders`).
    motor_angle
        Evaluate at these motor angles [rad] instead of bin centres, shape (m,).
    direction
        Directional lines: ``"mean"`` of both directions, or one direction's.
    table_lines
        Only the lines a table over one revolution holds (integer orders): default for
        ``bins``; with ``motor_angle``, what a drive applying the exported table adds there
        (``cogging verify``), else every line (default).

    Returns
    -------
    PdtvMap
        Angles, torques and currents.

    Raises
    ------
    InputError
        On an unknown joint, or ``bins`` outside ``2 .. MAX_BINS``.

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> from torquemap.model import JointModel
    >>> rb = robot_from_dict({"robot": {"kinematics": "none"},
    ...                       "joints": {"m": {"gear_ratio": 1, "torque_constant": 0.5}}})
    >>> jm = JointModel(pdtv=(PdtvLine(order=1, amplitude=1.0, phase=0.0),))
    >>> m = pdtv_map(Model(robot=rb, joints={"m": jm}), "m", bins=4)
    >>> m.current.round(3)
    array([ 1.414, -1.414, -1.414,  1.414])
    """
    jt = model.robot.joint(joint)
    jm = model.joints[joint]
    if motor_angle is None:
        if bins < 2:
            raise InputError(f"--bins must be at least 2, got {bins}")
        if bins > MAX_BINS:
            raise InputError(f"--bins must be at most {MAX_BINS} (2**20), got {bins}")
        theta = (np.arange(bins, dtype=np.float64) + 0.5) * (TWO_PI / bins)
    else:
        theta = np.asarray(motor_angle, dtype=np.float64).ravel()
    lines = jm.pdtv
    if (motor_angle is None) if table_lines is None else table_lines:
        # a table over one revolution repeats every revolution: a line of non-integer order
        # does not, and tabulated it would be wrong by up to twice itself on the revolutions
        # after the first; left out (fractional_orders names them)
        lines = tuple(ln for ln in lines if _is_integer(ln.order))
    if direction == "mean":
        torque = _mean_direction(lines, theta)
    else:
        sign = 1.0 if direction == "positive" else -1.0
        torque = pdtv_torque(theta, lines, velocity=np.full_like(theta, sign))
    return PdtvMap(
        joint=joint, motor_angle=theta, torque=torque, current=torque / jt.torque_constant
    )


def _is_integer(order: float) -> bool:
    return abs(order - round(order)) <= 1e-9 * max(1.0, abs(order))


def fractional_orders(model: Model, joint: str) -> tuple[tuple[float, float], ...]:
    """``(order [CPR], amplitude [N m])`` of a joint's PDTV lines of non-integer order, which a
    table over one motor revolution cannot hold (:func:`pdtv_map` leaves them out of its bins).

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> from torquemap.model import JointModel
    >>> rb = robot_from_dict({"robot": {"kinematics": "none"},
    ...                       "joints": {"m": {"gear_ratio": 9, "torque_constant": 0.5}}})
    >>> jm = JointModel(pdtv=(PdtvLine(order=7, amplitude=1.0, phase=0.0),
    ...                       PdtvLine(order=2.25, amplitude=0.5, phase=0.0)))
    >>> fractional_orders(Model(robot=rb, joints={"m": jm}), "m")
    ((2.25, 0.5),)
    """
    model.robot.joint(joint)
    return tuple(
        (float(ln.order), float(ln.amplitude))
        for ln in model.joints[joint].pdtv
        if not _is_integer(ln.order)
    )


def aliased_orders(model: Model, joint: str, bins: int) -> tuple[float, ...]:
    """Orders [CPR] of a joint's PDTV lines that a table of ``bins`` bins cannot hold.

    A firmware applies the table as a staircase (each bin's value over its interval). A line
    of order ``n >= bins / 2`` is sampled at two or fewer bins per period: the staircase then
    carries an alias of order ``|bins - n|`` (or none, at ``n = bins / 2`` with a phase of
    zeros), a ripple the motor does not have.

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> from torquemap.model import JointModel
    >>> rb = robot_from_dict({"robot": {"kinematics": "none"},
    ...                       "joints": {"m": {"gear_ratio": 1, "torque_constant": 0.5}}})
    >>> jm = JointModel(pdtv=(PdtvLine(order=7, amplitude=1.0, phase=0.0),
    ...                       PdtvLine(order=84, amplitude=1.0, phase=0.0)))
    >>> aliased_orders(Model(robot=rb, joints={"m": jm}), "m", 128)
    (84.0,)
    """
    model.robot.joint(joint)
    jm = model.joints[joint]
    return tuple(
        sorted(
            {float(ln.order) for ln in jm.pdtv if 2.0 * ln.order >= bins and _is_integer(ln.order)}
        )
    )


def quantise(
    values: ArrayLike, *, int_type: Literal["int16", "int8"]
) -> tuple[NDArray[np.int64], float]:
    """Integer table and its scale [unit per count], the largest ``|value|`` at full range.

    Examples
    --------
    >>> q, scale = quantise([0.5, -1.0], int_type="int8")
    >>> q.tolist(), scale
    ([64, -127], 0.007874015748031496)
    """
    v = np.asarray(values, dtype=np.float64)
    top = 32767 if int_type == "int16" else 127
    peak = float(np.max(np.abs(v))) if v.size else 0.0
    scale = peak / top if peak > 0 else 1.0
    return np.round(v / scale).astype(np.int64), scale


def write_pdtv_map(
    path: str | os.PathLike[str],
    table: PdtvMap,
    *,
    file_format: Literal["csv", "json", "c-header"] = "csv",
    int_type: Literal["int16", "int8"] = "int16",
) -> None:
    """Write a PDTV map atomically as CSV, JSON or a C header.

    CSV: columns ``motor_angle`` [rad], ``torque`` [N m], ``current`` [A]. JSON: an object
    with metadata and the three arrays. C header: the current as an ``int16_t``/``int8_t``
    array and its scale in amps per count, chosen so the largest ``|current|`` uses the full
    range.
    """
    if file_format == "csv":
        write_table(
            path,
            {"motor_angle": table.motor_angle, "torque": table.torque, "current": table.current},
        )
        return
    if file_format == "json":
        doc = {
            "joint": table.joint,
            "bins": int(table.motor_angle.size),
            "units": {"motor_angle": "rad", "torque": "N m", "current": "A"},
            "motor_angle_convention": "bin centre, 0 = encoder zero, motor side",
            "motor_angle": table.motor_angle.tolist(),
            "torque": table.torque.tolist(),
            "current": table.current.tolist(),
        }
        with atomic_output(path) as tmp:
            tmp.write_text(json.dumps(doc, indent=1) + "\n")
        return
    q, scale = quantise(table.current, int_type=int_type)
    ident = c_identifier(table.joint, fallback="joint").upper()
    ctype = "int16_t" if int_type == "int16" else "int8_t"
    full = 32767 if int_type == "int16" else 127
    rows = [", ".join(str(int(x)) for x in q[i : i + 16]) for i in range(0, q.size, 16)]
    text = (
        f"/* PDTV (anti-cogging) feed-forward current of joint '{c_comment(table.joint)}', "
        "written by torquemap.\n"
        f" * {q.size} bins over one motor revolution; bin k is centred at (k + 0.5) * 2 pi / {q.size}\n"
        f" * rad from the encoder zero. current [A] = table[k] * PDTV_{ident}_SCALE_A.\n"
        f" * The scale is chosen so the largest |current| uses the full {ctype} range (+-{full}). */\n"
        f"#ifndef PDTV_{ident}_H\n#define PDTV_{ident}_H\n#include <stdint.h>\n\n"
        f"#define PDTV_{ident}_BINS {q.size}\n"
        f"#define PDTV_{ident}_SCALE_A {c_float(float(f'{scale:.9g}'), suffix='f')} "
        "/* amps per count */\n\n"
        f"static const {ctype} pdtv_{ident.lower()}[PDTV_{ident}_BINS] = {{\n    "
        + ",\n    ".join(rows)
        + "\n};\n\n#endif\n"
    )
    with atomic_output(path) as tmp:
        tmp.write_text(text)


# ``torquemap.pdtv_map(...)`` calls :func:`torquemap.api.pdtv_map` (the module stays a module).
_make_callable(__name__, "torquemap.api:pdtv_map")
