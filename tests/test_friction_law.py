"""The friction law object: linear view against its own evaluation, symmetry, the file table."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.friction_law import (
    FRICTION_LAWS,
    FrictionLaw,
    SpeedTableFriction,
    StribeckFriction,
    friction_law_from_dict,
)

positive = st.floats(1e-3, 1.0)


@settings(max_examples=40, deadline=None)
@given(
    cp=positive,
    cn=positive,
    v=st.floats(0.0, 0.1),
    sp=st.floats(0.0, 0.5),
    sn=st.floats(0.0, 0.5),
    vs=st.floats(0.05, 5.0),
    w0=st.floats(1e-3, 1.0),
    ex=st.floats(0.5, 3.0),
    transition=st.sampled_from(["linear", "smooth"]),
)
def test_basis_reproduces_torque(
    cp: float,
    cn: float,
    v: float,
    sp: float,
    sn: float,
    vs: float,
    w0: float,
    ex: float,
    transition: str,
) -> None:
    law = StribeckFriction(cp, cn, v, sp, sn, vs, w0, ex, transition)  # type: ignore[arg-type]
    w = np.linspace(-5.0, 5.0, 201)
    # exact algebra: the two evaluations differ by rounding only
    assert_allclose(law.basis(w) @ law.linear_parameters(), law.torque(w), atol=1e-12)
    back = law.with_linear_parameters(law.linear_parameters() * 2.0)
    assert_allclose(back.torque(w), 2.0 * law.torque(w) - 0.0, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(c=positive, s=st.floats(0.0, 0.5), w0=st.floats(1e-3, 1.0))
def test_symmetric_law_is_odd(c: float, s: float, w0: float) -> None:
    for transition in ("linear", "smooth"):
        law = StribeckFriction(c, c, 0.01, s, s, 1.0, w0, transition=transition)
        w = np.linspace(0.0, 4.0, 81)
        assert_allclose(law.torque(-w), -law.torque(w), atol=1e-12)


def test_smooth_transition_by_hand() -> None:
    law = StribeckFriction(
        coulomb_positive=0.2, coulomb_negative=0.1, zero_velocity=0.5, transition="smooth"
    )
    # b(w) = (1 + tanh(w / w0)) / 2: at w = w0, b = (1 + tanh 1) / 2
    b = 0.5 * (1.0 + np.tanh(1.0))
    assert_allclose(law.torque([0.5]), [b * 0.2 - (1 - b) * 0.1], rtol=1e-14)
    assert_allclose(law.torque([0.0]), [0.05], rtol=1e-14)  # halfway between the levels


def test_exponent_two_is_the_gaussian_form() -> None:
    law = StribeckFriction(0.1, 0.1, 0.0, 0.05, 0.05, 2.0, 1e-3)
    assert_allclose(law.torque([3.0]), [0.1 + 0.05 * np.exp(-((3.0 / 2.0) ** 2))], rtol=1e-14)


def test_table_round_trip() -> None:
    law = StribeckFriction(0.1, 0.2, 0.003, 0.04, 0.05, 1.5, 0.02, 1.3, "smooth")
    table = law.to_dict()
    assert table["kind"] == "stribeck"
    back = friction_law_from_dict(table)
    assert isinstance(back, FrictionLaw)
    w = np.linspace(-3, 3, 61)
    assert_allclose(back.torque(w), law.torque(w), rtol=0, atol=0)
    assert "stribeck" in FRICTION_LAWS


def test_identified_offset_round_trips() -> None:
    # an identified law may carry an offset: one Coulomb level below zero (Tiago's vertical
    # torso, 2026-11-27: identify wrote -0.0026 / 0.027 N m, and estimate refused its model)
    law = StribeckFriction(-0.0026, 0.027, -4.6e-5, -0.0039, -0.0039, 1.55, 0.9, 2.0, "smooth")
    back = friction_law_from_dict(law.to_dict())
    w = np.linspace(-30, 30, 61)
    assert_allclose(back.torque(w), law.torque(w), rtol=0, atol=0)


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"kind": "lugre2"}, "kind must be one of"),
        ({"coulomb": 0.1}, "unknown key 'coulomb'"),
        ({"coulomb_positive": -0.1}, "Coulomb magnitudes must be >= 0"),
        ({"coulomb_positive": 0.1, "coulomb_negative": -0.2}, "Coulomb magnitudes must be >= 0"),
        ({"stribeck_velocity": 0.0}, "stribeck_velocity must be > 0"),
        ({"stribeck_exponent": -1.0}, "stribeck_exponent must be > 0"),
        ({"transition": "step"}, "transition must be 'linear' or 'smooth'"),
        ({"viscous": float("nan")}, "must be a finite number"),
        ({"viscous": True}, "must be a finite number"),
    ],
)
def test_bad_tables(table: dict[str, object], message: str) -> None:
    with pytest.raises(InputError, match=message):
        friction_law_from_dict(table, where="[joints.a.friction]", path="m.toml")


# -- the speed table (issue 12) ------------------------------------------------------------

levels = st.lists(st.floats(0.0, 1.0), min_size=3, max_size=3)


@settings(max_examples=40, deadline=None)
@given(
    up=levels,
    down=levels,
    b=st.floats(0.0, 0.01),
    bn=st.floats(0.0, 0.01),
    w0=st.floats(1e-3, 1.0),
)
def test_speed_table_basis_reproduces_torque(
    up: list[float], down: list[float], b: float, bn: float, w0: float
) -> None:
    law = SpeedTableFriction((0.1, 1.0, 10.0), tuple(up), tuple(down), b, bn, w0)
    w = np.r_[np.linspace(-30.0, 30.0, 201), 1e-9, -1e-9]
    # exact algebra: the two evaluations differ by rounding only
    assert_allclose(law.basis(w) @ law.linear_parameters(), law.torque(w), atol=1e-12)
    assert len(law.linear_parameter_names) == law.linear_parameters().size == 8
    doubled = law.with_linear_parameters(2.0 * law.linear_parameters())
    assert_allclose(doubled.torque(w), 2.0 * law.torque(w), atol=1e-12)
    if up == down and b == bn:
        assert_allclose(law.torque(-w), -law.torque(w), atol=1e-12)


def test_speed_table_by_hand() -> None:
    law = SpeedTableFriction((0.1, 10.0), (0.3, 0.1), (0.5, 0.2), 0.01, 0.02, 1e-3)
    # halfway in log speed (1 rad/s) the level is halfway; beyond the knots it is constant,
    # plus the viscous term; at rest the two branches share the transition
    assert_allclose(law.torque([1.0, -1.0]), [0.2 + 0.01, -(0.35 + 0.02)], rtol=1e-12)
    # at 0.01 rad/s the transition (width 1e-3) leaves (1 - tanh 10) / 2 = 2e-9 of the other branch
    assert_allclose(law.torque([0.01, 100.0]), [0.3 + 1e-4, 0.1 + 1.0], rtol=1e-7)
    assert_allclose(law.torque([0.0]), [0.5 * (0.3 - 0.5)], rtol=1e-12)
    assert law.static_levels() == (0.3, 0.5)
    up, down = law.levels(np.array([10.0]))
    assert_allclose([up[0], down[0]], [0.2, 0.4])


def test_speed_table_round_trip() -> None:
    law = SpeedTableFriction((0.1, 1.0, 10.0), (0.3, 0.2, 0.25), (0.4, 0.3, 0.3), 1e-3, 2e-3, 0.02)
    table = law.to_dict()
    assert table["kind"] == "speed-table"
    back = friction_law_from_dict(table)
    assert isinstance(back, FrictionLaw)
    w = np.linspace(-30, 30, 61)
    assert_allclose(back.torque(w), law.torque(w), rtol=0, atol=0)


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({"speeds": [1.0, 2.0], "positive": [0.1, 0.1]}, "needs negative"),
        ({"speeds": [1.0], "positive": [0.1], "negative": [0.1]}, "at least 2"),
        ({"speeds": [2.0, 1.0], "positive": [0.1, 0.1], "negative": [0.1, 0.1]}, "increasing"),
        ({"speeds": [1.0, 2.0], "positive": [0.1, "x"], "negative": [0.1, 0.1]}, "finite"),
        (
            {"speeds": [1.0, 2.0], "positive": [0.1, 0.1], "negative": [0.1, 0.1], "w": 1},
            "unknown key 'w'",
        ),
        (
            {"speeds": [1, 2], "positive": [1, 1], "negative": [1, 1], "zero_velocity": 0},
            "zero_velocity must be > 0",
        ),
    ],
)
def test_speed_table_bad_tables(table: dict[str, object], message: str) -> None:
    with pytest.raises(InputError, match=message):
        friction_law_from_dict({"kind": "speed-table", **table}, path="m.toml")
