"""The robot file: round trip and every bad-input path (InputError naming problem and file)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import tomli_w

from torquemap.errors import InputError
from torquemap.robot import Joint, Robot, load_robot, robot_from_dict, robot_to_dict


def _doc() -> dict[str, Any]:
    return {
        "robot": {"name": "arm", "kinematics": "planar2r", "link_lengths": [0.25, 0.2]},
        "joints": {
            "a": {"gear_ratio": 100, "torque_constant": 0.11, "encoder_counts_per_rev": 8000},
            "b": {
                "gear_ratio": 80.0,
                "torque_constant": 0.08,
                "encoder_counts_per_rev": 8000,
                "position_unit": "counts",
            },
        },
    }


def _write(tmp_path: Path, doc: dict[str, Any]) -> Path:
    p = tmp_path / "robot.toml"
    p.write_text(tomli_w.dumps(doc))
    return p


def test_round_trip_through_toml(tmp_path: Path) -> None:
    robot = Robot(
        name="arm",
        kinematics="planar2r",
        link_lengths=(0.25, 0.2),
        joints=(
            Joint("a", 100.0, 0.11, 8000),
            Joint("b", 80.0, 0.08, 4096, "counts"),
        ),
    )
    back = load_robot(_write(tmp_path, robot_to_dict(robot)))
    assert back.name == robot.name
    assert back.kinematics == robot.kinematics
    assert back.link_lengths == robot.link_lengths
    for j, k in zip(back.joints, robot.joints, strict=True):
        assert (j.name, j.gear_ratio, j.torque_constant) == (
            k.name,
            k.gear_ratio,
            k.torque_constant,
        )
        assert (j.encoder_counts_per_rev, j.position_unit) == (
            k.encoder_counts_per_rev,
            k.position_unit,
        )


def test_joint_order_is_file_order(tmp_path: Path) -> None:
    robot = load_robot(_write(tmp_path, _doc()))
    assert robot.joint_names == ("a", "b")
    assert robot.joint("b").position_unit == "counts"
    assert robot.joint("a").gear_ratio == 100.0


def test_unknown_joint_names_the_known_ones(tmp_path: Path) -> None:
    robot = load_robot(_write(tmp_path, _doc()))
    with pytest.raises(InputError, match=r"unknown joint 'z'; the robot has a, b"):
        robot.joint("z")


def test_no_kinematics_robot() -> None:
    doc = {"robot": {"name": "m"}, "joints": {"m": {"gear_ratio": 1, "torque_constant": 1}}}
    robot = robot_from_dict(doc)
    assert robot.kinematics == "none" and robot.link_lengths == ()


def _edit(path: tuple[str, ...], value: Any) -> dict[str, Any]:
    doc = _doc()
    node = doc
    for key in path[:-1]:
        node = node[key]
    if value is _DELETE:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return doc


_DELETE = object()


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        (("robot",), _DELETE, r"missing table \[robot\]"),
        (("joints",), _DELETE, r"missing \[joints.<name>\] tables"),
        (("extra",), {"x": 1}, r"unknown key 'extra' in the file"),
        (("robot", "colour"), "red", r"unknown key 'colour' in \[robot\]"),
        (("joints", "a", "gear"), 3, r"unknown key 'gear' in \[joints.a\]"),
        (("robot", "kinematics"), "scara", r"kinematics must be one of 'none', 'planar2r'"),
        (("robot", "link_lengths"), [0.25], r"link_lengths must be \[l1, l2\]"),
        (("robot", "link_lengths"), [0.25, -0.2], r"link_lengths must be positive"),
        (("joints", "a", "gear_ratio"), _DELETE, r"\[joints.a\] is missing gear_ratio"),
        (("joints", "a", "torque_constant"), 0, r"torque_constant must be positive"),
        (
            ("joints", "a", "gear_ratio"),
            -100,
            r"gear_ratio must be positive and finite, got -100: for a motor that turns against "
            r"its joint, give the magnitude and negate the joint's current",
        ),
        (("joints", "a", "gear_ratio"), "100", r"gear_ratio must be a number"),
        (
            ("joints", "a", "encoder_counts_per_rev"),
            0.5,
            r"encoder_counts_per_rev must be an integer in 0\.\.4294967296",
        ),
        (
            ("joints", "a", "position_unit"),
            "deg",
            r"position_unit must be one of rad, counts, turns",
        ),
        (
            ("joints", "b", "encoder_counts_per_rev"),
            _DELETE,
            r"position_unit = 'counts' needs encoder_counts_per_rev",
        ),
        (("joints", "b"), _DELETE, r"planar2r needs exactly 2 joints"),
    ],
)
def test_bad_robot_file(tmp_path: Path, path: tuple[str, ...], value: Any, message: str) -> None:
    p = _write(tmp_path, _edit(path, value))
    with pytest.raises(InputError, match=message) as info:
        load_robot(p)
    assert str(info.value).startswith(str(p))  # the message names the file


def test_link_lengths_only_for_planar2r(tmp_path: Path) -> None:
    doc = _edit(("robot", "kinematics"), "none")
    with pytest.raises(InputError, match="link_lengths is only for kinematics = 'planar2r'"):
        load_robot(_write(tmp_path, doc))


@pytest.mark.parametrize(
    ("text", "message"),
    [("", "file is empty"), ("  \n", "file is empty"), ("[robot\nname=", "not valid TOML")],
)
def test_empty_and_malformed_files(tmp_path: Path, text: str, message: str) -> None:
    p = tmp_path / "robot.toml"
    p.write_text(text)
    with pytest.raises(InputError, match=message) as info:
        load_robot(p)
    assert "robot.toml" in str(info.value)


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"nothere.toml: file not found"):
        load_robot(tmp_path / "nothere.toml")


def test_truncated_file(tmp_path: Path) -> None:
    text = tomli_w.dumps(_doc())
    p = tmp_path / "robot.toml"
    p.write_text(text[: text.index("torque_constant") + 8])  # cut mid-key
    with pytest.raises(InputError, match=r"robot\.toml: not valid TOML"):
        load_robot(p)
