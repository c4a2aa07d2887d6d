"""friction: segmentation, friction and inertia fits on data simulated here."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.filters import differentiate
from torquemap.friction import angle_mean, fit_friction, fit_inertia, segment_motion
from torquemap.model import FrictionModel, friction_torque


def test_angle_mean_cancels_whole_revolutions_of_pdtv() -> None:
    theta = np.linspace(0.0, 2.7 * 2 * np.pi, 20000)
    m, revs = angle_mean(theta, 0.3 + 0.1 * np.cos(5 * theta + 1.0))
    # 2 whole revolutions are used: the order-5 term integrates to 0, up to the end landing on
    # the first sample past 2 revolutions (step 5.4e-3 rad: error < 0.1*step/(4 pi) = 4e-5)
    assert_allclose(m, 0.3, atol=5e-5)
    assert_allclose(revs, 2.7, rtol=1e-6)


def test_stribeck_found_when_present_and_refused_when_absent() -> None:
    rng = np.random.default_rng(0)
    speeds = np.array([0.2, 0.4, 0.8, 1.6, 3.2, 6.4])
    w = np.concatenate([speeds, -speeds, speeds, -speeds])
    true = FrictionModel(
        coulomb_positive=0.05,
        coulomb_negative=0.05,
        viscous=0.002,
        stribeck_positive=0.03,
        stribeck_negative=0.03,
        stribeck_velocity=0.5,
    )
    tau = friction_torque(w, true) + rng.normal(0.0, 2e-4, w.size)
    fit = fit_friction(w, tau)
    assert fit.stribeck_used
    # noise 0.2 mN m on 24 pass means: parameters to a few percent
    assert_allclose(fit.friction.stribeck_positive, 0.03, rtol=0.1)
    assert_allclose(fit.friction.coulomb_positive, 0.05, rtol=0.05)
    plain = FrictionModel(coulomb_positive=0.05, coulomb_negative=0.05, viscous=0.002)
    fit2 = fit_friction(w, friction_torque(w, plain) + rng.normal(0.0, 2e-4, w.size))
    assert not fit2.stribeck_used
    with pytest.raises(InputError, match="no constant-speed pass"):
        fit_friction([], [])


def _rising_law(w: np.ndarray, top: float, power: float, rise: float) -> np.ndarray:
    """Friction of another form than Stribeck's: a Stribeck dip below the passes, then a
    torque that rises faster than linearly towards the top speed (``rise`` N m at ``top``)."""
    a = np.abs(w)
    level = np.where(w > 0, 0.0437, 0.0362) + np.where(w > 0, 0.0235, 0.0102) * np.exp(
        -((a / 4.6) ** 2)
    )
    return np.sign(w) * (level + 0.001 * a + rise * (a / top) ** power)


def test_stribeck_refused_where_it_is_not_physical_or_not_testable() -> None:
    # random robot 16 of the family: a Stribeck term fitted to three speeds per direction of a
    # law of another form dropped 3.9 N m over a Coulomb level of -3.8 N m, clipped to 0: a
    # law 90x too strong below the slowest pass, exit 0 (9000 % of the spring force)
    rng = np.random.default_rng(3)
    for speeds, power, rise in (
        ((7.0, 18.8, 47.9), 3.0, 0.007),
        ((5.0, 11.3, 38.5, 43.3), 6.2, 0.0168),
    ):
        s = np.asarray(speeds)
        w = np.concatenate([s, -s, s, -s])
        tau = _rising_law(w, s[-1], power, rise) + rng.normal(0.0, 3e-4, w.size)
        fit = fit_friction(w, tau)
        f = fit.friction
        assert not fit.stribeck_used
        assert f.coulomb_positive >= 0 and f.coulomb_negative >= 0
        # below the slowest pass the law stays within the torques the passes measured
        rest = friction_torque(np.array([0.5, -0.5]), f)
        assert np.all(np.abs(rest) <= np.max(np.abs(tau)))
        if s.size == 4:  # testable, but it needs a negative Coulomb level: said so
            assert any("negative Coulomb level" in m for m in fit.warnings)


@pytest.mark.parametrize("vs", [0.37, 1.5, 2.9])
def test_stribeck_velocity_between_grid_points_is_recovered(vs: float) -> None:
    # exact pass means at the five speeds of a typical sweep: the grid over Stribeck velocities
    # only brackets the minimum, the bounded search must land on it
    speeds = np.array([0.5, 1.5, 5.0, 15.0, 43.0])
    w = np.concatenate([speeds, -speeds])
    true = FrictionModel(
        coulomb_positive=0.045,
        coulomb_negative=0.05,
        viscous=3e-4,
        stribeck_positive=0.012,
        stribeck_negative=0.01,
        stribeck_velocity=vs,
    )
    f = fit_friction(w, friction_torque(w, true), stribeck="always").friction
    assert_allclose(f.stribeck_velocity, vs, rtol=1e-3)
    assert_allclose(
        [f.coulomb_positive, f.coulomb_negative, f.stribeck_positive, f.stribeck_negative],
        [0.045, 0.05, 0.012, 0.01],
        rtol=1e-3,
    )


@given(st.floats(0.01, 0.5), st.floats(0.01, 0.5), st.floats(0.0, 0.05))
def test_friction_fit_exact_on_exact_data(cp: float, cn: float, b: float) -> None:
    w = np.array([1.0, 3.0, -1.0, -3.0])
    tau = np.where(w > 0, cp, -cn) + b * w
    f = fit_friction(w, tau, stribeck="never").friction
    # exact data, 3 unknowns, 4 equations: recovered to rounding
    assert_allclose([f.coulomb_positive, f.coulomb_negative, f.viscous], [cp, cn, b], atol=1e-9)


def test_inertia_with_elbow_term_and_without() -> None:
    rng = np.random.default_rng(1)
    acc = rng.normal(0.0, 50.0, 5000)
    elbow = rng.uniform(-2.0, 2.0, 5000)
    y = (3e-4 + 1e-4 * np.cos(elbow)) * acc + rng.normal(0.0, 1e-3, 5000)
    fit = fit_inertia(acc, y, elbow_angle=elbow)
    # SE ~ 1e-3 / (50 * sqrt(5000)) = 3e-7: 1e-6 is 3 standard errors
    assert_allclose([fit.inertia.constant, fit.inertia.cos_elbow], [3e-4, 1e-4], atol=2e-6)
    one = fit_inertia(acc, y, elbow_angle=np.full(5000, 0.5))
    assert one.inertia.cos_elbow == 0.0
    assert "one elbow angle" in one.warnings[0]
    # random SCARA 102 swept joint a at 2.37, 2.64 and 2.66 rad: three angles, not one (the
    # warning said "one"); their cosines differ by 0.17, under the 0.2 the term needs
    close = fit_inertia(acc, y, elbow_angle=np.where(elbow > 0, 2.37, 2.66))
    assert close.inertia.cos_elbow == 0.0
    spread = math.cos(2.37) - math.cos(2.66)
    assert f"2.37 to 2.66 rad only, whose cosines differ by {spread:.2g}" in close.warnings[0]
    assert "differ by 0.2 or more" in close.warnings[0]
    assert "no accelerating segment" in fit_inertia([], []).warnings[0]


def test_segmentation_bridges_ripple_and_finds_ramps() -> None:
    t = np.arange(0.0, 20.0, 1e-3)
    v = np.clip(t, 0.0, 1.0) * np.clip(20.0 - t, 0.0, 1.0) * 2.0  # 1 s ramps, 2 rad/s
    v = v * (1 + 0.8 * np.sin(2 * np.pi * 30 * t))  # strong ripple
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * 1e-3)))
    seg = segment_motion(t, theta, v, np.ones_like(t))
    assert len(seg.passes) == 1
    p = seg.passes[0]
    assert p.direction == "positive"
    # the pass starts after the 1 s ramp (within the revolution-average window) and ends before
    assert 0.8 < t[p.start] < 2.5 and 17.5 < t[p.stop - 1] < 19.2
    assert seg.accelerating[:500].sum() > 0


def _stick_slip(v_ref: float, duration: float) -> tuple[np.ndarray, ...]:
    """A position servo (15 Hz, damping 0.8) ramping a rotor (1e-4 kg m^2) at ``v_ref``
    through Stribeck friction (static 0.08, Coulomb 0.05 N m, 0.3 rad/s): at 0.5 rad/s it
    sticks and slips. Logged at 1 kHz with a 4096-count encoder; returns the time, the encoder
    angle, the true angle and the commanded torque."""
    dt, inertia = 2e-4, 1e-4
    wn = 2 * math.pi * 15.0
    stiff, damp = inertia * wn**2, 2 * 0.8 * inertia * wn
    n = round(duration / dt)
    angle, torque = np.empty(n), np.empty(n)
    th = w = 0.0
    for i in range(n):
        u = stiff * (v_ref * i * dt - th) + damp * (v_ref - w)
        torque[i] = u
        if w == 0.0 and abs(u) <= 0.08:  # stuck
            angle[i] = th
            continue
        f = math.copysign(0.05 + 0.03 * math.exp(-((w / 0.3) ** 2)), w if w else u) + 1e-3 * w
        w_new = w + dt * (u - f) / inertia
        w = 0.0 if w * w_new < 0 else w_new
        th += dt * w
        angle[i] = th
    count = 2 * math.pi / 4096
    true = angle[::5]
    return np.arange(true.size) * 1e-3, np.round(true / count) * count, true, torque[::5]


def test_segmentation_chains_the_bursts_of_a_joint_that_sticks_and_slips() -> None:
    # random SCARA 204's slowest positive sweep pass at the 0.05 s window: bursts of 0.05 to
    # 0.1 s, each a run too small for the bridge between significant runs, so no pass was
    # found (its friction below 3.9 rad/s then came from the prior alone)
    t, q, true, tau = _stick_slip(0.5, 16.0)
    # the premise: the rotor sticks and slips (still 30-50 % of the time, in 0.02-0.1 s rests)
    still = np.diff(true) == 0
    starts = np.flatnonzero(np.diff(still.astype(int)) == 1)
    assert 0.3 < still.mean() < 0.5 and starts.size > 100
    count = 2 * math.pi / 4096
    for sign in (1.0, -1.0):
        d = differentiate(t, sign * q, window=0.05)
        threshold = 5 * count / 0.05  # identify's: five velocity quanta
        old = segment_motion(t, d.position, d.velocity, tau, speed_threshold=threshold)
        assert old.passes == ()
        seg = segment_motion(
            t, d.position, d.velocity, sign * tau, speed_threshold=threshold, window=0.05
        )
        assert [p.direction for p in seg.passes] == ["positive" if sign > 0 else "negative"]
        # the servo tracks its ramp: the pass's mean speed is the commanded one
        assert_allclose(seg.passes[0].speed, sign * 0.5, rtol=0.01)
        assert seg.passes[0].revolutions > 0.8 * 16.0 * 0.5 / (2 * math.pi)


@pytest.mark.parametrize(("hold", "found"), [(0.3, False), (0.1, False), (0.03, True)])
def test_segmentation_chains_no_hold_and_step(hold: float, found: bool) -> None:
    # an anti-cogging calibration: 0.05 s steps of 1/64 revolution (small runs, as the
    # bursts above) and holds. Held for two differentiator windows or more, it is no pass (the
    # CLI then points to identify --quasi-static); rests of 0.03 s are a stick-slip's
    period, step = 0.05 + hold, 2 * math.pi / 64
    t = np.arange(0.0, 64 * period, 1e-3)
    k, phase = np.divmod(t, period)
    moved = np.where(phase < 0.05, 0.5 - 0.5 * np.cos(math.pi * phase / 0.05), 1.0)
    count = 2 * math.pi / 4096
    q = np.round((k + moved) * step / count) * count
    d = differentiate(t, q, window=0.05)
    seg = segment_motion(
        t, d.position, d.velocity, np.ones_like(t), speed_threshold=5 * count / 0.05, window=0.05
    )
    assert len(seg.passes) == int(found)
    if found:
        assert_allclose(seg.passes[0].speed, step / period, rtol=0.02)


def test_segmentation_finds_no_pass_in_a_servo_dithering_at_rest() -> None:
    # bursts both ways that cancel (no net travel): chaining must not make a pass of them
    t = np.arange(0.0, 40.0, 1e-3)
    phase = t % 0.2
    v = np.where(phase < 0.06, 0.8, np.where((phase >= 0.1) & (phase < 0.16), -0.8, 0.0))
    theta = np.concatenate(([0.0], np.cumsum(v[:-1]) * 1e-3))
    seg = segment_motion(t, theta, v, np.ones_like(t), window=0.05)
    assert seg.passes == ()


def test_segmentation_keeps_a_fast_pass_followed_by_slow_bursts_apart() -> None:
    # a fast pass at 20 rad/s (0.2 s ramps), then the joint sticks and slips the same way
    # (bursts of 0.06 s at 0.8 rad/s every 0.1 s): two passes at their own closed-form speeds,
    # the bursts never joined to the fast pass (random robot 6 of the family: chaining before
    # the bridge turned its 92 rad/s pass into 8.95)
    t = np.arange(0.0, 44.0, 1e-3)
    fast = 20.0 * np.clip(t / 0.2, 0, 1) * np.clip((3.2 - t) / 0.2, 0, 1)
    slow = np.where((t > 3.5) & (((t - 3.5) % 0.1) < 0.06), 0.8, 0.0)
    v = fast + slow
    theta = np.concatenate(([0.0], np.cumsum(v[:-1]) * 1e-3))
    seg = segment_motion(t, theta, v, np.ones_like(t), window=0.05)
    speeds = sorted(p.speed for p in seg.passes)
    # the slow one 0.048 rad every 0.1 s; the fast one flat at 20 rad/s between its ramps
    assert_allclose(speeds, [0.48, 20.0], rtol=0.01)
