"""ROS bag import: bags written by the test itself (ROS 1, ROS 2 sqlite3 and MCAP), read back."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from torquemap.cli.main import main
from torquemap.io import read_log, read_table, write_toml
from torquemap.robot import robot_from_dict

ROBOT = {
    "robot": {"name": "arm", "kinematics": "planar2r", "link_lengths": [0.3, 0.2]},
    "joints": {
        "a": {"gear_ratio": 100.0, "torque_constant": 0.1},
        "b": {"gear_ratio": 50.0, "torque_constant": 0.1},
    },
}
N = 200
T0 = 1_700_000_000.25


def truth() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = T0 + np.arange(N) * 0.01
    q = np.c_[np.sin(t - T0), 0.5 * np.cos(t - T0)]
    effort = np.c_[2.0 + np.sin(3 * (t - T0)), -1.0 + 0.1 * (t - T0)]
    return t, q, effort


def _messages(
    store: object, names: Sequence[str], order: Sequence[int], extra: bool
) -> list[tuple[int, object]]:
    types = store.types  # type: ignore[attr-defined]
    JointState = types["sensor_msgs/msg/JointState"]
    Header = types["std_msgs/msg/Header"]
    Time = types["builtin_interfaces/msg/Time"]
    t, q, effort = truth()
    out = []
    ros1 = "seq" in Header.__dataclass_fields__
    for k in range(N):
        seq = {"seq": k} if ros1 else {}
        sec = int(np.floor(t[k]))
        nsec = round((t[k] - sec) * 1e9)
        msg_names = [names[i] for i in order]
        pos = [q[k, i] for i in order]
        eff = [effort[k, i] for i in order]
        if extra:
            msg_names.append("gripper")
            pos.append(0.01)
            eff.append(0.5)
        msg = JointState(
            header=Header(stamp=Time(sec=sec, nanosec=nsec), frame_id="base", **seq),
            name=msg_names,
            position=np.array(pos),
            velocity=np.zeros(len(pos)),
            effort=np.array(eff),
        )
        out.append((sec * 10**9 + nsec, msg))
    return out


def write_bag(
    path: Path,
    kind: str,
    *,
    names: Sequence[str] = ("a", "b"),
    order: Sequence[int] = (1, 0),
    extra: bool = True,
    topic: str = "/joint_states",
) -> Path:
    """A bag of N JointState messages of ``truth()``; returns what to pass to the importer."""
    msgtype = "sensor_msgs/msg/JointState"
    if kind == "ros1":
        store = get_typestore(Stores.ROS1_NOETIC)
        bag = path.with_suffix(".bag")
        with Writer1(bag) as writer:
            conn = writer.add_connection(topic, msgtype, typestore=store)
            for ts, msg in _messages(store, names, order, extra):
                writer.write(conn, ts, store.serialize_ros1(msg, msgtype))
        return bag
    store = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.SQLITE3 if kind == "sqlite3" else StoragePlugin.MCAP
    with Writer2(path, version=9, storage_plugin=plugin) as writer:
        conn = writer.add_connection(topic, msgtype, typestore=store)
        for ts, msg in _messages(store, names, order, extra):
            writer.write(conn, ts, store.serialize_cdr(msg, msgtype))
    return path


@pytest.fixture
def robot_file(tmp_path: Path) -> Path:
    p = tmp_path / "robot.toml"
    write_toml(p, ROBOT)
    return p


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_import_every_bag_kind(kind: str, tmp_path: Path, robot_file: Path) -> None:
    bag = write_bag(tmp_path / f"bag_{kind}", kind)
    out = tmp_path / "log.parquet"
    argv = ["import", "rosbag", str(bag), "--robot", str(robot_file), "-o", str(out)]
    assert main(argv) == 0
    cols = read_table(out)
    t, q, effort = truth()
    np.testing.assert_allclose(cols["t"], t - t[0], atol=2e-9)
    np.testing.assert_allclose(cols["q_a"], q[:, 0])
    np.testing.assert_allclose(cols["q_b"], q[:, 1])
    # ROS effort is joint-side torque: the log holds the motor side, divided by the gear ratio
    np.testing.assert_allclose(cols["tau_a"], effort[:, 0] / 100.0)
    np.testing.assert_allclose(cols["tau_b"], effort[:, 1] / 50.0)
    assert "gripper" not in "".join(cols)
    # the log is a valid log for the robot
    log = read_log(out, robot_from_dict(ROBOT))
    np.testing.assert_allclose(log.motor_torque[:, 0], effort[:, 0] / 100.0)


def test_map_names_and_current(tmp_path: Path, robot_file: Path) -> None:
    bag = write_bag(tmp_path / "bag", "mcap", names=("shoulder", "elbow"))
    out = tmp_path / "log.csv"
    argv = ["import", "rosbag", str(bag), "--robot", str(robot_file), "-o", str(out)]
    argv += ["--map", "shoulder=a", "--map", "elbow=b", "--effort", "current"]
    assert main(argv) == 0
    cols = read_table(out)
    _, q, effort = truth()
    np.testing.assert_allclose(cols["i_a"], effort[:, 0])
    np.testing.assert_allclose(cols["q_b"], q[:, 1])
    assert "tau_a" not in cols


def test_storage_file_inside_a_ros2_bag(tmp_path: Path, robot_file: Path) -> None:
    bag = write_bag(tmp_path / "bag", "sqlite3")
    db3 = next(bag.glob("*.db3"))
    out = tmp_path / "log.csv"
    assert main(["import", "rosbag", str(db3), "--robot", str(robot_file), "-o", str(out)]) == 0
    assert read_table(out)["t"].size == N


def _error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    return err


def test_bad_bags_give_one_line_and_no_output(
    tmp_path: Path, robot_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "log.parquet"
    base = ["--robot", str(robot_file), "-o", str(out)]
    bag = write_bag(tmp_path / "good", "ros1")

    err = _error(["import", "rosbag", str(bag), "--topic", "/nope", *base], capsys)
    assert "'/nope' is not in the bag" in err and "/joint_states" in err

    err = _error(["import", "rosbag", str(bag), "--map", "x=zz", *base], capsys)
    assert "unknown joint 'zz'" in err

    lacking = write_bag(tmp_path / "lacking", "mcap", names=("a", "c"))
    err = _error(["import", "rosbag", str(lacking), *base], capsys)
    assert "holds all of the joints a, b" in err

    truncated = tmp_path / "trunc.bag"
    truncated.write_bytes(bag.read_bytes()[:700])
    err = _error(["import", "rosbag", str(truncated), *base], capsys)
    assert "trunc.bag" in err

    empty = tmp_path / "empty.bag"
    empty.write_bytes(b"")
    err = _error(["import", "rosbag", str(empty), *base], capsys)
    assert "empty.bag" in err

    folder = tmp_path / "folder"
    folder.mkdir()
    err = _error(["import", "rosbag", str(folder), *base], capsys)
    assert "metadata.yaml is missing" in err

    err = _error(["import", "rosbag", str(tmp_path / "missing.bag"), *base], capsys)
    assert "no such bag" in err
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir() if p.suffix == ".parquet") == []


def test_stamps_keep_their_nanoseconds(
    tmp_path: Path, robot_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # 1 kHz at a 2023 epoch, with 1 ns and 7 ns steps between some messages: float seconds since
    # the epoch step by 238 ns there, so they would merge the 1 ns pair (a false duplicate) and
    # move every t by up to 0.1 us; integer nanoseconds keep them exact
    store = get_typestore(Stores.ROS1_NOETIC)
    types = store.types
    msgtype = "sensor_msgs/msg/JointState"
    sec0, nsec0 = 1_700_000_000, 123_456_789
    offsets = [0, 1, 1_000_001, 2_000_000, 2_000_007, 3_000_000]
    bag = tmp_path / "ns.bag"
    with Writer1(bag) as writer:
        conn = writer.add_connection("/joint_states", msgtype, typestore=store)
        for k, off in enumerate(offsets):
            ns = sec0 * 10**9 + nsec0 + off
            stamp = types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            msg = types[msgtype](
                header=types["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id="base"),
                name=["a", "b"],
                position=np.array([0.001 * k, -0.001 * k]),
                velocity=np.zeros(2),
                effort=np.array([1.0, 2.0]),
            )
            writer.write(conn, ns, store.serialize_ros1(msg, msgtype))
    out = tmp_path / "log.csv"
    assert main(["import", "rosbag", str(bag), "--robot", str(robot_file), "-o", str(out)]) == 0
    t = read_table(out)["t"]
    # exact to float64 rounding of the elapsed time (1e-16 relative), far below 1 ns
    np.testing.assert_allclose(t, np.asarray(offsets) * 1e-9, rtol=1e-15, atol=1e-18)
    assert "first stamp 1700000000.123456789 s" in capsys.readouterr().out


@pytest.mark.parametrize("unit", ["counts", "turns"])
def test_positions_in_the_robot_files_unit(unit: str, tmp_path: Path) -> None:
    # JointState positions are radians; under a robot file whose joint a is logged in counts
    # (or turns) they were written as they are and read back as counts: the joint barely moved
    doc = {
        "robot": dict(ROBOT["robot"]),
        "joints": {k: dict(v) for k, v in ROBOT["joints"].items()},
    }
    doc["joints"]["a"].update(position_unit=unit, encoder_counts_per_rev=4096)
    robot_file = tmp_path / "robot.toml"
    write_toml(robot_file, doc)
    bag = write_bag(tmp_path / "bag", "ros1")
    out = tmp_path / "log.csv"
    argv = ["import", "rosbag", str(bag), "--robot", str(robot_file), "-o", str(out)]
    assert main(argv) == 0
    _, q, _ = truth()
    log = read_log(out, robot_from_dict(doc))
    np.testing.assert_allclose(log.q, q, atol=1e-12)
