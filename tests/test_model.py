"""The model file: TOML round trip, the friction and PDTV laws, and every bad-input path."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.io import write_toml
from torquemap.model import (
    FrictionModel,
    InertiaModel,
    JointModel,
    Model,
    PdtvLine,
    friction_torque,
    inertia_at,
    load_model,
    model_to_dict,
    pdtv_torque,
)
from torquemap.robot import Joint, Robot


def _model() -> Model:
    robot = Robot(
        name="arm",
        kinematics="planar2r",
        link_lengths=(0.25, 0.2),
        joints=(Joint("a", 100.0, 0.11, 8000), Joint("b", 80.0, 0.08)),
    )
    a = JointModel(
        inertia=InertiaModel(constant=1.5e-4, cos_elbow=1e-5),
        friction=FrictionModel(0.045, 0.05, 3e-4, 0.012, 0.01, 1.5, 0.05),
        pdtv=(PdtvLine(2.0, 0.004, -1.1), PdtvLine(21.0, 0.0015, 2.3, "positive")),
    )
    b = JointModel(friction=FrictionModel(coulomb_positive=0.03, coulomb_negative=0.034))
    return Model(robot=robot, joints={"a": a, "b": b}, notes={"logs": ["sweep.csv"], "k": 2})


def test_model_round_trip(tmp_path: Path) -> None:
    model = _model()
    write_toml(tmp_path / "m.toml", model_to_dict(model))
    back = load_model(tmp_path / "m.toml")
    assert back.robot.joint_names == ("a", "b")
    assert dict(back.notes) == {"logs": ["sweep.csv"], "k": 2}
    for name, jm in model.joints.items():
        got = back.joints[name]
        assert (got.inertia.constant, got.inertia.cos_elbow) == (
            jm.inertia.constant,
            jm.inertia.cos_elbow,
        )
        for key in FrictionModel.__dataclass_fields__:
            assert getattr(got.friction, key) == getattr(jm.friction, key)
        assert [(ln.order, ln.amplitude, ln.phase, ln.direction) for ln in got.pdtv] == [
            (ln.order, ln.amplitude, ln.phase, ln.direction) for ln in jm.pdtv
        ]


def test_plain_robot_file_is_a_model(tmp_path: Path) -> None:
    doc = {"robot": {"name": "m"}, "joints": {"m": {"gear_ratio": 1, "torque_constant": 1}}}
    write_toml(tmp_path / "r.toml", doc)
    m = load_model(tmp_path / "r.toml")
    assert m.joints["m"].pdtv == ()
    assert friction_torque([1.0, -1.0], m.joints["m"].friction).tolist() == [0.0, 0.0]


def test_friction_law_by_hand() -> None:
    f = FrictionModel(0.045, 0.05, 3e-4, 0.012, 0.01, 1.5, 0.05)
    w = np.array([2.0, -2.0, 0.0, 0.025])
    s = math.exp(-((2.0 / 1.5) ** 2))
    pos0, neg0 = 0.045 + 0.012, -(0.05 + 0.01)
    s_small = math.exp(-((0.025 / 1.5) ** 2))
    blend = (0.025 + 0.05) / 0.1
    expected = [
        0.045 + 0.012 * s + 3e-4 * 2.0,
        -0.05 - 0.01 * s - 3e-4 * 2.0,
        0.5 * pos0 + 0.5 * neg0,
        blend * (0.045 + 0.012 * s_small) + (1 - blend) * -(0.05 + 0.01 * s_small) + 3e-4 * 0.025,
    ]
    # The law written out by hand: rounding only.
    assert_allclose(friction_torque(w, f), expected, rtol=1e-13)


positive = st.floats(0.0, 1.0)


@settings(max_examples=100, deadline=None)
@given(c=positive, v=st.floats(0.0, 0.1), s=positive, w=st.floats(-100.0, 100.0))
def test_symmetric_friction_is_odd(c: float, v: float, s: float, w: float) -> None:
    f = FrictionModel(c, c, v, s, s, 2.0, 1e-3)
    assert_allclose(friction_torque(-w, f), -friction_torque(w, f), atol=1e-12)


@settings(max_examples=50, deadline=None)
@given(cp=positive, cn=positive, sp=positive, sn=positive, w0=st.floats(1e-4, 1.0))
def test_friction_is_continuous_at_the_blend_edges(
    cp: float, cn: float, sp: float, sn: float, w0: float
) -> None:
    f = FrictionModel(cp, cn, 0.01, sp, sn, 1.0, w0)
    for edge in (w0, -w0):
        eps = 1e-9 * max(w0, 1.0)
        inside, outside = friction_torque([edge * (1 - 1e-9), edge + math.copysign(eps, edge)], f)
        # The blend meets each branch at its edge: jump ~ slope * 1e-9.
        assert abs(inside - outside) < 1e-6 * (1 + (cp + cn + sp + sn) / w0)


def test_pdtv_directions() -> None:
    lines = (PdtvLine(2.0, 1.0, 0.0), PdtvLine(3.0, 0.5, 0.0, "positive"))
    theta = np.array([0.0, 0.0, 0.0])
    w = np.array([1.0, -1.0, 0.0])
    assert pdtv_torque(theta, lines, velocity=w).tolist() == [1.5, 1.0, 1.0]
    assert pdtv_torque(theta, lines).tolist() == [1.0, 1.0, 1.0]  # no velocity: skipped
    neg = (PdtvLine(1.0, 2.0, math.pi / 2, "negative"),)
    assert_allclose(pdtv_torque([math.pi / 2], neg, velocity=[-1.0]), [-2.0], atol=1e-15)


def test_pdtv_line_has_its_order_in_cpr() -> None:
    line = PdtvLine(order=10.0, amplitude=1.0, phase=0.3)
    theta = np.linspace(0, 2 * math.pi, 4096, endpoint=False)
    spec = np.fft.rfft(pdtv_torque(theta, (line,))) / 2048
    # 10 cycles per motor revolution land in FFT bin 10 with the stated amplitude and phase.
    assert int(np.argmax(np.abs(spec))) == 10
    assert_allclose([abs(spec[10]), np.angle(spec[10])], [1.0, 0.3], atol=1e-12)


def test_inertia_at() -> None:
    jm = JointModel(inertia=InertiaModel(constant=2.0, cos_elbow=0.5))
    assert_allclose(inertia_at(jm, [0.0, math.pi / 2, math.pi]), [2.5, 2.0, 1.5], atol=1e-15)


def _doc() -> dict[str, Any]:
    return model_to_dict(_model())


def _set(doc: dict[str, Any], path: tuple[Any, ...], value: Any) -> dict[str, Any]:
    node = doc
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    return doc


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        (
            ("joints", "a", "friction", "stiction"),
            0.1,
            r"unknown key 'stiction' in \[joints\.a\.friction\]",
        ),
        (("joints", "a", "inertia", "mass"), 1.0, r"unknown key 'mass' in \[joints\.a\.inertia\]"),
        (("joints", "a", "friction", "viscous"), "high", r"viscous must be a finite number"),
        (("joints", "a", "friction", "coulomb_positive"), -0.1, r"Coulomb magnitudes must be >= 0"),
        (("joints", "a", "friction", "zero_velocity"), 0.0, r"zero_velocity must be > 0"),
        (("joints", "a", "pdtv", 0, "order"), 0.0, r"order must be positive"),
        # before: accepted, and pdtv-map/estimate evaluated cos(1e9 theta), noise in float64
        (
            ("joints", "a", "pdtv", 0, "order"),
            1e9,
            r"\[joints\.a\.pdtv\]\[0\] order must be at most 1e\+06 CPR .*got 1e\+09",
        ),
        (
            ("joints", "a", "inertia", "constant"),
            1e300,
            r"\[joints\.a\.inertia\] constant must lie in \+-1e\+06 kg m\^2 .*got 1e\+300",
        ),
        (
            ("joints", "a", "inertia", "cos_elbow"),
            -2e6,
            r"\[joints\.a\.inertia\] cos_elbow must lie in \+-1e\+06",
        ),
        (("joints", "a", "pdtv", 0, "direction"), "up", r"direction must be 'both', 'positive'"),
        (("joints", "a", "pdtv", 0, "width"), 1.0, r"unknown key 'width'"),
        (("joints", "a", "pdtv"), {"order": 1}, r"must be an array of tables"),
        (("joints", "a", "spring"), {"k": 1}, r"unknown key 'spring' in \[joints\.a\]"),
        (("identification",), "notes", r"\[identification\] must be a table"),
        (("calibration",), {"x": 1}, r"unknown key 'calibration' in the file"),
    ],
)
def test_bad_model_file(tmp_path: Path, path: tuple[Any, ...], value: Any, message: str) -> None:
    p = tmp_path / "model.toml"
    p.write_text(tomli_w.dumps(_set(_doc(), path, value)))
    with pytest.raises(InputError, match=message) as info:
        load_model(p)
    assert str(info.value).startswith(str(p))


def test_pdtv_line_missing_amplitude(tmp_path: Path) -> None:
    doc = _doc()
    del doc["joints"]["a"]["pdtv"][0]["amplitude"]
    p = tmp_path / "model.toml"
    p.write_text(tomli_w.dumps(doc))
    with pytest.raises(InputError, match=r"\[joints\.a\.pdtv\]\[0\] is missing amplitude"):
        load_model(p)


def test_nan_in_model_file(tmp_path: Path) -> None:
    p = tmp_path / "model.toml"
    text = tomli_w.dumps(_doc()).replace("viscous = 0.0003", "viscous = nan")
    p.write_text(text)
    with pytest.raises(InputError, match=r"viscous must be a finite number, got nan"):
        load_model(p)


def test_missing_robot_table(tmp_path: Path) -> None:
    doc = _doc()
    del doc["robot"]
    p = tmp_path / "model.toml"
    p.write_text(tomli_w.dumps(doc))
    with pytest.raises(InputError, match=r"model\.toml: missing table \[robot\]"):
        load_model(p)


def test_negative_inertia_is_accepted(tmp_path: Path) -> None:
    # identify writes a negative armature when the data want it: not a bad file
    p = tmp_path / "model.toml"
    p.write_text(tomli_w.dumps(_set(_doc(), ("joints", "a", "inertia", "constant"), -2e-5)))
    assert load_model(p).joints["a"].inertia.constant == -2e-5


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        (("joints", "a", "pdtv", 0, "order"), 1e9, "[joints.a.pdtv][0] order must be at most"),
        (("joints", "a", "inertia", "constant"), 1e300, "[joints.a.inertia] constant must lie"),
        (("joints", "a", "pdtv", 0, "amplitude"), -1e300, "[joints.a.pdtv][0] amplitude must lie"),
    ],
)
def test_absurd_model_values_are_refused_by_the_cli(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    path: tuple[Any, ...],
    value: Any,
    message: str,
) -> None:
    from torquemap.cli.main import main

    p = tmp_path / "model.toml"
    p.write_text(tomli_w.dumps(_set(_doc(), path, value)))
    out = tmp_path / "map.csv"
    capsys.readouterr()
    assert main(["pdtv-map", str(p), "--joint", "a", "--bins", "64", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith(f"torquemap: error: {p}: {message}")
    assert not out.exists()


def test_identify_never_writes_an_order_the_model_loader_refuses() -> None:
    """``identify --max-order`` keeps its own copy of the limit (the CLI module loads without
    numpy): it must be the loader's."""
    from torquemap.cli.cmd_identify import MAX_ORDER
    from torquemap.model import MAX_PDTV_ORDER

    assert MAX_ORDER == MAX_PDTV_ORDER
