"""Simulated motors, amplifier and characterisation bench (torquemap.sim.motors, sim.rig)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.linearize.motor import ramped_actuation
from torquemap.sim.motors import (
    Amplifier,
    BrushlessDcMotor,
    VariableReluctanceMotor,
    amplifier_current,
    motor_torque,
)
from torquemap.sim.rig import brushless_dc_rig, sim_rig, variable_reluctance_rig


def _apmd(tau: np.ndarray) -> float:
    """Paper Eq 1 over c = 1 .. C: plane through (c=0, tau=0) and the mean torque at C/2."""
    c_max = tau.shape[1] - 1
    c = np.arange(c_max + 1)
    desired = tau[:, c_max // 2].mean() * c / (c_max / 2)
    return float(np.mean(np.abs(desired[1:] - tau[:, 1:]) / np.abs(desired[1:])))


def test_vr_torque_quadratic_at_low_current_and_saturating_at_high() -> None:
    motor = VariableReluctanceMotor()
    x = 120.0  # phase 1 near its peak

    def torque(i: float) -> float:
        return float(motor_torque(motor, x, [i, 0.0, 0.0]))

    def slope(i: float) -> float:  # log-log slope by a central difference
        return (np.log(torque(i * 1.01)) - np.log(torque(i / 1.01))) / (2 * np.log(1.01))

    # closed form of f(i) = i^2 / sqrt(1 + (i/i_s)^2): d ln f / d ln i = 2 - r / (1 + r)
    for i in (0.05, 2.0, 9.0):
        r = (i / motor.saturation_current) ** 2
        assert_allclose(slope(i), 2 - r / (1 + r), atol=1e-3)  # O(h^2) difference error
    assert slope(0.05) > 1.99 and slope(9.5) < 1.45


def test_bldc_torque_linear_in_current_apart_from_cogging() -> None:
    motor = BrushlessDcMotor()
    x = np.linspace(0, 255, 50)
    cog = motor_torque(motor, x, np.zeros((50, 3)))
    one = motor_torque(motor, x, np.tile([2.0, 0.0, 0.0], (50, 1))) - cog
    two = motor_torque(motor, x, np.tile([4.0, 0.0, 0.0], (50, 1))) - cog
    assert_allclose(two, 2 * one, atol=1e-12)  # single phase: exactly linear by construction
    assert np.abs(cog).max() > 0.05  # cogging is there


def test_two_phase_torque_is_not_the_sum_of_phase_torques() -> None:
    for motor, x in ((VariableReluctanceMotor(), 170.0), (BrushlessDcMotor(), 85.0)):
        a = float(motor_torque(motor, x, [9.0, 0.0, 0.0]))
        b = float(motor_torque(motor, x, [0.0, 9.0, 0.0]))
        both = float(motor_torque(motor, x, [9.0, 9.0, 0.0]))
        base = float(motor_torque(motor, x, [0.0, 0.0, 0.0]))
        assert both - base < 0.95 * ((a - base) + (b - base))  # mutual saturation


def test_amplifier_dead_band_curve_and_limit() -> None:
    amp = Amplifier()
    i = amplifier_current(np.arange(256), amp)
    assert (i[: int(amp.dead_band) + 1] == 0).all()
    assert i.max() == amp.current_limit
    assert (np.diff(i) >= 0).all()
    mid = amplifier_current((amp.dead_band + amp.actuation_max) / 2, amp)
    # a convex curve (a < 0) lies below the chord: closed form (e^{|a|/2} - 1) / (e^{|a|} - 1)
    a = -amp.curve
    assert_allclose(mid, amp.current_max * np.expm1(a / 2) / np.expm1(a), rtol=1e-12)


@pytest.mark.parametrize("factory", [variable_reluctance_rig, brushless_dc_rig])
def test_equilibrium_positions_zero_torque_and_restoring(factory) -> None:  # type: ignore[no-untyped-def]
    rig = factory(rng=0)
    eq = rig.equilibrium_positions()
    peak = rig.true_torque(np.arange(rig.positions_per_cycle), [255, 0, 0]).max()
    n = rig.positions_per_cycle
    for k, e in enumerate(eq):
        act = np.zeros(3, dtype=int)
        act[k] = 255
        # within half a table position of the root: |T| below the slope times 0.5
        here = float(rig.true_torque(e, act))
        before = float(rig.true_torque((e - 2) % n, act))
        after = float(rig.true_torque((e + 2) % n, act))
        assert abs(here) < 0.5 * (before - after) / 4 + 1e-9
        assert before > 0 > after  # restoring: pushes forward before, back after
        assert abs(here) < 0.03 * peak
    assert rig.motor_spec().equilibrium_positions == eq


@pytest.mark.parametrize(
    ("factory", "low", "high"),
    [(variable_reluctance_rig, 0.55, 0.85), (brushless_dc_rig, 0.10, 0.40)],
)
def test_uncompensated_apmd_in_paper_range(factory, low: float, high: float) -> None:  # type: ignore[no-untyped-def]
    # Paper Table 2 (wide ramping): VR joints 76.1 % and 58.3 %, BLDC joints 36.0 % and 9.1 %.
    rig = factory(rng=0)
    spec = rig.motor_spec(ramping="wide")
    n = spec.positions_per_cycle
    act = ramped_actuation(np.arange(256)[None, :], np.arange(n)[:, None], spec.ramp)
    tau = rig.true_torque(np.arange(n)[:, None], act)
    assert low < _apmd(tau) < high


def test_sensor_bias_compliance_and_saturation() -> None:
    rig = variable_reluctance_rig(rng=0, noise=0.0, friction=0.0, saturation=30.0)
    rig.apply([0, 0, 0])
    rig.settle()
    assert_allclose(rig.read_torque(), rig.bias_at(rig.base), atol=1e-12)  # no load: bias only
    for _ in range(250):  # to position 100: phase 1 pushes hard there
        rig.step_secondary()
    rig.apply([120, 0, 0])
    rig.settle()
    x = rig.base + rig.force / rig.settings.stiffness
    # settled: the force is the true torque at the deflected position (a fixed point)
    assert_allclose(rig.force, float(rig.true_torque(x, [120, 0, 0])), rtol=1e-9)
    assert rig.read_position() == round(x)
    assert_allclose(rig.read_torque(), rig.bias_at(rig.base) + rig.force, atol=1e-12)
    rig.apply([255, 0, 0])
    rig.settle()
    assert rig.read_torque() == 30.0  # clipped at the sensor's range


def test_friction_band_holds_small_torques() -> None:
    rig = brushless_dc_rig(rng=0, noise=0.0, friction=0.5, start_position=40.0)
    rig.apply([20, 0, 0])  # a little current: torque inside the friction band
    rig.settle()
    assert float(rig.true_torque(40, [20, 0, 0])) < 0.5 and rig.force == 0.0
    rig.apply([200, 0, 0])
    rig.settle()
    x = rig.base + rig.force / rig.settings.stiffness
    assert_allclose(rig.force, float(rig.true_torque(x, [200, 0, 0])) - 0.5, rtol=1e-9)


def test_noise_is_seeded() -> None:
    a = variable_reluctance_rig(rng=5)
    b = variable_reluctance_rig(rng=5)
    assert [a.read_torque() for _ in range(3)] == [b.read_torque() for _ in range(3)]
    readings = np.array([a.read_torque() for _ in range(4000)])
    assert_allclose(readings.std(), a.settings.noise, rtol=0.05)  # 4000 samples: ~1.1 % std error


def test_rig_rejects_bad_actuation_and_options() -> None:
    rig = brushless_dc_rig(rng=0)
    with pytest.raises(ValueError, match="need 3 actuations"):
        rig.apply([1, 2])
    with pytest.raises(ValueError, match=r"outside 0 \.\. 255"):
        rig.apply([0, 300, 0])
    with pytest.raises(TypeError, match="unknown rig option 'colour'"):
        brushless_dc_rig(colour="red")
    with pytest.raises(InputError, match="unknown simulated motor"):
        sim_rig("dc")  # type: ignore[arg-type]
