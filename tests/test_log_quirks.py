"""Logs as real controllers and loggers write them: quirks that gave wrong numbers silently or
refusals that did not say why (new-user QA, stop 36; docs/safety.md, "Log quirks QA").

Each test builds its log here, small and seeded, and asserts one independent fact: the exact
refusal or warning, or the same numbers as the clean log.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from torquemap.errors import InputError
from torquemap.io import iter_log_chunks, log_from_columns, read_log, write_table
from torquemap.robot import Joint, Robot

#: The paper bench's joint a: 100:1, 8000 counts per motor turn, logged as raw counts.
COUNTS = Robot(
    name="m", kinematics="none", link_lengths=(), joints=(Joint("m", 100.0, 0.11, 8000, "counts"),)
)


def _counts(n: int = 4000) -> dict[str, np.ndarray]:
    """A joint sweeping 1 rad and back at 1 kHz: 16 motor turns, 127 324 counts."""
    t = np.arange(n) * 1e-3
    joint = np.sin(math.pi * t / t[-1])
    counts = np.floor(joint * 100.0 * 8000 / (2 * math.pi))
    return {"t": t, "q_m": counts, "i_m": np.cos(t)}


@pytest.mark.parametrize(
    ("bits", "register"),
    [
        (16, lambda c: (c + 2**15) % 2**16 - 2**15),  # int16 timer in encoder mode
        (16, lambda c: c % 2**16),  # the same, written unsigned
        (32, lambda c: (c - 5000.0) % 2**32),  # a signed count near zero written as uint32
    ],
)
def test_an_overflowing_count_register_is_refused(
    tmp_path: Path, bits: int, register: object
) -> None:
    # Before: each overflow was unwrapped as whole turns, leaving 1536 counts (0.19 turn) of
    # an 8000-count encoder behind; the paper bench's forces were 10 to 35 N off, exit 0.
    cols = _counts()
    clean = log_from_columns(cols, COUNTS)
    assert clean.q[:, 0].max() == pytest.approx(1.0, abs=1e-4)  # the clean log reads right
    cols["q_m"] = register(cols["q_m"])  # type: ignore[operator]
    rows = np.flatnonzero(np.abs(np.abs(np.diff(cols["q_m"])) - 2.0**bits) < 2.0**bits / 4)
    message = (
        rf"joint m: q_m steps by [+-]\d+ counts at data row {rows[0] + 2}: a {bits}-bit count "
        rf"register overflowed \(or a signed count was written unsigned\), so the log holds the "
        rf"count only modulo 2\*\*{bits}"
    )
    with pytest.raises(InputError, match=message):
        log_from_columns(cols, COUNTS)
    p = tmp_path / "log.parquet"  # read in chunks (estimate's large logs): the same row
    write_table(p, cols)
    with pytest.raises(InputError, match=message):
        list(iter_log_chunks(p, COUNTS, rows=700))
    with pytest.raises(InputError, match=message):
        read_log(p, COUNTS)


#: The paper bench's robot in rad, with its encoder declared.
RAD = Robot(
    name="m", kinematics="none", link_lengths=(), joints=(Joint("m", 100.0, 0.11, 8000, "rad"),)
)


@pytest.mark.parametrize(
    ("scale", "says"),
    [
        (100.0, r"q_m holds the motor angle, not the joint angle \(the 100:1 gear not applied\)"),
        (1 / 100.0, r"q_m holds the joint angle divided by the gear ratio once more"),
        (100.0 / (2 * math.pi), r"q_m holds motor turns \(as ODrive's pos_estimate\)"),
        (1 / (2 * math.pi), r"q_m holds joint turns, not rad: multiply it by 2 pi"),
        (180 / math.pi, r"q_m holds degrees, not rad"),
    ],
)
def test_an_angle_in_another_unit_is_named(scale: float, says: str) -> None:
    # Before: identified and estimated alike (random SCARA 7), forces 35 to 39 N off, exit 0;
    # a model from good logs refused such a task log as "a log from another robot?".
    from torquemap.estimate import check_log_angle_units
    from torquemap.identify import identify_model
    from torquemap.log_quirks import check_angle_units
    from torquemap.model import model_from_dict

    cols = _counts()
    cols["q_m"] = cols["q_m"] * (2 * math.pi / 8000 / 100.0)  # the joint angle [rad]
    check_angle_units([log_from_columns(cols, RAD)], RAD)  # the clean log passes
    cols["q_m"] = cols["q_m"] * scale
    log = log_from_columns(cols, RAD, path="sweep.csv")
    with pytest.raises(InputError, match=r"sweep.csv: joint m: the log's angle moves in steps "):
        identify_model(RAD, [log])
    with pytest.raises(InputError, match=says):
        identify_model(RAD, [log])
    document = {
        "robot": {"kinematics": "none"},
        "joints": {"m": {"gear_ratio": 100.0, "torque_constant": 0.11}},
        "identification": {"joints": {"m": {"motor_angle_quantum": 2 * math.pi / 8000}}},
    }
    model = model_from_dict(document)
    check_log_angle_units(model, log_from_columns(_counts(), COUNTS))  # the clean log passes
    with pytest.raises(InputError, match=says):
        check_log_angle_units(model, log)


def _wrap(period: float) -> object:
    """Stamps of a counter that wraps every ``period`` [s], read as seconds."""
    return lambda t: (t + period - 1.5) % period  # wraps 1.5 s into the log


def _interleaved(t: np.ndarray) -> np.ndarray:
    late = t.copy()
    late[1::2] += 0.0123  # every other row stamped by the host, 12 ms late
    return late


def _swapped(t: np.ndarray) -> np.ndarray:
    out = t.copy()
    out[[2100, 2101]] = out[[2101, 2100]]
    return out


@pytest.mark.parametrize(
    ("stamp", "says"),
    [
        (
            _wrap(2**32 * 1e-6),
            r"\(at data row 1501\): t falls by 4294.97 s: a 32-bit microsecond time stamp counter "
            r"wrapped \(every 4294.967296 s\); add 4294.967296 s to t from data row 1501 on",
        ),
        (
            _wrap(2**16 * 1e-3),
            r"\(at data row 1501\): t falls by 65.535 s: a 16-bit millisecond time stamp counter "
            r"wrapped \(every 65.536 s\); add 65.536 s to t from data row 1501 on",
        ),
        (
            _interleaved,
            r"\(at data row 3\): t goes back on \d+ of its \d+ steps \(by 0.0113 s in the "
            r"median\): time stamps of two clocks interleaved",
        ),
        (
            _swapped,
            r"\(at data row 2102\): data rows 2101 and 2102 are out of order \(t 2.101 then 2.1\)",
        ),
    ],
)
def test_time_going_back_says_why(tmp_path: Path, stamp: object, says: str) -> None:
    # Before: "time 't' goes backwards (at data row 1501)" and nothing more.
    cols = _counts()
    cols["t"] = stamp(cols["t"])  # type: ignore[operator]
    with pytest.raises(InputError, match=r"time 't' goes backwards " + says):
        log_from_columns(cols, COUNTS)
    p = tmp_path / "log.parquet"  # in chunks, the fault in a later chunk: the same words
    write_table(p, cols)
    with pytest.raises(InputError, match=r"time 't' goes backwards " + says):
        list(iter_log_chunks(p, COUNTS, rows=1400))


def test_time_stamps_rounded_to_a_large_part_of_the_step_are_warned() -> None:
    # Before: a 400 Hz log written with 3 decimals (steps of 2 and 3 ms) was estimated without
    # a word, its force error 1.41 N against 1.20 N (random SCARA 7).
    from torquemap.sanitize import sanitize_log

    rng = np.random.default_rng(0)
    ticks = np.cumsum(rng.integers(4, 7, 2000))  # 400 Hz, jittered on a 2 kHz servo's ticks
    cols = _counts(2000)
    cols["t"] = ticks * 5e-4
    exact = sanitize_log(log_from_columns(cols, COUNTS), window=0.05)
    assert exact.warnings == ()  # the servo's own ticks are no rounding
    cols["t"] = np.round(ticks * 5e-4, 3)
    rounded = sanitize_log(log_from_columns(cols, COUNTS), window=0.05)
    coarse = [w for w in rounded.warnings if w.startswith("'t' is written with 3 decimals")]
    assert len(coarse) == 1
    assert "each stamp may be off by up to 0.0005 s" in coarse[0]
    cols["t"] = np.arange(2000) * 1e-3  # 1 kHz in whole ms: exact
    assert sanitize_log(log_from_columns(cols, COUNTS), window=0.05).warnings == ()


@pytest.mark.parametrize(
    ("rows", "says"),
    [
        (
            ["s,counts,A", "0,1,0.5"],
            r"column 't' is not numeric \(data row 1: 's'\): a units row under the header\? "
            r"delete it",
        ),
        (['"0",1,0.5', '"0,0025",2,0.5'], r"\(data row 2: '0,0025'\): decimal commas"),
        (
            ["0,0025,1,0,5", "0,005,2,0,5"],
            r"the rows hold more commas than the header: decimal commas\? write numbers with a "
            r"decimal point",
        ),
    ],
)
def test_a_units_row_and_decimal_commas_are_named(
    tmp_path: Path, rows: list[str], says: str
) -> None:
    # Before: "column 't' is not numeric (data row 1: 's')", "cannot parse table, truncated or
    # malformed (Expected 3 columns, got 5 ...)" and nothing more.
    p = tmp_path / "log.csv"
    p.write_text("\n".join(["t,q_m,i_m", *rows]) + "\n")
    with pytest.raises(InputError, match=says):
        read_log(p, COUNTS)
    if "units" in says:  # the block reader of large logs (estimate) says it too
        with pytest.raises(InputError, match=r"the first row is a units row under the header\?"):
            list(iter_log_chunks(p, COUNTS))


def _bag(path: Path, publishers: list[tuple[str, tuple[str, ...], int, int]]) -> Path:
    """A ROS 1 bag on /joint_states: per publisher (caller id, joints, every n-th sample, stamp
    delay [ns]), JointState messages of one 400 Hz motion (q = sin t, effort = cos t)."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    types = store.types
    state, header, time = (
        types["sensor_msgs/msg/JointState"],
        types["std_msgs/msg/Header"],
        types["builtin_interfaces/msg/Time"],
    )
    items = []
    with Writer(path) as writer:
        for caller, joints, every, delay in publishers:
            conn = writer.add_connection(
                "/joint_states", "sensor_msgs/msg/JointState", typestore=store, callerid=caller
            )
            for k in range(0, 800, every):
                items.append((1_700_000_000 * 10**9 + k * 2_500_000 + delay, conn, joints, k))
        for seq, (ns, conn, joints, k) in enumerate(sorted(items, key=lambda x: x[0])):
            msg = state(
                header=header(
                    seq=seq, stamp=time(sec=ns // 10**9, nanosec=ns % 10**9), frame_id=""
                ),
                name=list(joints),
                position=np.full(len(joints), math.sin(k * 0.0025)),
                velocity=np.zeros(len(joints)),
                effort=np.full(len(joints), math.cos(k * 0.0025)),
            )
            writer.write(conn, ns, store.serialize_ros1(msg, "sensor_msgs/msg/JointState"))
    return path


def test_a_bag_with_a_second_publisher_reads_the_driver_alone(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Before: a relay republishing every 4th state 20 ms late was merged in time order, its
    # stale copies read as the joints stepping back and forth (random SCARA 7's circle: forces
    # 8.2 N off against 1.2 N, exit 0); joints published in separate messages were refused
    # without saying so.
    from torquemap.cli.main import main
    from torquemap.io import read_table, write_toml

    robot = tmp_path / "robot.toml"
    write_toml(robot, {"robot": {"kinematics": "none"}, "joints": {"a": {"gear_ratio": 1.0, "torque_constant": 0.1}}})  # fmt: skip
    bag = _bag(
        tmp_path / "relay.bag", [("/drive", ("a",), 1, 0), ("/relay", ("a",), 4, 20_000_000)]
    )
    out = tmp_path / "log.csv"
    assert main(["import", "rosbag", str(bag), "--robot", str(robot), "-o", str(out), "--effort", "current"]) == 0  # fmt: skip
    err = capsys.readouterr().err
    assert "more than one publisher on /joint_states sends every joint" in err
    assert "dropped /relay's 200" in err
    log = read_table(out)
    # the driver's own stamps (integer ns times 1e-9: within a rounding of float64)
    np.testing.assert_allclose(log["t"], np.arange(800) * 0.0025, rtol=0, atol=1e-15)
    np.testing.assert_allclose(log["q_a"], np.sin(np.arange(800) * 0.0025), rtol=0, atol=1e-15)
    bag = _bag(tmp_path / "split.bag", [("/drive_a", ("a",), 1, 0), ("/drive_b", ("b",), 4, 0)])
    two = tmp_path / "robot2.toml"
    write_toml(two, {"robot": {"kinematics": "none"}, "joints": {"a": {"gear_ratio": 1.0, "torque_constant": 0.1}, "b": {"gear_ratio": 1.0, "torque_constant": 0.1}}})  # fmt: skip
    assert main(["import", "rosbag", str(bag), "--robot", str(two), "-o", str(out)]) == 2
    assert "the joints come in separate messages (a in 800, b in 200)" in capsys.readouterr().err


def test_a_multi_turn_count_moving_more_than_half_a_turn_between_samples_is_motion() -> None:
    # Before: a step of a multi-turn counter beyond half a turn within 0.125 s was unwrapped
    # as a wrap: random SCARA 7's circle in counts (0.66 motor turn across a 0.1 s gap) read
    # joint b one turn off from there on, forces 1.36 N off against 1.20 N from the log in rad.
    cols = _counts()
    cols["t"][2000:] += 0.1  # a 0.1 s gap ...
    cols["q_m"][2000:] += 5300.0  # ... across which the motor turned 0.66 turn more
    log = log_from_columns(cols, COUNTS)
    np.testing.assert_allclose(
        log.q[:, 0], cols["q_m"] * (2 * math.pi / 8000 / 100.0), rtol=0, atol=1e-12
    )
    fast = _counts(40)  # a fast motor logged slowly: 0.6 turn a sample, every sample
    fast["q_m"] = 20_000.0 + 4800.0 * np.arange(40)
    np.testing.assert_allclose(
        log_from_columns(fast, COUNTS).q[:, 0],
        fast["q_m"] * (2 * math.pi / 8000 / 100.0),
        rtol=0,
        atol=1e-12,
    )


def test_a_float32_parquet_log_of_a_fine_encoder_is_read_as_the_robots(tmp_path: Path) -> None:
    # Before: random SCARA 7's circle (2**17 counts, 46:1) with q as float32 was refused as "a
    # log from another robot?": float32 rounds its steps by up to 0.06 count.
    from torquemap.estimate import check_log_matches_model, check_log_steps_exact
    from torquemap.model import model_from_dict

    gear, cpr = 46.21665132328604, 2**17
    count = 2 * math.pi / cpr / gear  # one count at the joint [rad]
    t = np.arange(3000) * 2.5e-3
    counts = np.floor(0.84 / count * np.sin(0.3 * t) + 5000.0 * np.sin(2.0 * t))
    document = {
        "robot": {"kinematics": "none"},
        "joints": {"a": {"gear_ratio": gear, "torque_constant": 0.05}},
        "identification": {"joints": {"a": {"motor_angle_quantum": 2 * math.pi / cpr}}},
    }
    model = model_from_dict(document)
    p = tmp_path / "log.parquet"
    import pyarrow as pa
    import pyarrow.parquet as pq

    for other in (1.0, 1.013):  # the robot's own log, and one of a 1.3 % other gear
        q = (counts * count * other).astype(np.float32)
        pq.write_table(pa.table({"t": t, "q_a": q, "i_a": np.cos(t)}), p)
        log = read_log(p, model.robot)
        if other == 1.0:
            check_log_matches_model(model, log)
            check_log_steps_exact(model, log)
            continue
        with pytest.raises(InputError, match="a log from another robot"):
            check_log_matches_model(model, log)
            check_log_steps_exact(model, log)


def test_angles_computed_from_an_overflowing_register_are_refused() -> None:
    # Before: the drive's 16-bit count turned into rad jumped by 0.51 rad at each overflow,
    # taken for an encoder glitch: the log was cut there and every later angle was off (the
    # paper bench's forces 73.7 N off, exit 0).
    from torquemap.estimate import check_log_angle_units
    from torquemap.identify import identify_model
    from torquemap.model import model_from_dict

    cols = _counts()
    cols["q_m"] = ((cols["q_m"] + 2**15) % 2**16 - 2**15) * (2 * math.pi / 8000 / 100.0)
    log = log_from_columns(cols, RAD, path="task.csv")
    says = (
        r"task.csv: joint m: q_m steps by -0.51\d* rad at t = 0.\d+ s, -65\d\d\d encoder counts: a "
        r"16-bit count register overflowed before the angle was computed from it"
    )
    with pytest.raises(InputError, match=says):
        identify_model(RAD, [log])
    document = {
        "robot": {"kinematics": "none"},
        "joints": {"m": {"gear_ratio": 100.0, "torque_constant": 0.11, "encoder_counts_per_rev": 8000}},
    }  # fmt: skip
    with pytest.raises(InputError, match=says):
        check_log_angle_units(model_from_dict(document), log)


@pytest.mark.parametrize(
    ("tick", "name"), [(1e-3, "milliseconds"), (1e-6, "microseconds"), (1e-9, "nanoseconds")]
)
def test_unix_time_in_integer_ticks_is_named(tmp_path: Path, tick: float, name: str) -> None:
    # Before (stop 39): "column 't' value 1.7643e+18 s at data row 1 is beyond +-1e+10 s", no
    # word of what the number is; ROS and most loggers stamp in integer nanoseconds since 1970.
    cols = _counts()
    cols["t"] = np.round((1_764_300_000.0 + cols["t"]) / tick)
    message = rf"column 't' value .* beyond \+-1e\+10 s: Unix time in {name}\? write t in seconds"
    p = tmp_path / "log.csv"
    write_table(p, cols)
    with pytest.raises(InputError, match=message):
        read_log(p, COUNTS)
    q = tmp_path / "log.parquet"  # estimate's block reader: the same words
    write_table(q, cols)
    with pytest.raises(InputError, match=message):
        list(iter_log_chunks(q, COUNTS, rows=700))
    cols["t"] = cols["t"] * tick  # the same stamps in seconds read fine
    assert read_log(_written(tmp_path / "s.csv", cols), COUNTS).t[0] == pytest.approx(1.7643e9)


def _written(path: Path, cols: dict[str, np.ndarray]) -> Path:
    write_table(path, cols)
    return path
