"""A Stribeck drop between passes far apart (random robot 242 of the family, stop 38): the
whole fit's table between the passes is its prior's, and its sigma there gets a model-form
term from a second estimate (``identify_whole.CURVE_FORM``: the same fit with its prior centred
on a Stribeck curve). Robot 242's joint a law (Fc 0.027 / 0.022 N m, Fs 0.0132 N m at 3.66
rad/s, exponent 2) swept at 242's passes, 0.85, 3.7 and 16 rad/s (4.35x apart), with ramps of
20 ms; the truth is read by the test only."""

from __future__ import annotations

import numpy as np
import pytest
from test_identify_whole import robot, simulate

from torquemap.friction_law import StribeckFriction
from torquemap.identify import identify_model
from torquemap.model import Model
from torquemap.uncertainty import interpolation_sigma

# one worker runs the module, so its module fixture (two identifications) is built once
pytestmark = pytest.mark.xdist_group("robot242_like")

LAW = StribeckFriction(
    coulomb_positive=0.027,
    coulomb_negative=0.022,
    viscous=0.0001,
    stribeck_positive=0.0132,
    stribeck_negative=0.0131,
    stribeck_velocity=3.66,
    stribeck_exponent=2.0,
    zero_velocity=0.05,
    transition="smooth",
)
PASSES = (0.85, 3.7, 16.0)
BETWEEN = np.array([1.2, 1.6, 2.0, 2.5, 3.0, 5.0, 6.5, 8.5, 11.0])


def _table_sigma(model: Model, velocity: np.ndarray) -> np.ndarray:
    """The friction table's standard deviation [N m] at steady ``velocity``: the parameters'
    covariance along the table's basis, and the leave-one-pass-out interpolation term."""
    entry = model.notes["joints"]["m"]
    record = entry["uncertainty"]
    names = record["parameters"]
    cov = np.asarray(record["covariance"])
    law = model.joints["m"].friction
    basis = law.basis(velocity)
    own = tuple(law.linear_parameter_names)
    g = np.zeros((velocity.size, len(names)))
    for i, name in enumerate(names):
        key = name.split(".", 1)[1] if name.startswith("friction.") else ""
        if key in own:
            g[:, i] = basis[:, own.index(key)]
    var = np.einsum("ij,jk,ik->i", g, cov, g)
    inter = record["interpolation"]
    spread = interpolation_sigma(
        velocity,
        1e-3,
        entry["speeds"],
        inter["curvature"],
        floor=entry["friction_observed_speed"],
    )
    return np.sqrt(var + spread**2)


@pytest.fixture(scope="module")
def models() -> tuple[Model, Model]:
    import torquemap.identify_whole as iw

    log = simulate(law=LAW, ramp=0.02, speeds=PASSES, noise=3e-4, seed=3)
    saved = iw.CURVE_FORM
    try:
        iw.CURVE_FORM = False
        off = identify_model(robot(), [log], max_order=20, friction="whole").model
        iw.CURVE_FORM = True
        on = identify_model(robot(), [log], max_order=20, friction="whole").model
    finally:
        iw.CURVE_FORM = saved
    return off, on


def test_the_table_misses_the_drop_between_the_passes(models: tuple[Model, Model]) -> None:
    # the cause: between the passes the table is drawn by its prior and misses the Stribeck
    # drop (measured 2.8-7.8 % of the friction, most at 2 and 6.5 rad/s); the term changes the
    # sigma only, not the table
    off, on = models
    for sign in (1.0, -1.0):
        v = sign * BETWEEN
        err = on.joints["m"].friction.torque(v) - LAW.torque(v)
        assert np.max(np.abs(err)) > 0.04 * float(np.min(np.abs(LAW.torque(v))))
        np.testing.assert_array_equal(
            on.joints["m"].friction.torque(v), off.joints["m"].friction.torque(v)
        )


def test_the_sigma_covers_the_truth_between_the_passes(models: tuple[Model, Model]) -> None:
    # every between-pass speed's error within 2 sigma with the term (measured 0.26-0.73
    # sigma; without it the same holds on this motor, whose leave-one-pass-out term is
    # wide, unlike robot 242's), and the sigma not narrower than without it
    off, on = models
    for sign in (1.0, -1.0):
        v = sign * BETWEEN
        err = np.abs(on.joints["m"].friction.torque(v) - LAW.torque(v))
        s_on, s_off = _table_sigma(on, v), _table_sigma(off, v)
        assert np.all(err <= 2.0 * s_on)
        assert np.all(s_on >= s_off * (1.0 - 1e-9))


def test_the_sigma_at_the_passes_is_unchanged(models: tuple[Model, Model]) -> None:
    # the term sits on the knots the prior holds between the passes only: at the passes'
    # speeds the sigma is what it was (measured: equal at 0.85 and 3.7 rad/s, 1.8 % wider at
    # 16 rad/s, which lies just off its knot, so a held knot's hat reaches it), while between
    # them it widens (measured up to 1.57x positive, 1.16x negative)
    off, on = models
    for sign in (1.0, -1.0):
        v = sign * np.asarray(PASSES)
        np.testing.assert_allclose(_table_sigma(on, v)[:2], _table_sigma(off, v)[:2], rtol=1e-6)
        assert _table_sigma(on, v)[2] <= 1.02 * _table_sigma(off, v)[2]
        w = sign * BETWEEN
        assert np.max(_table_sigma(on, w) / _table_sigma(off, w)) > 1.1
