"""Homing from the phases' equilibria (torquemap.linearize.homing) on the simulated free motor."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.errors import InputError
from torquemap.io import write_toml
from torquemap.linearize.homing import circular_difference, circular_mean, home_motor
from torquemap.linearize.motor import motor_spec, motor_to_dict
from torquemap.sim.free_motor import FreeMotorRig, home_on_sim
from torquemap.sim.motors import Amplifier, VariableReluctanceMotor, amplifier_current

EQ = (213, 384, 43)


def _sine_motor(**kw: object) -> VariableReluctanceMotor:
    """A VR motor whose phase torque is a pure sine about integer equilibria."""
    args: dict[str, object] = {
        "equilibrium": tuple(float(e) for e in EQ),
        "phase_offset": (0.0, 0.0, 0.0),
        "phase_gain": (1.0, 1.0, 1.0),
        "second_harmonic": 0.0,
    }
    args.update(kw)
    return VariableReluctanceMotor(**args)  # type: ignore[arg-type]


def _spec(eq: tuple[int, ...] = EQ) -> object:
    return motor_spec("sine", phases=3, positions_per_cycle=512, equilibrium_positions=eq)


def test_offset_and_hysteresis_match_the_closed_form() -> None:
    # Phase torque A sin(2 pi (e - x) / P): with friction band f the motor stops where
    # A sin(2 pi d / P) = f, d = P asin(f / A) / (2 pi) short of e on the side it came from.
    motor, amp = _sine_motor(), Amplifier()
    f = 2.0
    rig = FreeMotorRig(motor, amp, friction=f, friction_spread=0.0, encoder_offset=100.0)
    rig.x = 300.0
    result = home_motor(rig, _spec())  # type: ignore[arg-type]
    i = float(amplifier_current(255, amp))
    s = motor.saturation_current
    a = motor.peak_torque * (i**2 / math.sqrt(1 + (i / s) ** 2)) / (10.0**2 / math.sqrt(2.5625))
    d = 512 * math.asin(f / a) / (2 * math.pi)
    # integer equilibria and offset: the readings are e + 100 -+ round(d), symmetric
    np.testing.assert_array_equal(result.hysteresis, -2 * round(d))
    assert result.offset == pytest.approx(100.0, abs=1e-9)
    # one direction alone is biased by the friction: the reason for walking both ways
    one_way = circular_mean(result.forward - np.array(EQ), 512)
    assert one_way == pytest.approx(100.0 - round(d), abs=1e-9)


def test_repeatability_on_the_default_motor_is_within_the_friction_hysteresis() -> None:
    from torquemap.sim.rig import sim_rig

    ms = sim_rig("vr", rng=0).motor_spec()
    results, truth = home_on_sim(ms, sim="vr", seed=3, repeats=4)
    err = circular_difference([r.offset for r in results], truth, 512)
    # bound: the motor file's equilibria are rounded (0.5) and each reading is rounded (0.5)
    assert np.all(np.abs(err) <= 1.0)


def test_friction_the_phases_cannot_overcome_is_named() -> None:
    # bearing friction at 99 % of a phase's peak torque (linearize home --friction 0.99): the
    # phases are alive; before, the refusal asked only "a phase that produces no torque?"
    from torquemap.sim.rig import sim_rig

    ms = sim_rig("vr", rng=0).motor_spec()
    with pytest.raises(InputError, match="did not pull the motor") as info:
        home_on_sim(ms, sim="vr", seed=3, repeats=1, friction_fraction=0.99)
    assert "or a load or friction it cannot overcome?" in str(info.value)


def test_dead_phase_and_wrong_motor_file_are_input_errors() -> None:
    dead = FreeMotorRig(
        _sine_motor(phase_gain=(1.0, 0.0, 1.0)), Amplifier(), friction=1.0, friction_spread=0.0
    )
    with pytest.raises(InputError, match="phase 2 did not pull the motor") as info:
        home_motor(dead, _spec())  # type: ignore[arg-type]
    assert "pulse width" not in str(info.value)  # at full scale: the phase, not the width
    # below the amplifier's dead band (20 of 255) no phase moves the motor: the message named
    # only "a phase that produces no torque?" (QA: --pulse-width 3 on bench 323)
    live = FreeMotorRig(_sine_motor(), Amplifier(), friction=1.0, friction_spread=0.0)
    with pytest.raises(InputError, match=r"Or a pulse width \(3\) too small to move it"):
        home_motor(live, _spec(), pulse_width=3)  # type: ignore[arg-type]
    rig = FreeMotorRig(_sine_motor(), Amplifier(), friction=1.0, friction_spread=0.0)
    with pytest.raises(InputError, match="another motor"):
        home_motor(rig, _spec((213, 300, 43)))  # type: ignore[arg-type]
    two = motor_spec("two", phases=2, positions_per_cycle=512, equilibrium_positions=(0, 256))
    with pytest.raises(InputError, match="at least 3 phases"):
        home_motor(rig, two)


def test_cli_home(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from torquemap.sim.rig import sim_rig

    path = tmp_path / "motor.toml"
    write_toml(path, motor_to_dict(sim_rig("bldc", rng=0).motor_spec()))
    assert main(["linearize", "home", str(path), "--sim", "bldc", "--repeats", "1"]) == 0
    # one homing has no spread to measure (before: "repeatability: std 0.000, range 0.000")
    out = capsys.readouterr().out
    assert "repeatability: not measured by one homing (--repeats 2 or more)" in out
    assert "std" not in out
    assert main(["linearize", "home", str(path), "--sim", "bldc", "--repeats", "1", "--json"]) == 0
    import json

    summary = json.loads(capsys.readouterr().out)
    assert summary["repeatability_std"] is None and summary["range"] is None
    assert main(["linearize", "home", str(path), "--sim", "bldc", "--repeats", "2"]) == 0
    assert "repeatability: std" in capsys.readouterr().out
    assert main(["linearize", "home", str(path), "--sim", "vr"]) == 2
    assert "the simulated vr motor has 3 and 512" in capsys.readouterr().err


def test_cli_home_random_bench(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # `linearize home --random SEED` homes the family's bench SEED (the motor of `simulate rig
    # --random SEED`): the homed offset is the free motor's hidden encoder offset
    import json

    from torquemap.sim.family import random_bench
    from torquemap.sim.free_motor import free_motor_rig

    seed = next(s for s in range(100) if random_bench(s).kind == "bldc")
    bench = random_bench(seed)
    spec = bench.rig.motor_spec(ramping=bench.ramping)
    path = tmp_path / "motor.toml"
    write_toml(path, motor_to_dict(spec))
    argv = ["linearize", "home", str(path), "--random", str(seed), "--repeats", "3", "--json"]
    assert main(argv) == 0
    offset = json.loads(capsys.readouterr().out)["offset"]
    # the same power-up (seed 0) the command draws, from the simulator's side
    hidden = free_motor_rig(
        "bldc", motor=bench.rig.motor, amplifier=bench.rig.amplifier, rng=0
    ).encoder_offset
    n = spec.positions_per_cycle
    # bound: the motor file's equilibria are rounded (0.5) and each reading is rounded (0.5)
    assert abs(float(circular_difference(offset, hidden, n))) <= 1.0
    other = next(s for s in range(100) if random_bench(s).rig.phases != spec.phases)
    assert main(["linearize", "home", str(path), "--random", str(other)]) == 2
    err = capsys.readouterr().err
    assert f"random motor {other} has" in err and str(path) in err and err.count("\n") == 1
    # a bench of the same shape: homed to this file's equilibria, exit 0 (QA: bench 304's file
    # with --random 321, equilibria 1 to 2 positions apart)
    shape = (spec.phases, spec.positions_per_cycle)
    twin = next(
        s
        for s in range(seed + 1, 300)
        if (random_bench(s).rig.phases, random_bench(s).rig.positions_per_cycle) == shape
    )
    assert main(["linearize", "home", str(path), "--random", str(twin)]) == 2
    err = capsys.readouterr().err
    assert f"the motor file is 'random-{seed}'" in err and err.count("\n") == 1


def test_cli_home_refuses_tables_of_another_motor(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # tables whose equilibria are another joint's (same phases and cycle) would home the motor
    # to the wrong equilibria; like evaluate and collect, home refuses them in one line
    import dataclasses

    from torquemap.linearize.export import save_tables
    from torquemap.linearize.tables import build_tables
    from torquemap.sim.rig import sim_rig

    spec = sim_rig("vr", rng=0).motor_spec()
    path = tmp_path / "motor.toml"
    write_toml(path, motor_to_dict(spec))
    n = spec.positions_per_cycle
    p, w = np.meshgrid(np.arange(0, n, 8), np.arange(0, 256, 32), indexing="ij")
    torque = (w * (1.5 + np.cos(2 * np.pi * 3 * p / n))).ravel() / 255.0
    other = dataclasses.replace(
        spec, equilibrium_positions=tuple((e + 3) % n for e in spec.equilibrium_positions)
    )
    for name, s in (("own.npz", spec), ("other.npz", other)):
        save_tables(tmp_path / name, build_tables(s, p.ravel(), w.ravel(), torque))
    argv = ["linearize", "home", str(path), "--sim", "vr", "--repeats", "1", "--tables"]
    assert main([*argv, str(tmp_path / "own.npz")]) == 0
    capsys.readouterr()
    assert main([*argv, str(tmp_path / "other.npz")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(tmp_path / "other.npz") in err
    assert "tables are for another motor" in err and "equilibrium positions" in err
