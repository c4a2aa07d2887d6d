"""ROS bags to the log format: ``sensor_msgs/JointState`` from ROS 1 and ROS 2 bags, no ROS needed.

Reading uses the ``rosbags`` package, which parses ROS 1 ``.bag`` files and ROS 2 bag folders
(``metadata.yaml`` with sqlite3 ``.db3`` or MCAP ``.mcap`` storage) in pure Python.

Conventions (docs/rosbag.md): ``position`` is the joint angle [rad] and becomes ``q_<j>``;
``effort`` is, by ROS convention, the joint-side torque [N m], divided by the joint's gear ratio
into the motor-side ``tau_<j>``; with ``effort="current"`` it is the motor current [A] and becomes
``i_<j>`` unchanged. ``t`` is the header stamp [s] since the first kept message (the bag's receive
time where a stamp is zero).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.robot import Robot

JOINT_STATE = "sensor_msgs/msg/JointState"
EffortKind = Literal["torque", "current"]


@dataclass(frozen=True, slots=True, eq=False)
class JointStates:
    """The JointState messages of one topic, for the joints asked for.

    Attributes
    ----------
    t
        Seconds since the first kept message, strictly increasing, shape (n,).
    start
        Absolute time of the first kept message [s since the epoch] (rounded to a float).
    start_ns
        The same, exact: integer nanoseconds since the epoch.
    names
        The message joint names read, in the order asked for.
    position
        Joint positions [rad], shape (n, k).
    effort
        Joint efforts (N m or A), shape (n, k).
    skipped
        Messages skipped because they lacked one of the joints.
    duplicates
        Messages dropped because they repeated the previous stamp.
    path
        The bag.
    unwrapped
        Message names of the joints whose positions were wrapped to one turn and were unwrapped
        (:func:`unwrap_turns`).
    other_publishers
        ``(publisher, messages)`` of every other publisher (ROS 1 caller id) whose messages on
        the topic held every joint: dropped, only the publisher with the most such messages is
        read (:func:`read_joint_states`).
    """

    t: NDArray[np.float64]
    start: float
    start_ns: int
    names: tuple[str, ...]
    position: NDArray[np.float64]
    effort: NDArray[np.float64]
    skipped: int
    duplicates: int
    path: str
    unwrapped: tuple[str, ...] = ()
    other_publishers: tuple[tuple[str, int], ...] = ()


def _bag_paths(bag: Path) -> list[Path]:
    """What AnyReader opens: a ROS 1 file, or a ROS 2 folder (a .db3/.mcap file means its folder)."""
    if not bag.exists():
        raise InputError("no such bag", path=bag)
    if bag.is_file() and bag.suffix == ".bag":
        return [bag]
    if bag.is_file() and bag.suffix in (".db3", ".mcap"):
        if (bag.parent / "metadata.yaml").is_file():
            return [bag.parent]
        raise InputError(
            "a ROS 2 bag is a folder with metadata.yaml; none next to this storage file",
            path=bag,
        )
    if bag.is_dir():
        if not (bag / "metadata.yaml").is_file():
            raise InputError("not a ROS 2 bag folder: metadata.yaml is missing", path=bag)
        return [bag]
    raise InputError("not a ROS bag (expected a ROS 1 .bag file or a ROS 2 bag folder)", path=bag)


def read_joint_states(
    bag: str | os.PathLike[str], topic: str, names: tuple[str, ...]
) -> JointStates:
    """Read the JointState messages of ``topic`` for the joints ``names``.

    Messages that lack one of the joints are skipped (publishers often split joint groups over
    messages); a message that repeats the previous stamp is dropped.

    Parameters
    ----------
    bag
        A ROS 1 ``.bag`` file, a ROS 2 bag folder, or the ``.db3``/``.mcap`` file inside one.
    topic
        The JointState topic, for example ``/joint_states``.
    names
        Joint names as they appear in the messages.

    Returns
    -------
    JointStates

    Raises
    ------
    InputError
        Unreadable, empty or truncated bag; topic not in the bag (the JointState topics are
        listed); a topic of another type; no message holding every joint (naming joints that
        come in separate messages); an empty effort; NaN or inf; a stamp going back in time.

    Notes
    -----
    Where more than one publisher's messages on the topic hold every joint (a ROS 1 bag records
    each caller id apart: a relay republishing the driver's states at a lower rate with its own
    stamps, a second driver), only the publisher with the most such messages is read; the
    others are listed in ``other_publishers``. Before (new-user QA, stop 36), their messages
    were merged in time order: a relay's copies, 20 ms stale, read as the joints stepping back
    and forth, and the forces of random SCARA 7's circle were 8.2 N off (1.2 N clean), exit 0.
    """
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    path = Path(bag)
    paths = _bag_paths(path)
    rows_ns: list[int] = []  # integer nanoseconds: a float second has ~0.2 us steps in 2025
    rows_q: list[list[float]] = []
    rows_e: list[list[float]] = []
    skipped = duplicates = 0
    # every message holding the joints, with its index and publisher, before the checks of time
    # (kept from one publisher only: read_joint_states' Notes)
    full: list[tuple[int, int, int, list[float], list[float]]] = []
    publishers: dict[int, str] = {}
    partial: dict[str, int] = {}
    try:
        with AnyReader(paths, default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            conns = [c for c in reader.connections if c.topic == topic]
            if not conns:
                states = sorted({c.topic for c in reader.connections if c.msgtype == JOINT_STATE})
                listed = ", ".join(states) if states else "none"
                raise InputError(
                    f"topic {topic!r} is not in the bag (JointState topics: {listed})", path=path
                )
            wrong = {c.msgtype for c in conns if c.msgtype != JOINT_STATE}
            if wrong:
                raise InputError(
                    f"topic {topic!r} carries {', '.join(sorted(wrong))}, not {JOINT_STATE}",
                    path=path,
                )
            for conn in conns:
                publishers[conn.id] = str(getattr(conn.ext, "callerid", None) or conn.id)
            for index, (conn, stamp_ns, raw) in enumerate(reader.messages(connections=conns)):
                msg: Any = reader.deserialize(raw, conn.msgtype)
                header = msg.header.stamp
                ns = int(header.sec) * 1_000_000_000 + int(header.nanosec)
                if ns == 0:
                    ns = int(stamp_ns)
                present = list(msg.name)
                if not all(n in present for n in names):
                    skipped += 1
                    for n in names:
                        if n in present:
                            partial[n] = partial.get(n, 0) + 1
                    continue
                cols = [present.index(n) for n in names]
                position = np.asarray(msg.position, dtype=np.float64)
                effort = np.asarray(msg.effort, dtype=np.float64)
                if position.size != len(present):
                    raise InputError(
                        f"message {index} on {topic} has {len(present)} names but "
                        f"{position.size} positions",
                        path=path,
                    )
                if effort.size != len(present):
                    raise InputError(
                        f"message {index} on {topic} has no effort for every joint "
                        f"({effort.size} values for {len(present)} names)",
                        path=path,
                    )
                q, e = position[cols], effort[cols]
                if not (np.all(np.isfinite(q)) and np.all(np.isfinite(e))):
                    raise InputError(
                        f"message {index} on {topic} holds NaN or inf in position or effort",
                        path=path,
                    )
                full.append((index, conn.id, ns, q.tolist(), e.tolist()))
    except InputError:
        raise
    except FileNotFoundError:
        raise InputError("no such bag", path=path) from None
    except Exception as exc:  # rosbags raises many types on corrupt input
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(
            f"cannot read ROS bag, truncated or corrupt ({detail})", path=path
        ) from None
    counts: dict[int, int] = {}
    for _, conn_id, _, _, _ in full:
        counts[conn_id] = counts.get(conn_id, 0) + 1
    main = max(counts, key=lambda c: (counts[c], -c)) if counts else None
    others = tuple((publishers[c], n) for c, n in counts.items() if c != main)
    for index, conn_id, ns, q_row, e_row in full:
        if conn_id != main:
            continue
        if rows_ns and ns <= rows_ns[-1]:
            if ns == rows_ns[-1]:
                duplicates += 1
                continue
            raise InputError(
                f"message {index} on {topic} is stamped {1e-9 * (rows_ns[-1] - ns):.6g} s "
                "before the previous one (time must increase)",
                path=path,
            )
        rows_ns.append(ns)
        rows_q.append(q_row)
        rows_e.append(e_row)
    if not rows_ns:
        separate = ""
        if skipped and len(partial) == len(names) and len(names) > 1:
            each = ", ".join(f"{n} in {partial[n]}" for n in names)
            separate = (
                f"; the joints come in separate messages ({each}): torquemap needs every "
                "joint's reading of a sample in one message; publish them together, or "
                "resample them onto one time base first"
            )
        raise InputError(
            f"no message on {topic} holds all of the joints {', '.join(names)}"
            + (
                f" ({skipped} messages lacked some{separate})"
                if skipped
                else " (the topic is empty)"
            ),
            path=path,
        )
    if len(rows_ns) < 2:
        raise InputError(f"only one usable message on {topic}; a log needs two", path=path)
    # subtract in integers, then scale: exact to the nanosecond over any bag (float seconds since
    # the epoch would round every stamp to about 0.2 us first)
    elapsed = np.asarray(rows_ns, dtype=np.int64) - rows_ns[0]
    return JointStates(
        t=elapsed.astype(np.float64) * 1e-9,
        start=rows_ns[0] * 1e-9,
        start_ns=rows_ns[0],
        names=tuple(names),
        position=np.asarray(rows_q, dtype=np.float64),
        effort=np.asarray(rows_e, dtype=np.float64),
        skipped=skipped,
        duplicates=duplicates,
        path=os.fspath(path),
        other_publishers=others,
    )


def unwrap_turns(states: JointStates) -> JointStates:
    """Unwrap the joints whose positions jump by a whole turn between two messages.

    ROS publishes a continuous joint's position wrapped to (-pi, pi]: each time it passes pi
    it jumps by 2 pi, which the log would read as the joint spinning a turn in one sample. A
    joint whose every step longer than pi is within 5 % of a whole turn is unwrapped
    (``numpy.unwrap``); its name is added to ``unwrapped``.

    Examples
    --------
    >>> q = np.angle(np.exp(1j * np.linspace(0.0, 10.0, 50)))[:, None]  # wrapped
    >>> s = JointStates(np.arange(50.0), 0.0, 0, ("w",), q, q, 0, 0, "bag")
    >>> u = unwrap_turns(s)
    >>> u.unwrapped, round(float(u.position[-1, 0]), 6)
    (('w',), 10.0)
    """
    position = states.position.copy()
    names: list[str] = []
    for k, name in enumerate(states.names):
        column = position[:, k]
        big = np.abs(np.diff(column))
        big = big[big > np.pi]
        if big.size and bool(np.all(np.abs(big - 2.0 * np.pi) < 0.05 * 2.0 * np.pi)):
            position[:, k] = np.unwrap(column)
            names.append(name)
    if not names:
        return states
    return replace(states, position=position, unwrapped=tuple(names))


def parse_mapping(pairs: list[str] | None, robot: Robot) -> dict[str, str]:
    """``["msg_name=joint", ...]`` to {robot joint: message name}; identity for the rest.

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> r = robot_from_dict({"robot": {"name": "r", "kinematics": "none"},
    ...                      "joints": {"a": {"gear_ratio": 1.0, "torque_constant": 0.1}}})
    >>> parse_mapping(["shoulder_joint=a"], r)
    {'a': 'shoulder_joint'}
    """
    out = {j.name: j.name for j in robot.joints}
    for pair in pairs or []:
        name, sep, joint = pair.partition("=")
        if not sep or not name or not joint:
            raise InputError(f"--map expects name=joint, got {pair!r}")
        if joint not in out:
            raise InputError(
                f"--map {pair!r}: unknown joint {joint!r} (robot joints: "
                f"{', '.join(robot.joint_names)})"
            )
        out[joint] = name
    return out


def log_columns(
    states: JointStates,
    robot: Robot,
    mapping: Mapping[str, str],
    *,
    effort: EffortKind = "torque",
) -> dict[str, NDArray[np.float64]]:
    """Log columns (docs/formats.md) from JointState data read with :func:`read_joint_states`."""
    if effort not in ("torque", "current"):
        raise InputError(f"--effort must be torque or current, got {effort!r}")
    cols: dict[str, NDArray[np.float64]] = {"t": states.t}
    for joint in robot.joints:
        k = states.names.index(mapping[joint.name])
        # JointState positions are joint-side radians; the log's q_<j> is in the robot file's
        # position_unit (before: radians written under a "counts" file, read back as counts)
        scale = 1.0
        if joint.position_unit == "counts" and joint.encoder_counts_per_rev:
            scale = joint.gear_ratio * joint.encoder_counts_per_rev / (2.0 * np.pi)
        elif joint.position_unit == "turns":
            scale = joint.gear_ratio / (2.0 * np.pi)
        cols[f"q_{joint.name}"] = states.position[:, k] * scale
    for joint in robot.joints:
        k = states.names.index(mapping[joint.name])
        if effort == "torque":
            cols[f"tau_{joint.name}"] = states.effort[:, k] / joint.gear_ratio
        else:
            cols[f"i_{joint.name}"] = states.effort[:, k]
    return cols


def import_rosbag(
    bag: str | os.PathLike[str],
    robot: Robot,
    topic: str,
    out: str | os.PathLike[str],
    *,
    mapping: list[str] | None = None,
    effort: EffortKind = "torque",
) -> JointStates:
    """Convert a bag's JointState topic into a log file (CSV or Parquet by suffix), atomically;
    positions wrapped to one turn (continuous joints) are unwrapped (:func:`unwrap_turns`)."""
    from torquemap.io import write_table

    names = parse_mapping(mapping, robot)
    states = unwrap_turns(read_joint_states(bag, topic, tuple(names[j.name] for j in robot.joints)))
    write_table(out, log_columns(states, robot, names, effort=effort))
    return states


__all__ = [
    "JOINT_STATE",
    "JointStates",
    "import_rosbag",
    "log_columns",
    "parse_mapping",
    "read_joint_states",
    "unwrap_turns",
]
