"""pdtv_map: table against the closed form of the lines, exports and their scales."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.io import read_table
from torquemap.model import JointModel, Model, PdtvLine
from torquemap.pdtv_map import pdtv_map, quantise, write_pdtv_map
from torquemap.robot import robot_from_dict

RB = robot_from_dict(
    {"robot": {"kinematics": "none"}, "joints": {"m": {"gear_ratio": 1, "torque_constant": 0.5}}}
)
LINES = (
    PdtvLine(order=3, amplitude=0.2, phase=0.5),
    PdtvLine(order=5, amplitude=0.1, phase=0.0, direction="positive"),
    PdtvLine(order=5, amplitude=0.3, phase=0.0, direction="negative"),
)
MODEL = Model(robot=RB, joints={"m": JointModel(pdtv=LINES)})


def test_map_is_the_closed_form_at_bin_centres() -> None:
    table = pdtv_map(MODEL, "m", bins=360)
    theta = (np.arange(360) + 0.5) * 2 * np.pi / 360
    expected = 0.2 * np.cos(3 * theta + 0.5) + 0.5 * (0.1 + 0.3) * np.cos(5 * theta)
    assert_allclose(table.motor_angle, theta)
    assert_allclose(table.torque, expected, atol=1e-12)  # same formula evaluated twice
    assert_allclose(table.current, expected / 0.5, atol=1e-12)
    up = pdtv_map(MODEL, "m", bins=360, direction="positive")
    assert_allclose(up.torque, 0.2 * np.cos(3 * theta + 0.5) + 0.1 * np.cos(5 * theta), atol=1e-12)
    with pytest.raises(InputError, match="unknown joint"):
        pdtv_map(MODEL, "x")
    with pytest.raises(InputError, match="at least 2"):
        pdtv_map(MODEL, "m", bins=1)


@pytest.mark.parametrize("int_type,full", [("int16", 32767), ("int8", 127)])
def test_quantised_table_uses_full_range(int_type: str, full: int) -> None:
    v = np.array([0.25, -1.5, 0.75])
    q, scale = quantise(v, int_type=int_type)  # type: ignore[arg-type]
    assert int(np.abs(q).max()) == full
    assert_allclose(q * scale, v, atol=scale / 2)  # rounding to the nearest count


def test_exports(tmp_path: Path) -> None:
    table = pdtv_map(MODEL, "m", bins=64)
    write_pdtv_map(tmp_path / "m.json", table, file_format="json")
    doc = json.loads((tmp_path / "m.json").read_text())
    assert doc["bins"] == 64 and doc["units"]["current"] == "A"
    assert_allclose(doc["current"], table.current)
    write_pdtv_map(tmp_path / "m.h", table, file_format="c-header", int_type="int8")
    text = (tmp_path / "m.h").read_text()
    scale = float(re.search(r"PDTV_M_SCALE_A ([0-9.e+-]+)f", text).group(1))  # type: ignore[union-attr]
    body = text.split("{", 1)[1].split("}", 1)[0]
    counts = np.array([int(x) for x in body.replace("\n", " ").split(",")])
    assert counts.size == 64 and np.abs(counts).max() == 127
    assert_allclose(counts * scale, table.current, atol=scale)
    write_pdtv_map(tmp_path / "m.csv", table)
    cols = read_table(tmp_path / "m.csv")
    assert list(cols) == ["motor_angle", "torque", "current"]
    assert_allclose(cols["current"], table.current)


def test_too_few_bins_for_a_line_is_warned(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a 12-slot 14-pole motor's 84 CPR line in 128 bins: the staircase of bin-centre values
    # carries a 128 - 84 = 44 CPR ripple of the line's own size (its DFT, computed here
    # independently), which the motor does not have; before: written silently, exit 0
    from torquemap.cli.main import main
    from torquemap.model import save_model

    model = Model(robot=RB, joints={"m": JointModel(pdtv=(PdtvLine(84, 0.01, 0.3),))})
    save_model(tmp_path / "m.toml", model)
    table = pdtv_map(model, "m", bins=128)
    spectrum = np.abs(np.fft.rfft(table.torque)) * 2 / 128
    assert spectrum[44] == pytest.approx(0.01, rel=1e-9)  # all of the line lands at 44 CPR
    out = tmp_path / "m.csv"
    argv = ["pdtv-map", str(tmp_path / "m.toml"), "--joint", "m", "--bins", "128", "-o", str(out)]
    assert main(argv) == 0 and out.exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "m.toml: joint 'm': 128 bins cannot hold" in err[0]
    assert "order 84 CPR" in err[0] and "--bins 169 or more" in err[0]
    argv[5] = "169"
    assert main(argv) == 0 and capsys.readouterr().err == ""


def test_a_line_of_non_integer_order_is_left_out_and_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a 9:1 gearbox's joint-side ripple at 2.25 CPR of the motor: a table over one motor
    # revolution repeats every revolution, so tabulated the line is wrong on the next
    # revolutions (at 2 pi + theta it is off by 2 A |sin(0.25 pi)|, 1.41 A); before: tabulated
    # silently. Out of the bins, the table is the integer line alone (closed form)
    from torquemap.cli.main import main
    from torquemap.model import save_model

    lines = (PdtvLine(7, 0.01, 0.3), PdtvLine(2.25, 0.02, 0.0))
    model = Model(robot=RB, joints={"m": JointModel(pdtv=lines)})
    table = pdtv_map(model, "m", bins=256)
    assert_allclose(table.torque, 0.01 * np.cos(7 * table.motor_angle + 0.3), atol=1e-15)
    # at given angles (an evaluation, not a table) every line counts
    at = pdtv_map(model, "m", motor_angle=[2 * np.pi])
    assert_allclose(at.torque, 0.01 * np.cos(7 * 2 * np.pi + 0.3) + 0.02 * np.cos(4.5 * np.pi))
    save_model(tmp_path / "m.toml", model)
    argv = ["pdtv-map", str(tmp_path / "m.toml"), "--joint", "m", "--bins", "256", "-o"]
    assert main([*argv, str(tmp_path / "m.csv")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"torquemap: warning: {tmp_path / 'm.toml'}: joint 'm': PDTV line(s) of non-integer "
        "order left out of the table: 2.25 CPR (0.02 N m); a table over one motor revolution "
        "repeats every revolution and cannot hold them (joint-side or gearbox ripple?)"
    ]
