"""Log files (CSV and Parquet), counts unwrapping, atomic writes, and every bad-input path."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from torquemap.errors import InputError
from torquemap.io import (
    atomic_output,
    numeric_column,
    read_log,
    read_table,
    write_table,
    write_toml,
)
from torquemap.robot import Joint, Robot, read_toml

ROBOT = Robot(
    name="arm",
    kinematics="planar2r",
    link_lengths=(0.25, 0.2),
    joints=(Joint("a", 100.0, 0.11, 8000), Joint("b", 80.0, 0.08, 8000)),
)


def _columns(n: int = 50, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.0004, 0.0006, n))  # irregular sampling is allowed
    return {
        "t": t,
        "q_a": np.sin(t),
        "q_b": rng.normal(size=n),
        "i_a": rng.normal(size=n),
        "i_b": rng.normal(size=n) * 1e-7,
        "note": np.arange(n),  # other columns are ignored
    }


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_table_round_trip(tmp_path: Path, suffix: str) -> None:
    cols = _columns()
    p = tmp_path / f"log{suffix}"
    write_table(p, cols)
    back = read_table(p)
    assert list(back) == list(cols)
    for name, values in cols.items():
        # CSV writes the shortest repr that round-trips a float64; Parquet is binary: exact.
        assert_array_equal(back[name], values)


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_read_log_current_times_torque_constant(tmp_path: Path, suffix: str) -> None:
    cols = _columns()
    p = tmp_path / f"log{suffix}"
    write_table(p, cols)
    log = read_log(p, ROBOT)
    assert log.joint_names == ("a", "b")
    assert log.path == str(p)
    assert_array_equal(log.t, cols["t"])
    assert_array_equal(log.q, np.stack([cols["q_a"], cols["q_b"]], axis=-1))
    # tau = i * torque_constant, one multiplication: exact to rounding.
    assert_allclose(log.motor_torque[:, 0], cols["i_a"] * 0.11, rtol=1e-15)
    assert_allclose(log.motor_torque[:, 1], cols["i_b"] * 0.08, rtol=1e-15)


def test_torque_column_is_used_as_is(tmp_path: Path) -> None:
    cols = _columns()
    cols["tau_a"] = cols.pop("i_a") * 3.0
    p = tmp_path / "log.csv"
    write_table(p, cols)
    assert_array_equal(read_log(p, ROBOT).motor_torque[:, 0], cols["tau_a"])


def test_counts_are_converted_and_unwrapped(tmp_path: Path) -> None:
    cpr, ratio = 8192, 50.0
    robot = Robot(
        name="m",
        kinematics="none",
        link_lengths=(),
        joints=(Joint("m", ratio, 1.0, cpr, "counts"),),
    )
    t = np.arange(4000) * 1e-3
    motor_angle = 0.3 + 20.0 * np.sin(0.8 * t) + 9.0 * t  # several revolutions, both ways
    counts = np.floor(motor_angle / (2 * math.pi / cpr))
    wrapped = np.mod(counts, cpr)  # the encoder register wraps once per revolution
    assert np.any(np.diff(wrapped) > cpr / 2) and np.any(np.diff(wrapped) < -cpr / 2)
    p = tmp_path / "log.csv"
    write_table(p, {"t": t, "q_m": wrapped, "i_m": np.zeros_like(t)})
    q = read_log(p, robot).q[:, 0]
    # Unwrapped to the first revolution's origin: within one count of the true joint angle.
    assert_allclose(q, motor_angle / ratio, atol=2 * math.pi / cpr / ratio)


def _write_csv(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "log.csv"
    p.write_text(text)
    return p


GOOD = "t,q_a,q_b,i_a,i_b\n0,0,0,0,0\n0.5,1,1,1,1\n1,2,2,2,2\n"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("t,q_a,i_a,i_b\n0,0,0,0\n1,1,1,1\n", r"missing column 'q_b'"),
        (
            "t,q_a,q_b,i_a\n0,0,0,0\n1,1,1,1\n",
            r"missing column 'i_b' or 'tau_b' for joint 'b' \(the file has t, q_a, q_b, i_a\)",
        ),
        ("q_a,q_b,i_a,i_b\n0,0,0,0\n1,1,1,1\n", r"missing column 't'"),
        # what the file holds instead: another separator, a near miss, else its columns
        (
            GOOD.replace(",", ";"),
            r"missing column 't' \(the header is one column, 't;q_a;q_b;i_a;i_b': separate",
        ),
        (GOOD.replace("t,", "T,", 1), r"missing column 't' \(the file has 'T': names are exact"),
        (GOOD.replace("q_a,", "q_a [rad],", 1), r"'q_a' \(the file has 'q_a \[rad\]': names"),
        (GOOD.replace("t,", "x,", 1), r"missing column 't' \(the file has x, q_a, q_b, i_a, i_b\)"),
        (
            GOOD.replace("0.5,1,1,1,1", "0.5,nan,1,1,1"),
            r"'q_a' holds NaN or inf \(first at data row 2\)",
        ),
        (
            GOOD.replace("1,2,2,2,2", "1,2,2,inf,2"),
            r"'i_a' holds NaN or inf \(first at data row 3\)",
        ),
        (GOOD.replace("0.5,1,1,1,1", "0.5,1,,1,1"), r"'q_b' holds NaN or inf"),
        (GOOD.replace("0.5,1", "-1,1"), r"time 't' goes backwards \(at data row 2\)"),
        (GOOD.replace("1,2,2,2,2", "0.25,2,2,2,2"), r"goes backwards \(at data row 3\)"),
        ("t,q_a,q_b,i_a,i_b\n0,0,0,0,0\n0,1,1,1,1\n", r"time 't' never advances"),
        (GOOD.replace("0.5,1,1,1,1", "0.5,x,1,1,1"), r"column 'q_a' is not numeric"),
        ("t,q_a,q_b,i_a,i_b\n0,0,0,0,0\n", r"log needs at least two samples"),
        ("t,q_a,q_b,i_a,i_b\n", r"table has no rows"),
        ("", r"file is empty"),
        (GOOD + "1.5,3,3", r"cannot parse table, truncated or malformed"),
    ],
)
def test_bad_csv_log(tmp_path: Path, text: str, message: str) -> None:
    p = _write_csv(tmp_path, text)
    with pytest.raises(InputError, match=message) as info:
        read_log(p, ROBOT)
    assert str(info.value).startswith(f"{p}: ")  # names the file


def test_a_bad_cell_deep_in_a_csv_column_is_named_not_the_first(tmp_path: Path) -> None:
    # one word among numbers: the CSV reader types the whole column as text, and the message
    # named data row 1 and its (good) number; it must name the cell that is not a number
    rows = [f"{k},{k},{0.25 * k}" for k in range(8)]
    rows[5] = "5,5,abc"
    p = tmp_path / "d.csv"
    p.write_text("position,pulse_width,torque\n" + "\n".join(rows) + "\n")
    with pytest.raises(InputError, match=r"'torque' is not numeric \(data row 6: 'abc'\)"):
        numeric_column(read_table(p), "torque", p)


def test_csv_cut_mid_line(tmp_path: Path) -> None:
    source = tmp_path / "full.csv"
    write_table(source, _columns(200))
    data = source.read_bytes()
    p = tmp_path / "cut.csv"
    p.write_bytes(data[: data.rindex(b"\n", 0, len(data) - 1) + 12])  # a last line of 12 chars
    with pytest.raises(InputError, match=r"cut\.csv: cannot parse table, truncated or malformed"):
        read_log(p, ROBOT)


def test_parquet_cut(tmp_path: Path) -> None:
    source = tmp_path / "full.parquet"
    write_table(source, _columns(200))
    data = source.read_bytes()
    p = tmp_path / "cut.parquet"
    p.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match=r"cut\.parquet: cannot parse table"):
        read_log(p, ROBOT)


def test_missing_file_and_unknown_format(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"none\.csv: file not found"):
        read_table(tmp_path / "none.csv")
    with pytest.raises(InputError, match=r"log\.txt: unknown table format"):
        read_table(tmp_path / "log.txt")
    with pytest.raises(InputError, match=r"unknown table format"):
        write_table(tmp_path / "out.xlsx", {"t": [0.0]})


def test_failed_write_leaves_nothing(tmp_path: Path) -> None:
    target = tmp_path / "out.csv"
    with pytest.raises(ValueError):
        write_table(target, {"t": np.arange(3.0), "q_a": np.arange(4.0)})  # unequal lengths
    assert list(tmp_path.iterdir()) == []
    target.write_text("old")
    with pytest.raises(RuntimeError), atomic_output(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("interrupted")
    assert target.read_text() == "old"  # untouched, and no temporary file left beside it
    assert list(tmp_path.iterdir()) == [target]


def test_output_folder_must_exist(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="output folder does not exist"):
        write_table(tmp_path / "no" / "out.csv", {"t": [0.0, 1.0]})


def test_write_toml_round_trip(tmp_path: Path) -> None:
    doc = {"robot": {"name": "x", "link_lengths": [0.1, 0.2]}, "n": {"k": 1.5e-7}}
    write_toml(tmp_path / "x.toml", doc)
    assert read_toml(tmp_path / "x.toml") == doc
