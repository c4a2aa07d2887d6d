"""Transfer to a second joint (torquemap.linearize.transfer): recovery of known scalings."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.errors import InputError
from torquemap.io import write_toml
from torquemap.linearize.collect import CollectionSettings as Settings
from torquemap.linearize.collect import collect_characterisation
from torquemap.linearize.motor import motor_to_dict, ramped_actuation
from torquemap.linearize.tables import LinearizeData, read_data
from torquemap.linearize.transfer import TransferResult, transfer_characterisation
from torquemap.sim.rig import SimRig, sim_rig

GAINS = (1.06, 0.95, 1.02)  # the second joint's phase gains over the first's


@pytest.fixture(scope="module")
def joints(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """A first VR joint characterised coarsely, and a second one whose phases are scaled by
    GAINS and whose amplifier's dead band is 6 pulse widths wider, with a handful of rows."""
    tmp = tmp_path_factory.mktemp("transfer")
    first = sim_rig("vr", rng=1)
    spec1 = first.motor_spec()
    collect_characterisation(
        first, spec1, tmp / "first.csv", Settings(position_step=16, level_step=16, progress=False)
    )
    g = tuple(a * b for a, b in zip(first.motor.phase_gain, GAINS, strict=True))
    motor2 = dataclasses.replace(first.motor, phase_gain=g)
    amp2 = dataclasses.replace(first.amplifier, dead_band=first.amplifier.dead_band + 6.0)
    second = sim_rig("vr", rng=2, motor=motor2, amplifier=amp2)
    spec2 = second.motor_spec()
    collect_characterisation(
        second, spec2, tmp / "few.csv", Settings(position_step=43, level_step=32, progress=False)
    )
    data1 = read_data(tmp / "first.csv", spec1, kind="characterisation")
    few = read_data(tmp / "few.csv", spec2, kind="characterisation")
    return {
        "result": transfer_characterisation(spec1, data1, spec2, few),
        "tmp": tmp,
        "first": first,
        "second": second,
        "spec1": spec1,
        "spec2": spec2,
        "data1": data1,
        "few": few,
    }


def _sensed(rig: SimRig, data: LinearizeData, ramp: np.ndarray) -> np.ndarray:
    act = ramped_actuation(data.level, data.position, ramp)
    out: np.ndarray = np.maximum(rig.true_torque(data.position, act) - rig.settings.friction, 0)
    return out


def test_transfer_recovers_the_phase_gains_and_the_dead_band(joints: dict[str, object]) -> None:
    r: TransferResult = joints["result"]  # type: ignore[assignment]
    # the phases' torque ratios are GAINS; 3 % covers the sensor noise of 10 readings a row
    # and the first joint's surface interpolated between every 16th position and pulse width
    np.testing.assert_allclose(r.gain, GAINS, rtol=0.03)
    # the amplifier law x = (u - u0) / (u_max - u0): the first joint reaches the second's
    # current at w1 = u0 + (w2 - u0') (u_max - u0) / (u_max - u0'), u0' = u0 + 6: at
    # w2 = u_max / 2 that is 3.5 pulse widths lower; 2 pulse widths of slack for the fit
    top = 255.0
    u = 0.5
    v = r.pulse_offset + top * (r.pulse_scale * u + r.pulse_curve * u * (1 - u))
    expected = 20.0 + (127.5 - 26.0) * (235.0 / 229.0)
    assert v == pytest.approx(expected, abs=2.0)
    assert r.residual < 0.5 * r.residual_unchanged


def test_transfer_beats_the_first_joints_surface(joints: dict[str, object]) -> None:
    r: TransferResult = joints["result"]  # type: ignore[assignment]
    data1: LinearizeData = joints["data1"]  # type: ignore[assignment]
    truth = _sensed(joints["second"], data1, joints["spec2"].ramp)  # type: ignore[arg-type,attr-defined]
    first = _sensed(joints["first"], data1, joints["spec1"].ramp)  # type: ignore[arg-type,attr-defined]
    ok = truth > 0.1 * truth.max()
    err_transfer = np.mean(np.abs(r.torque - truth)[ok] / truth[ok])
    err_unchanged = np.mean(np.abs(first - truth)[ok] / truth[ok])
    assert err_transfer < 0.5 * err_unchanged


def test_cli_transfer_and_bad_input(
    joints: dict[str, object], capsys: pytest.CaptureFixture[str]
) -> None:
    tmp: Path = joints["tmp"]  # type: ignore[assignment]
    write_toml(tmp / "m1.toml", motor_to_dict(joints["spec1"]))  # type: ignore[arg-type]
    write_toml(tmp / "m2.toml", motor_to_dict(joints["spec2"]))  # type: ignore[arg-type]
    args = [str(tmp / n) for n in ("m1.toml", "first.csv", "m2.toml", "few.csv")]
    assert main(["linearize", "transfer", *args, "-o", str(tmp / "out.csv")]) == 0
    assert "phase gains" in capsys.readouterr().out
    assert (tmp / "out.csv").read_text().startswith("position,pulse_width,torque\n")
    bldc = sim_rig("bldc", rng=0).motor_spec()
    write_toml(tmp / "b.toml", motor_to_dict(bldc))
    with pytest.raises(InputError, match="not of the first's type"):
        transfer_characterisation(
            joints["spec1"],  # type: ignore[arg-type]
            joints["data1"],  # type: ignore[arg-type]
            bldc,
            joints["few"],  # type: ignore[arg-type]
        )
    few: LinearizeData = joints["few"]  # type: ignore[assignment]
    one = dataclasses.replace(few, position=np.zeros_like(few.position))
    with pytest.raises(InputError, match="at least 2 positions"):
        transfer_characterisation(
            joints["spec1"],  # type: ignore[arg-type]
            joints["data1"],  # type: ignore[arg-type]
            joints["spec2"],  # type: ignore[arg-type]
            one,
        )


def test_a_second_motor_file_that_misregisters_the_handful_warns(
    joints: dict[str, object], capsys: pytest.CaptureFixture[str]
) -> None:
    # the second joint's motor file with equilibria 20 positions off its own (the file of
    # another joint): the registration s(p) then misplaces the first joint's surface and the
    # transferred torque is worse than the first joint's taken unchanged, against the truth
    spec2 = joints["spec2"]
    wrong = dataclasses.replace(
        spec2,  # type: ignore[type-var]
        equilibrium_positions=tuple((e + 20) % 512 for e in spec2.equilibrium_positions),  # type: ignore[attr-defined]
    )
    r = transfer_characterisation(
        joints["spec1"],  # type: ignore[arg-type]
        joints["data1"],  # type: ignore[arg-type]
        wrong,
        joints["few"],  # type: ignore[arg-type]
    )
    data1: LinearizeData = joints["data1"]  # type: ignore[assignment]
    truth = _sensed(joints["second"], data1, spec2.ramp)  # type: ignore[arg-type,attr-defined]
    first = _sensed(joints["first"], data1, joints["spec1"].ramp)  # type: ignore[arg-type,attr-defined]
    ok = truth > 0.1 * truth.max()
    err_transfer = np.mean(np.abs(r.torque - truth)[ok] / truth[ok])
    err_unchanged = np.mean(np.abs(first - truth)[ok] / truth[ok])
    assert err_transfer > err_unchanged  # the warning's claim, checked against the truth
    assert len(r.warnings) == 1 and "misfits the handful more" in r.warnings[0]
    ok_result: TransferResult = joints["result"]  # type: ignore[assignment]
    assert ok_result.warnings == ()  # the right motor file: no warning
    tmp: Path = joints["tmp"]  # type: ignore[assignment]
    write_toml(tmp / "m1.toml", motor_to_dict(joints["spec1"]))  # type: ignore[arg-type]
    write_toml(tmp / "wrong.toml", motor_to_dict(wrong))
    args = [str(tmp / n) for n in ("m1.toml", "first.csv", "wrong.toml", "few.csv")]
    assert main(["linearize", "transfer", *args, "-o", str(tmp / "w.csv")]) == 0
    err = capsys.readouterr().err
    assert err.startswith(f"torquemap: warning: {tmp / 'wrong.toml'}: the transferred surface")
    assert err.count("\n") == 1
