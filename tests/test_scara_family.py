"""The random family of simulated SCARA benches: its friction laws, logger and draws.

Independent references: the LuGre law's closed forms (steady state, the pre-sliding curve as a
function of displacement), the passivity of the law (its dissipation), finite differences for
the engine's Newton slopes, the static law written out again here, and the ranges the family
documents.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.cli.main import main
from torquemap.io import read_table
from torquemap.model import load_model
from torquemap.sim import scara_family as family
from torquemap.sim.bench import simulate_bench, simulate_sweep
from torquemap.sim.engine import _friction, _friction_general, _static_constants
from torquemap.sim.logger import delayed_ticks, logged_ticks
from torquemap.sim.lugre import bristle_energy, lugre_constants, lugre_response, lugre_update
from torquemap.sim.scara import (
    Controller,
    Friction,
    Harmonic,
    Logging,
    Lugre,
    ScaraBench,
    Sweep,
    friction_torque,
    pdtv_torque,
)
from torquemap.sim.scara_family import MIN_SIN_ELBOW, RANGES, random_bench
from torquemap.sim.trajectory import circle_reference, sweep_reference

# one worker runs the module, so its module fixtures (the draws, a short random bench) are
# built once
pytestmark = pytest.mark.xdist_group("scara_family")

SEEDS = range(24)

LUGRE = Friction(
    coulomb_positive=0.04,
    coulomb_negative=0.05,
    viscous=4e-4,
    stribeck_positive=0.015,
    stribeck_negative=0.01,
    stribeck_velocity=1.2,
    stribeck_exponent=1.3,
    viscous_negative=6e-4,
    stribeck_velocity_negative=0.8,
    lugre=Lugre(bristle_stiffness=8.0, bristle_damping=0.03, damping_velocity=1.0),
)


def _static(w: np.ndarray, f: Friction) -> np.ndarray:
    """The static law outside the blend, written out again: ``sign(w) g(w) + viscous(w) w``."""
    pos = w > 0
    vs = np.where(pos, f.stribeck_velocity, f.stribeck_velocity_negative or f.stribeck_velocity)
    c = np.where(pos, f.coulomb_positive, f.coulomb_negative)
    s = np.where(pos, f.stribeck_positive, f.stribeck_negative)
    v = np.where(
        pos, f.viscous, f.viscous_negative if f.viscous_negative is not None else f.viscous
    )
    return np.sign(w) * (c + s * np.exp(-(np.abs(w / vs) ** f.stribeck_exponent))) + v * w


# -- the friction laws ---------------------------------------------------------------------


@pytest.mark.parametrize("speed", [-30.0, -2.0, -0.3, 0.3, 1.0, 5.0, 40.0])
def test_lugre_steady_state_is_its_stribeck_curve(speed: float) -> None:
    t = np.arange(4001) * 2.5e-4
    out = lugre_response(t, np.full(t.size, speed), LUGRE)
    # Backward Euler's fixed point is the continuous one, z = sign(w) g(w) / sigma_0, so the
    # settled torque is the static law to rounding (the slowest speed settles in ~0.3 s).
    assert_allclose(out.torque[-1], _static(np.array([speed]), LUGRE)[0], rtol=1e-9)
    assert_allclose(out.torque[-1], friction_torque(speed, LUGRE), rtol=1e-9)


def test_lugre_presliding_follows_its_closed_form() -> None:
    # From rest with relaxed bristles, a slow forward creep: dz/dx = 1 - sigma_0 z / g, so
    # z(x) = g / sigma_0 (1 - exp(-sigma_0 x / g)), a function of the displacement x alone.
    w = 1e-3
    t = np.arange(20001) * 1e-3  # 20 s: x up to 0.02 rad, several pre-sliding ranges
    out = lugre_response(t, np.full(t.size, w), LUGRE)
    x = w * t
    g = LUGRE.coulomb_positive + LUGRE.stribeck_positive * math.exp(-((w / 1.2) ** 1.3))
    s0 = 8.0
    z = g / s0 * (1 - np.exp(-s0 * x / g))
    # Backward Euler over steps of 1e-6 rad of travel against a pre-sliding range of 6e-3 rad:
    # relative error ~1e-4; the damping and viscous terms add under 3e-5 N m at this speed.
    assert_allclose(out.deflection, z, rtol=2e-3, atol=1e-8)
    expected = s0 * z + 0.03 * w * (1 - s0 * z / g) + 4e-4 * w
    assert_allclose(out.torque[1:], expected[1:], rtol=2e-3, atol=1e-6)
    # The first few micro-radians act like a spring of stiffness sigma_0 (the "bristles"),
    # besides the damping and viscous terms' constant share at this constant speed.
    assert out.torque[10] - (0.03 + 4e-4) * w == pytest.approx(s0 * x[10], rel=0.01)


def test_lugre_dissipates_energy() -> None:
    rng = np.random.default_rng(4)
    t = np.arange(40001) * 2.5e-4
    # Reversals, slow creep and fast passes: a sum of sines of random phases.
    w = sum(
        a * np.sin(2 * math.pi * f * t + p)
        for a, f, p in zip([8.0, 2.0, 0.5], [0.3, 2.1, 9.0], rng.uniform(0, 6, 3), strict=True)
    )
    out = lugre_response(t, w, LUGRE)
    work = np.concatenate([[0.0], np.cumsum(out.torque[1:] * w[1:] * np.diff(t))])
    dissipated = work - bristle_energy(out.deflection, LUGRE)
    # Passive law (damping velocity within Olsson et al.'s bound) and a backward Euler step
    # that only adds dissipation: each step's dissipation is >= 0 up to rounding.
    assert np.diff(dissipated).min() > -1e-12
    assert dissipated[-1] > 0.1 * np.abs(work).max()


def test_lugre_slope_is_the_newton_slope() -> None:
    c = lugre_constants(LUGRE)
    for z, w in [(0.0, 0.5), (0.004, 3.0), (-0.003, -1.0), (0.001, -0.2)]:
        h = 1e-7
        up = lugre_update(z, w + h, 2.5e-4, c)[0]
        down = lugre_update(z, w - h, 2.5e-4, c)[0]
        # Central differences with h = 1e-7 on a smooth function: ~1e-7 relative.
        assert lugre_update(z, w, 2.5e-4, c)[1] == pytest.approx((up - down) / (2 * h), rel=1e-5)


@pytest.mark.parametrize("w", [-7.0, -0.5, -0.02, 0.0, 0.01, 0.3, 2.0, 25.0])
def test_static_law_of_another_form(w: float) -> None:
    f = dataclasses.replace(LUGRE, lugre=None, zero_velocity=0.05)
    value, slope, _ = _friction_general(w, _static_constants(f))
    # Engine (scalar) and bench law (numpy) are two implementations of the same law.
    assert value == pytest.approx(float(friction_torque(w, f)), rel=1e-12, abs=1e-15)
    if abs(w) > 0.05:
        assert value == pytest.approx(_static(np.array([w]), f)[0], rel=1e-12)
    h = 1e-7
    fd = (_friction_general(w + h, _static_constants(f))[0] - value) / h
    assert slope == pytest.approx(fd, rel=1e-3, abs=1e-6)


def test_paper_law_path_is_unchanged() -> None:
    f = Friction(0.045, 0.05, 3e-4, 0.012, 0.01)
    assert f.is_paper_law
    for w in (-3.0, -0.01, 0.0, 0.02, 4.0):
        # The general code path gives the paper's law when the law is the paper's.
        assert _friction(w, f)[0] == pytest.approx(
            _friction_general(w, _static_constants(f))[0], rel=1e-13, abs=1e-16
        )


def test_directional_pdtv_acts_one_way() -> None:
    lines = (Harmonic(2.0, 0.01, 0.3), Harmonic(5.0, 0.004, -1.0, "negative"))
    theta = np.linspace(0, 6, 50)
    both = 0.01 * np.cos(2 * theta + 0.3)
    assert_allclose(pdtv_torque(theta, lines, velocity=np.full(50, 2.0)), both, atol=1e-15)
    neg = both + 0.004 * np.cos(5 * theta - 1.0)
    assert_allclose(pdtv_torque(theta, lines, velocity=np.full(50, -2.0)), neg, atol=1e-15)
    half = both + 0.002 * np.cos(5 * theta - 1.0)  # faded in over zero_velocity (0.05)
    assert_allclose(pdtv_torque(theta, lines, velocity=np.full(50, -0.025)), half, atol=1e-15)


# -- the draw ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def benches() -> list[ScaraBench]:
    return [random_bench(s) for s in SEEDS]


def test_draw_is_a_function_of_the_seed(benches: list[ScaraBench]) -> None:
    assert repr(random_bench(7)) == repr(benches[7])
    assert len({repr(b) for b in benches}) == len(benches)
    with pytest.raises(ValueError, match="seed"):
        random_bench(-1)


def _inside(x: float, r: tuple[float, float]) -> bool:
    return r[0] <= x <= r[1]


def test_draws_respect_the_ranges(benches: list[ScaraBench]) -> None:
    for b in benches:
        for ax in b.axes:
            assert _inside(ax.gear_ratio, RANGES.gear_ratio)
            assert _inside(ax.torque_constant, RANGES.torque_constant)
            assert _inside(ax.rotor_inertia, RANGES.rotor_inertia)
            f = ax.friction
            assert _inside(f.coulomb_positive, RANGES.coulomb)
            assert f.stribeck_exponent == 2.0 or not 1.6 < f.stribeck_exponent < 2.5
            assert _inside(f.stribeck_exponent, RANGES.stribeck_exponent)
            if f.lugre is not None:
                # Olsson et al.'s passivity bound: sigma_1 vd < 4 sqrt(2 e) min(g).
                lg = f.lugre
                bound = 4 * math.sqrt(2 * math.e) * min(f.coulomb_positive, f.coulomb_negative)
                assert lg.bristle_damping * lg.damping_velocity < bound
            assert ax.pdtv and all(h.amplitude > 0 for h in ax.pdtv)
        assert _inside(b.links.lengths[0], RANGES.link_length)
        assert _inside(b.circle.spring_force, RANGES.spring_force)
        assert _inside(b.circle.radius, RANGES.circle_radius)
        assert _inside(b.circle.angular_speed, RANGES.circle_speed)
        assert b.circle.free_length > 0
        assert b.logging.rate is not None and _inside(b.logging.rate, RANGES.log_rate)
        assert _inside(b.logging.current_delay, RANGES.current_delay)
        assert b.controller.servo_rate >= b.logging.rate
        # The circle sampled at 400 Hz (its joint motion is far slower).
        ref = circle_reference(dataclasses.replace(b, controller=Controller(servo_rate=400.0)))
        assert np.abs(np.sin(ref.q[:, 1])).min() >= MIN_SIN_ELBOW
        # The sweeps cover the circle's motor speeds and go below them.
        peak = np.max(np.abs(ref.qd) * [ax.gear_ratio for ax in b.axes])
        assert max(b.sweep.speeds) >= peak
        assert _inside(min(b.sweep.speeds), (0.0, RANGES.slowest_speed[1]))


def test_family_covers_every_kind_of_law_and_logger(benches: list[ScaraBench]) -> None:
    laws = [ax.friction for b in benches for ax in b.axes]
    assert sum(f.lugre is not None for f in laws) >= 10
    assert sum(f.lugre is None and f.stribeck_exponent != 2.0 for f in laws) >= 10
    assert sum(f.is_paper_law for f in laws) >= 5
    assert sum(f.viscous_negative is not None for f in laws) >= 10
    assert sum(any(h.direction != "both" for h in ax.pdtv) for b in benches for ax in b.axes) >= 10
    assert sum(b.logging.gaps > 0 for b in benches) >= 5
    assert sum(b.logging.current_delay > 0.05 for b in benches) >= 5
    assert min(b.logging.rate or 0 for b in benches) < 400
    assert max(b.logging.rate or 0 for b in benches) > 2500


# -- the logger ----------------------------------------------------------------------------


def test_logged_ticks_rate_jitter_and_gaps() -> None:
    rng = np.random.default_rng(2)
    lg = Logging(rate=300.0, jitter=0.3, gaps=2, gap_durations=(0.05, 0.09))
    k = logged_ticks(40001, 2000.0, lg, rng)
    t = k / 2000.0
    step = np.diff(t)
    assert step.min() > 0
    # 0.3 of a period either side: steps between 0.4 and 1.6 periods, or a gap.
    normal = step[step < 0.04]
    assert normal.min() >= 0.4 / 300 - 1 / 2000 and normal.max() <= 1.6 / 300 + 1 / 2000
    gaps = step[step >= 0.04]
    assert 1 <= gaps.size <= 2 and gaps.max() <= 0.09 + 2 / 300
    assert k.size == pytest.approx(20 * 300 - 0.14 * 300, rel=0.02)
    assert k[0] == 0 and k[-1] == 40000


def test_delayed_current_is_the_current_of_an_earlier_tick() -> None:
    b = _one_joint_sweep(random_bench(3), revolutions=0.5)
    quiet = tuple(dataclasses.replace(ax, current_noise=0.0) for ax in b.axes)
    b = dataclasses.replace(
        b, axes=(quiet[0], quiet[1]), logging=Logging(current_delay=0.02)
    )  # every tick, 20 ms late
    run = simulate_sweep(b, rng=0)
    m = round(0.02 * b.controller.servo_rate)
    assert_allclose(run.current_tick, np.maximum(run.tick - m, 0))
    kt = np.array([ax.torque_constant for ax in b.axes])
    # Noise-free: the logged current is exactly the true current m ticks earlier.
    assert_allclose(run.current[m:] * kt, run.motor_torque[:-m], rtol=1e-15)
    assert delayed_ticks(np.array([3]), 1000.0, 0.01).tolist() == [0]


# -- engine, files and CLI on a shortened random bench ---------------------------------------


def _short_bench(b: ScaraBench) -> ScaraBench:
    fast = max(b.sweep.speeds)
    return dataclasses.replace(
        b,
        sweep=Sweep(
            speeds=(fast / 2,),
            revolutions=1.0,
            acceleration=b.sweep.acceleration,
            elbow_angles=b.sweep.elbow_angles[:2],
            fast_speeds=0,
            dwell=0.1,
        ),
        circle=dataclasses.replace(b.circle, turns=0.25, ramp=0.5, hold=0.2),
    )


def _one_joint_sweep(b: ScaraBench, *, revolutions: float) -> ScaraBench:
    """Joint a forward and back at a third of the fastest speed, nothing else."""
    sweep = Sweep(
        speeds=(max(b.sweep.speeds) / 3,),
        revolutions=revolutions,
        acceleration=b.sweep.acceleration,
        elbow_angles=b.sweep.elbow_angles[:1],
        fast_speeds=0,
        dwell=0.1,
    )
    return dataclasses.replace(b, sweep=sweep)


def test_engine_lugre_axis_at_constant_speed_feels_the_stribeck_curve() -> None:
    b = _one_joint_sweep(random_bench(3), revolutions=2.0)
    b = dataclasses.replace(b, axes=(dataclasses.replace(b.axes[0], friction=LUGRE), b.axes[1]))
    b = dataclasses.replace(b, logging=Logging())
    ref = sweep_reference(b)
    run = simulate_sweep(b, rng=1)
    moving = (ref.qd[:, 0] != 0) & (ref.qdd[:, 0] == 0)
    edges = np.flatnonzero(np.diff(moving.astype(int)))
    checked = 0
    for start, stop in zip(edges[::2] + 1, edges[1::2] + 1, strict=True):
        a = start + (stop - start) // 3  # settled (the loop's transient is ~0.1 s)
        speed = ref.qd[start, 0] * b.axes[0].gear_ratio
        # The friction the engine applied (LuGre, at the true speed) averages to the static law
        # at the cruise speed; the speed ripple from PDTV moves it by under 1 %.
        got = float(np.mean(run.friction[a:stop, 0]))
        assert got == pytest.approx(_static(np.array([speed]), LUGRE)[0], rel=0.01)
        checked += 1
    assert checked == 2


@pytest.fixture(scope="module")
def short_random(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("random_bench")
    b = _short_bench(random_bench(2))  # two gaps, 45 ms delay, ~540 Hz log
    from torquemap.sim.bench import write_scara_bench

    write_scara_bench(out, seed=2, bench=b)
    return out


def test_random_bench_files(short_random: Path) -> None:
    truth = load_model(short_random / "truth.toml")
    b = random_bench(2)
    assert [j.gear_ratio for j in truth.robot.joints] == [ax.gear_ratio for ax in b.axes]
    assert truth.notes["bench"]["random_seed"] == 2
    assert truth.notes["joints"]["a"]["channel_delay"] == b.logging.current_delay
    laws = truth.notes["bench"].get("friction", {})
    for ax in b.axes:
        assert (ax.name in laws) == (not ax.friction.is_paper_law)
    log = read_table(short_random / "circle.csv")
    step = np.diff(log["t"])
    assert step.min() > 0
    assert np.median(step) == pytest.approx(1 / b.logging.rate, rel=0.1)
    tr = read_table(short_random / "truth.csv")
    assert_allclose(tr["t"], log["t"])
    assert_allclose(np.hypot(tr["fx"], tr["fy"]), b.circle.spring_force, rtol=0.05)


def test_cli_random_writes_a_random_bench(
    short_random: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.setattr(family, "random_bench", lambda seed: _short_bench(random_bench(seed)))
    out = tmp_path / "r"
    assert main(["simulate", "scara", "--random", "2", "--out", str(out)]) == 0
    # Same seed: same bytes as the library with the same (shortened) bench and noise seed.
    for name in ("robot.toml", "sweep.csv", "circle.csv", "truth.csv", "truth.toml"):
        assert (out / name).read_bytes() == (short_random / name).read_bytes(), name
    assert "truth.toml" in capsys.readouterr().out
    assert main(["simulate", "scara", "--random", "-1", "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert "--random" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()


def test_simulate_bench_in_memory_matches_the_files(short_random: Path) -> None:
    files = simulate_bench(_short_bench(random_bench(2)), seed=2)
    log = read_table(short_random / "sweep.csv")
    # CSV holds float64 text to full precision: a round trip is exact.
    for name, col in files.sweep.items():
        assert_allclose(log[name], col, rtol=0, atol=0)


def test_true_friction_is_a_friction_law() -> None:
    from torquemap.friction_law import FrictionLaw
    from torquemap.sim.truth_law import TrueFriction

    law = TrueFriction(LUGRE)
    assert isinstance(law, FrictionLaw)
    w = np.linspace(-6, 6, 101)
    # The linear view reproduces the static law (two implementations of it).
    assert_allclose(law.basis(w) @ law.linear_parameters(), friction_torque(w, LUGRE), atol=1e-15)
    again = law.with_linear_parameters(law.linear_parameters() * 2)
    assert_allclose(again.torque(w), 2 * (law.basis(w) @ law.linear_parameters()), atol=1e-15)
    # With time, the LuGre law integrates its bristles: the same as lugre_response.
    t = np.arange(w.size) * 1e-3
    assert_allclose(law.torque(w, t=t), lugre_response(t, w, LUGRE).torque, rtol=1e-15)
