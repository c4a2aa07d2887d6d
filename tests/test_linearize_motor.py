"""MOTOR.toml and the ramping functions (torquemap.linearize.motor)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose, assert_array_equal

from torquemap.errors import InputError
from torquemap.io import write_table, write_toml
from torquemap.linearize.motor import (
    command_range,
    load_motor,
    motor_spec,
    motor_to_dict,
    ramp_function,
    ramped_actuation,
    read_ramp_csv,
)


@settings(max_examples=60, deadline=None)
@given(
    kind=st.sampled_from(["narrow", "wide"]),
    phases=st.integers(1, 6),
    extra=st.integers(0, 600),
)
def test_ramp_in_unit_interval_and_covers_every_position(
    kind: str, phases: int, extra: int
) -> None:
    n = 2 * phases + extra
    r = ramp_function(kind, phases=phases, positions_per_cycle=n)  # type: ignore[arg-type]
    assert r.shape == (n, phases)
    assert r.min() >= 0.0 and r.max() <= 1.0
    # every position energises some phase, at least one fully when not in a narrow transition
    assert (r.max(axis=1) >= 0.5 - 1e-12).all()


def _plateau_and_ramp(r: np.ndarray) -> tuple[int, int]:
    return int((r == 1.0).sum()), int(((r > 0) & (r < 1)).sum())


def test_narrow_breakpoints_as_documented() -> None:
    # P = 600, m = 3: W = 200, plateau W/2 = 100 wide, ramps W/2 = 100 long, on each side.
    r = ramp_function("narrow", phases=3, positions_per_cycle=600)
    plateau, ramps = _plateau_and_ramp(r[:, 0])
    # closed interval of length 100 holds 101 integers; two open ramps of length 100 hold 99 each
    assert plateau == 101 and ramps == 198
    assert_allclose(r.sum(axis=1), 1.0, atol=1e-12)  # complementary ramps: exact by construction
    # phase 1 plateau centred on its third's centre W/2 = 100
    assert_array_equal(np.flatnonzero(r[:, 0] == 1.0)[[0, -1]], [50, 150])
    # transition regions centred on 0, W, 2W: both neighbours at 0.5 there
    assert_allclose(r[200, :2], [0.5, 0.5], atol=1e-12)


def test_wide_breakpoints_as_documented() -> None:
    # P = 600, m = 3: W = 200; plateau 7W/6 = 233.3, ramps W/12 = 16.7; support 4W/3 = 266.7.
    r = ramp_function("wide", phases=3, positions_per_cycle=600)
    plateau, ramps = _plateau_and_ramp(r[:, 0])
    # plateau [-16.7, 216.7] holds 233 integers; each ramp (216.7, 233.3) holds 17
    assert plateau == 233 and ramps == 2 * 17
    both_on = ((r[:, 0] == 1.0) & (r[:, 1] == 1.0)).sum()
    assert both_on == 33  # the middle W/6 = 33.3 of the transition region
    assert r.sum(axis=1).max() == 2.0
    narrow = ramp_function("narrow", phases=3, positions_per_cycle=600)
    assert (r == 1.0).sum() > 2 * (narrow == 1.0).sum()


def test_phase_sequence_is_positive_direction() -> None:
    r = ramp_function("wide", phases=4, positions_per_cycle=512)
    centres = [np.flatnonzero(r[:, k] == 1.0).mean() for k in range(1, 4)]
    assert centres == sorted(centres)


def test_single_phase_motor_is_always_on() -> None:
    assert_array_equal(ramp_function("narrow", phases=1, positions_per_cycle=8), np.ones((8, 1)))


def test_ramp_function_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match="ramping must be"):
        ramp_function("round", phases=3, positions_per_cycle=12)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="phases must be"):
        ramp_function("wide", phases=0, positions_per_cycle=12)
    with pytest.raises(ValueError, match="positions_per_cycle"):
        ramp_function("wide", phases=3, positions_per_cycle=5)


def test_ramped_actuation_matches_elementwise_rounding() -> None:
    r = ramp_function("narrow", phases=3, positions_per_cycle=512)
    rng = np.random.default_rng(3)
    pw = rng.integers(0, 256, 50)
    pos = rng.integers(0, 512, 50)
    got = ramped_actuation(pw, pos, r)
    expected = [[round(float(w) * r[p, k]) for k in range(3)] for w, p in zip(pw, pos, strict=True)]
    assert got.dtype == np.int64 and got.shape == (50, 3)
    # Python's round and numpy's rint both round half to even
    assert_array_equal(got, expected)
    assert_array_equal(ramped_actuation(10, 512 + 7, r), ramped_actuation(10, 7, r))


def test_motor_file_round_trip(tmp_path: Path) -> None:
    spec = motor_spec("vr", phases=3, positions_per_cycle=512, equilibrium_positions=(213, 387, 41))
    write_toml(tmp_path / "motor.toml", motor_to_dict(spec))
    back = load_motor(tmp_path / "motor.toml")
    for field in ("name", "phases", "positions_per_cycle", "command_bits", "actuation_max"):
        assert getattr(back, field) == getattr(spec, field)
    assert back.equilibrium_positions == (213, 387, 41)
    assert back.ramping == "wide" and back.path == str(tmp_path / "motor.toml")
    assert_array_equal(back.ramp, spec.ramp)
    assert command_range(back) == 127


def _ramp_columns(r: np.ndarray) -> dict[str, np.ndarray]:
    return {f"phase_{k + 1}": r[:, k] for k in range(r.shape[1])}


def test_ramp_csv_relative_to_motor_file(tmp_path: Path) -> None:
    (tmp_path / "ramps").mkdir()
    r = ramp_function("narrow", phases=3, positions_per_cycle=24)
    write_table(tmp_path / "ramps" / "mine.csv", _ramp_columns(r))
    doc = motor_to_dict(
        motor_spec("m", phases=3, positions_per_cycle=24, equilibrium_positions=(1, 2, 3))
    )
    doc["motor"]["ramping"] = "ramps/mine.csv"
    write_toml(tmp_path / "motor.toml", doc)
    spec = load_motor(tmp_path / "motor.toml")
    assert spec.ramping == "ramps/mine.csv"
    assert_allclose(spec.ramp, r, rtol=0, atol=1e-15)  # CSV round trip of doubles
    assert motor_to_dict(spec)["motor"]["ramping"] == "ramps/mine.csv"


def test_ramp_csv_position_column_orders_rows(tmp_path: Path) -> None:
    r = ramp_function("wide", phases=2, positions_per_cycle=8)
    order = np.array([3, 0, 7, 1, 2, 6, 5, 4])
    cols = {"position": order, **_ramp_columns(r[order])}
    write_table(tmp_path / "r.csv", cols)
    assert_array_equal(read_ramp_csv(tmp_path / "r.csv", phases=2, positions_per_cycle=8), r)


@pytest.mark.parametrize(
    ("columns", "match"),
    [
        ({"phase_1": [0.5] * 7, "phase_2": [0.5] * 7}, "7 rows, expected one per table position"),
        (
            {"phase_1": [0.5] * 8, "phase_2": [0.5] * 7 + [1.5]},
            r"1.5 in phase_2 .*outside \[0, 1\]",
        ),
        ({"phase_1": [0.5] * 8, "phase_2": [0.5] * 7 + [-0.1]}, "outside"),
        ({"phase_1": [0.5] * 8}, "missing column 'phase_2'"),
        ({"phase_1": [0.5] * 8, "phase_2": [0.5] * 8, "phase_3": [0] * 8}, "unknown ramp column"),
        (
            {"position": [0, 1, 2, 3, 4, 5, 6, 6], "phase_1": [0.5] * 8, "phase_2": [0.5] * 8},
            "must hold each of 0 .. 7 once",
        ),
    ],
)
def test_ramp_csv_errors(tmp_path: Path, columns: dict[str, list[float]], match: str) -> None:
    write_table(tmp_path / "r.csv", {k: np.asarray(v) for k, v in columns.items()})
    with pytest.raises(InputError, match=match):
        read_ramp_csv(tmp_path / "r.csv", phases=2, positions_per_cycle=8)


_GOOD = {
    "name": "m",
    "phases": 3,
    "positions_per_cycle": 24,
    "command_bits": 8,
    "actuation_max": 255,
    "equilibrium_positions": [1, 2, 3],
    "ramping": "narrow",
}


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"colour": "red"}, "unknown key 'colour' in \\[motor\\]"),
        ({"name": None}, "missing name"),
        ({"phases": None}, "missing phases"),
        ({"positions_per_cycle": None}, "missing positions_per_cycle"),
        ({"equilibrium_positions": None}, "missing equilibrium_positions"),
        ({"ramping": None}, "missing ramping"),
        ({"name": ""}, "name must be a non-empty string"),
        ({"phases": 0}, "phases must be >= 1"),
        ({"phases": 2.5}, "phases must be an integer"),
        ({"phases": True}, "phases must be an integer"),
        ({"positions_per_cycle": 5}, "positions_per_cycle must be >= 6"),
        ({"command_bits": 1}, "command_bits must be in 2 .. 16"),
        ({"actuation_max": 0}, "actuation_max must be >= 1"),
        ({"equilibrium_positions": [1, 2]}, "list of 3 integers"),
        ({"equilibrium_positions": [1, 2, 24]}, r"equilibrium_positions\[2\] must be in 0 .. 23"),
        ({"equilibrium_positions": [1, 2, "3"]}, r"equilibrium_positions\[2\] must be an integer"),
        (
            {"equilibrium_positions": [5, 2, 5]},
            "equilibrium_positions: phases 1 and 3 are both at table position 5",
        ),
        ({"ramping": 3}, "ramping must be 'narrow', 'wide' or a CSV path"),
        ({"ramping": "nothere.csv"}, "ramping file 'nothere.csv' not found"),
    ],
)
def test_motor_file_errors_name_key_and_file(
    tmp_path: Path, change: dict[str, object], match: str
) -> None:
    motor = {k: v for k, v in {**_GOOD, **change}.items() if v is not None}
    write_toml(tmp_path / "motor.toml", {"motor": motor})
    with pytest.raises(InputError, match=match) as info:
        load_motor(tmp_path / "motor.toml")
    assert str(info.value).startswith(str(tmp_path / "motor.toml"))


def test_motor_file_structure_errors(tmp_path: Path) -> None:
    p = tmp_path / "motor.toml"
    write_toml(p, {"motor": _GOOD, "extra": {"a": 1}})
    with pytest.raises(InputError, match="unknown key 'extra'"):
        load_motor(p)
    write_toml(p, {"other": {"a": 1}})
    with pytest.raises(InputError, match="unknown key 'other'"):
        load_motor(p)
    write_toml(p, {})
    with pytest.raises(InputError, match="empty"):
        load_motor(p)
    p.write_text('motor = "x"\n')
    with pytest.raises(InputError, match=r"\[motor\] must be a table"):
        load_motor(p)
    p.write_text("[motor\n")
    with pytest.raises(InputError, match="not valid TOML"):
        load_motor(p)
    with pytest.raises(InputError, match="file not found"):
        load_motor(tmp_path / "missing.toml")
