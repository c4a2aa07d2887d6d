"""Issue 15 item 7: every input that raised a traceback is now one clear line, exit 2.

Each case was reproduced as a traceback first (the issue's probe list); the inputs are tiny and
written here. Refusals come from the readers (read_table, numeric_column, the log and TOML
readers, the motor file) or the CLI's argument types, so they happen before any work.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from torquemap.cli.main import main
from torquemap.errors import InputError
from torquemap.io import read_log, read_table, write_table, write_toml
from torquemap.linearize.motor import load_motor
from torquemap.robot import robot_from_dict
from torquemap.tomlfile import read_toml

ROBOT = {
    "robot": {"name": "r", "kinematics": "planar2r", "link_lengths": [0.25, 0.2]},
    "joints": {
        "a": {"gear_ratio": 100.0, "torque_constant": 0.11, "encoder_counts_per_rev": 8000},
        "b": {"gear_ratio": 80.0, "torque_constant": 0.08, "encoder_counts_per_rev": 8000},
    },
}
MOTOR = {
    "motor": {
        "name": "m",
        "phases": 3,
        "positions_per_cycle": 48,
        "equilibrium_positions": [8, 24, 40],
        "ramping": "wide",
    }
}


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    try:
        status = main(argv)
    except SystemExit as exc:
        status = int(exc.code or 0)
    return status, capsys.readouterr().err


def assert_one_line(status: int, err: str, match: str) -> None:
    assert status == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert match in err, err


def log_columns(n: int = 50) -> dict[str, np.ndarray]:
    t = np.arange(n) * 0.001
    return {
        "t": t,
        "q_a": 0.1 * np.sin(t),
        "q_b": 0.6 + 0.1 * np.cos(t),
        "i_a": np.full(n, 0.2),
        "i_b": np.full(n, -0.1),
    }


@pytest.fixture
def robot_file(tmp_path: Path) -> Path:
    write_toml(tmp_path / "robot.toml", ROBOT)
    return tmp_path / "robot.toml"


def estimate(robot: Path, log: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    return run(["estimate", str(robot), str(log), "-o", str(log.parent / "f.csv")], capsys)


def test_duplicate_column_names(
    robot_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "dup.csv"
    log.write_text("t,q_a,q_b,i_a,i_a\n0,0,0.6,1,2\n0.001,0,0.6,1,2\n")
    status, err = estimate(robot_file, log, capsys)
    assert_one_line(status, err, "column name 'i_a' appears more than once")


def test_latin1_header(
    robot_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "latin1.csv"
    log.write_bytes(b"t,q_a,q_b,i_a,i_b,\xe9\n0,0,0.6,1,2,3\n0.001,0,0.6,1,2,3\n")
    status, err = estimate(robot_file, log, capsys)
    assert_one_line(status, err, "not UTF-8 text (byte 0xe9")


def test_latin1_cell(robot_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "latin1.csv"
    log.write_bytes(b"t,q_a,q_b,i_a,i_b\n0,0,0.6,1,2\n0.001,0,0.6,\xe9,2\n")
    status, err = estimate(robot_file, log, capsys)
    assert_one_line(status, err, "column 'i_a' is not UTF-8 text (data row 2)")


def test_absurd_angle(robot_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cols = log_columns()
    cols["q_a"][20] = 1e29  # was a LinAlgError (singular Jacobian) deep in the estimate
    write_table(tmp_path / "q.csv", cols)
    status, err = estimate(robot_file, tmp_path / "q.csv", capsys)
    assert_one_line(status, err, "column 'q_a' value 1e+29 rad at data row 21 is beyond +-1e+09")


def test_absurd_time(robot_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cols = log_columns()
    cols["t"] = cols["t"] * 1e300
    write_table(tmp_path / "t.csv", cols)
    status, err = estimate(robot_file, tmp_path / "t.csv", capsys)
    assert_one_line(status, err, "column 't' value")


def test_uint64_counts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    doc = {
        **ROBOT,
        "joints": {k: {**v, "position_unit": "counts"} for k, v in ROBOT["joints"].items()},
    }
    write_toml(tmp_path / "robot.toml", doc)
    cols: dict[str, np.ndarray] = log_columns()
    n = cols["t"].size
    cols["q_a"] = np.arange(n, dtype=np.uint64) + np.uint64(2**63)
    cols["q_b"] = np.zeros(n, dtype=np.uint64)
    pq.write_table(pa.table(cols), tmp_path / "u.parquet")
    status, err = estimate(tmp_path / "robot.toml", tmp_path / "u.parquet", capsys)
    assert_one_line(status, err, "column 'q_a' value 9.22337e+18 counts at data row 1 is beyond")
    robot = robot_from_dict(doc)
    cols["q_a"] = np.arange(n, dtype=np.uint64) * np.uint64(3000) + np.uint64(2**52)  # too far
    pq.write_table(pa.table(cols), tmp_path / "far.parquet")
    with pytest.raises(InputError, match=r"unwraps to 3.53712e\+10 rad at data row 1, beyond"):
        read_log(tmp_path / "far.parquet", robot)


@pytest.mark.parametrize("dtype", ["bool", "string", "timestamp"])
def test_non_numeric_parquet_column(
    dtype: str, robot_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cols: dict[str, object] = dict(log_columns())
    n = 50
    if dtype == "bool":
        cols["i_a"] = np.zeros(n, dtype=bool)
    elif dtype == "string":
        cols["i_a"] = ["1.5"] * n
    else:
        cols["i_a"] = pa.array(np.arange(n).astype("datetime64[s]"))
    pq.write_table(pa.table(cols), tmp_path / "x.parquet")
    status, err = estimate(robot_file, tmp_path / "x.parquet", capsys)
    want = "holds booleans, not numbers" if dtype == "bool" else "column 'i_a' is not numeric"
    assert_one_line(status, err, want)


def test_mixed_object_column_is_refused(tmp_path: Path) -> None:
    from torquemap.io import numeric_column

    with pytest.raises(InputError, match=r"not numeric \(data row 2: True\)"):
        numeric_column({"x": np.array([1.0, True], dtype=object)}, "x", "f")
    assert numeric_column({"x": np.array([1, 2.5], dtype=object)}, "x", "f").tolist() == [1, 2.5]


@pytest.mark.parametrize("bits", ["0", "33", "64", "-3", "x"])
def test_actuation_bits(bits: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["linearize", "build", "m.toml", "d.csv", "-o", str(tmp_path / "t.npz")]
    status, err = run([*argv, "--actuation-bits", bits], capsys)
    assert status == 2 and err.strip().splitlines()[-1].startswith("torquemap linearize build:")
    assert "--actuation-bits" in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("option", "value", "match"),
    [
        ("--max-order", "-5", "must be a number in (0, 1e+06]"),
        ("--max-order", "nan", "must be a number in (0, 1e+06]"),
        ("--max-order", "1e300", "must be a number in (0, 1e+06]"),
    ],
)
def test_identify_options(
    option: str, value: str, match: str, capsys: pytest.CaptureFixture[str]
) -> None:
    status, err = run(["identify", "r.toml", "l.csv", "-o", "m.toml", option, value], capsys)
    assert status == 2 and match in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["pdtv-map", "m.toml", "--joint", "a", "--bins", "1000000000", "-o", "m.csv"],
         "must be in 2 .. 1048576"),
        (["pdtv-map", "m.toml", "--joint", "a", "--bins", "1", "-o", "m.csv"],
         "must be in 2 .. 1048576"),
        (["estimate", "m.toml", "l.csv", "-o", "f.csv", "--notch-width", "nan"],
         "must be a number in (0, inf)"),
        (["linearize", "build", "m.toml", "d.csv", "-o", "t.npz", "--log-curvature", "inf"],
         "must be a number in (0, 100]"),
        (["simulate", "rig", "--motor", "vr", "--out", "d", "--readings", "1000000000"],
         "readings must be at most 100000"),
    ],
)  # fmt: skip
def test_sizes_are_bounded(argv: list[str], match: str, capsys: pytest.CaptureFixture[str]) -> None:
    status, err = run(argv, capsys)
    assert status == 2 and match in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"positions_per_cycle": 4_000_000_000}, "positions_per_cycle must be at most 65536"),
        ({"phases": 1000, "equilibrium_positions": [0] * 1000}, "phases must be at most 64"),
        ({"command_bits": 16, "positions_per_cycle": 4096}, "table entries per phase"),
        ({"actuation_max": 2**40}, "actuation_max must be at most 4294967295"),
    ],
)
def test_motor_sizes(change: dict[str, object], match: str, tmp_path: Path) -> None:
    write_toml(tmp_path / "motor.toml", {"motor": {**MOTOR["motor"], **change}})
    with pytest.raises(InputError, match=match):
        load_motor(tmp_path / "motor.toml")


@pytest.mark.parametrize("nest", ["[", "{x="])
def test_toml_nested_100000_deep(
    nest: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    close = "]" if nest == "[" else "}"
    deep = tmp_path / "motor.toml"
    deep.write_text("a = " + nest * 100_000 + ("1" if nest != "[" else "") + close * 100_000)
    with pytest.raises(InputError, match="nested too deeply"):
        read_toml(deep)
    argv = ["linearize", "build", str(deep), "d.csv", "-o", str(tmp_path / "t.npz")]
    status, err = run(argv, capsys)
    assert_one_line(status, err, "not valid TOML (nested too deeply)")


def test_toml_not_utf8(tmp_path: Path) -> None:
    f = tmp_path / "m.toml"
    f.write_bytes(b'[motor]\nname = "\xe9"\n')
    with pytest.raises(InputError, match="not UTF-8 text"):
        read_toml(f)


def test_csv_header_injection_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="cannot be written to a CSV header"):
        write_table(tmp_path / "x.csv", {"a,b": [1.0]})
    assert list(tmp_path.iterdir()) == []
    write_table(tmp_path / "x.parquet", {"a,b": [1.0]})  # Parquet holds any name
    assert list(read_table(tmp_path / "x.parquet")) == ["a,b"]


@pytest.mark.parametrize("name", ["a\nb", "a\x1eb", "a\u2028b", "a\rb"])
def test_errors_naming_user_text_stay_one_line(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_toml(tmp_path / "robot.toml", {**ROBOT, "joints": {**ROBOT["joints"], name: 0}})
    argv = ["identify", str(tmp_path / "robot.toml"), "l.csv", "-o", str(tmp_path / "m.toml")]
    status, err = run(argv, capsys)
    assert status == 2 and len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert "] must be a table" in err


@pytest.mark.parametrize("value", [1e300, -1e16, 1.7e308])
def test_absurd_current(
    value: float, robot_file: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cols = log_columns()
    cols["i_b"][7] = value  # squared it overflowed float64 deep in identify and estimate
    write_table(tmp_path / "i.csv", cols)
    status, err = estimate(robot_file, tmp_path / "i.csv", capsys)
    assert_one_line(
        status, err, f"column 'i_b' value {value:.6g} A at data row 8 is beyond +-1e+15 A"
    )


def test_robot_and_model_toml_nested_100000_deep(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    deep = tmp_path / "robot.toml"
    deep.write_text("a = " + "[" * 100_000 + "]" * 100_000)
    for argv in (
        ["identify", str(deep), "l.csv", "-o", str(tmp_path / "m.toml")],
        ["estimate", str(deep), "l.csv", "-o", str(tmp_path / "f.csv")],
    ):
        status, err = run(argv, capsys)
        assert_one_line(status, err, "not valid TOML (nested too deeply)")


def _true_model_and_log(tmp_path: Path) -> tuple[dict[str, Any], Path]:
    from torquemap.sim.bench import truth_document
    from torquemap.sim.scara import default_bench

    n = 1000
    t = np.arange(n) / 500.0
    phase = (t / 1.7) % 1.0
    qa = 0.4 * (4.0 * np.abs(phase - 0.5) - 1.0)
    cols = {"t": t, "q_a": qa, "q_b": 0.8 + 0.5 * qa, "i_a": 0.4 * np.sign(np.gradient(qa))}
    cols["i_b"] = 0.5 * cols["i_a"]
    write_table(tmp_path / "log.csv", cols)
    return truth_document(default_bench(), seed=0), tmp_path / "log.csv"


def test_model_friction_that_is_not_a_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    doc, log = _true_model_and_log(tmp_path)
    doc["joints"]["b"]["friction"] = True
    write_toml(tmp_path / "model.toml", doc)
    status, err = estimate(tmp_path / "model.toml", log, capsys)
    assert status == 2 and err.count("\n") == 1 and "friction" in err, err


def test_robot_link_length_1e_320(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    doc, log = _true_model_and_log(tmp_path)
    doc["robot"]["link_lengths"] = [1e-320, 0.2]
    write_toml(tmp_path / "model.toml", doc)
    status, err = estimate(tmp_path / "model.toml", log, capsys)
    assert status == 2 and err.count("\n") == 1 and "link_lengths" in err, err


def test_toml_with_a_byte_order_mark_is_read(tmp_path: Path) -> None:
    # Windows editors (Notepad) start UTF-8 files with one; tomllib alone refuses it
    plain, marked = tmp_path / "r.toml", tmp_path / "bom.toml"
    write_toml(plain, ROBOT)
    marked.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    assert read_toml(marked) == read_toml(plain)


@pytest.mark.parametrize(("value", "shown"), [("-1.0", "-1.0"), ("'abc'", "'abc'"), ("nan", "nan")])
def test_model_differentiation_window_is_checked(
    value: str, shown: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # estimate, spectrum and report default to it: once skipped silently (0.05 s used instead)
    write_toml(tmp_path / "m.toml", ROBOT)
    model = tmp_path / "m.toml"
    model.write_text(model.read_text() + f"\n[identification]\ndifferentiation_window = {value}\n")
    write_table(tmp_path / "log.csv", log_columns())
    status, err = estimate(model, tmp_path / "log.csv", capsys)
    assert_one_line(
        status,
        err,
        f"m.toml: [identification] differentiation_window must be a number in (0, 10] s, got {shown}",
    )
    assert not (tmp_path / "f.csv").exists()


def test_a_joint_without_a_name_is_refused(tmp_path: Path) -> None:
    doc = {**ROBOT, "joints": {"": ROBOT["joints"]["a"], "b": ROBOT["joints"]["b"]}}
    with pytest.raises(InputError, match=r"\[joints\.''\] a joint needs a name"):
        robot_from_dict(doc, path="r.toml")
