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

#: conftest.py's ``_reused_builds`` (tests/_reuse.py): each distinct table build of this
#: module runs once; the CLI transfers what ``joints`` and ``auto`` did
REUSE_BUILDS = True

# one worker runs the module (pytest -n 2 --dist loadgroup), so its module fixture `joints`
# is built once, not once per worker
pytestmark = pytest.mark.xdist_group("transfer")

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


def test_a_handful_that_leaves_a_phase_unmeasured_is_refused(
    joints: dict[str, object], capsys: pytest.CaptureFixture[str]
) -> None:
    # a handful inside one phase's region (QA: the first 11 rows of a sibling's handful, at
    # positions 0 to 37 of 192) never sees phase 2: its least-squares gain was 0.000 and the
    # transferred rows had no torque where phase 2 leads, exit 0 (build then blamed them)
    few: LinearizeData = joints["few"]  # type: ignore[assignment]
    spec2 = joints["spec2"]
    n = spec2.positions_per_cycle  # type: ignore[attr-defined]
    keep = few.position < n // 6  # the first sixth: phase 1's single-phase region and below
    assert np.unique(few.position[keep]).size >= 2
    part = dataclasses.replace(
        few, position=few.position[keep], level=few.level[keep], torque=few.torque[keep]
    )
    with pytest.raises(
        InputError, match=r"few\.csv: the handful measures no position where phase 2"
    ):
        transfer_characterisation(
            joints["spec1"],  # type: ignore[arg-type]
            joints["data1"],  # type: ignore[arg-type]
            spec2,  # type: ignore[arg-type]
            part,
        )


def test_a_handful_no_scaling_predicts_is_warned(joints: dict[str, object]) -> None:
    # a second motor of the same shape but not of the first's type (QA: bench 328's handful on
    # bench 321's characterisation, both VR 3 x 128): phase gains 3.2, held-out error 41.7 %,
    # transferred tables at 82.5 % APMD against 1.14 % for its own, exit 0 and no word
    first: SimRig = joints["first"]  # type: ignore[assignment]
    data1: LinearizeData = joints["data1"]  # type: ignore[assignment]
    tmp: Path = joints["tmp"]  # type: ignore[assignment]
    motor = dataclasses.replace(
        first.motor, second_harmonic=-0.25, saturation_current=3.0, mutual_saturation=0.4
    )
    other = sim_rig("vr", rng=3, motor=motor)
    spec = other.motor_spec()
    collect_characterisation(
        other, spec, tmp / "other.csv", Settings(position_step=43, level_step=32, progress=False)
    )
    few = read_data(tmp / "other.csv", spec, kind="characterisation")
    r = transfer_characterisation(joints["spec1"], data1, spec, few)  # type: ignore[arg-type]
    lines = [w for w in r.warnings if w.startswith("no scaling of the first joint's")]
    assert len(lines) == 1 and "characterise it in full" in lines[0]
    # and the warning is right: the transferred rows are far from that joint's true torque
    truth = _sensed(other, data1, spec.ramp)
    ok = truth > 0.1 * truth.max()
    assert np.mean(np.abs(r.torque - truth)[ok] / truth[ok]) > 0.10
    # a joint of the first's type (the fixture's: gains and a wider dead band) is not warned
    same: TransferResult = joints["result"]  # type: ignore[assignment]
    assert not [w for w in same.warnings if w.startswith("no scaling")]


def test_motor_files_with_other_ramps_are_refused(joints: dict[str, object]) -> None:
    # the transferred rows are the first joint's base pulse widths through its ramp; under a
    # second motor file with another ramp they built tables at 86.9 % APMD (QA bench 305: first
    # narrow, SECOND.toml wide), with exit 0
    spec1 = joints["spec1"]
    other = "narrow" if spec1.ramping == "wide" else "wide"  # type: ignore[attr-defined]
    second: SimRig = joints["second"]  # type: ignore[assignment]
    spec2 = second.motor_spec(ramping=other)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=rf"ramp \({other}\) is not the first's"):
        transfer_characterisation(
            spec1,  # type: ignore[arg-type]
            joints["data1"],  # type: ignore[arg-type]
            spec2,
            joints["few"],  # type: ignore[arg-type]
        )


def test_the_handful_chooses_to_transfer_where_the_transfer_helps(
    joints: dict[str, object],
) -> None:
    # the fixture's second joint differs by known phase gains and a wider dead band: every
    # scaling is scored on the handful's positions it was not fitted to, and a scaling wins
    r: TransferResult = joints["result"]  # type: ignore[assignment]
    assert r.model in ("gains", "full") and r.warnings == ()
    assert r.held_out[r.model] < r.held_out["unchanged"]


def test_the_handful_keeps_the_first_joint_where_a_transfer_would_harm(
    joints: dict[str, object], capsys: pytest.CaptureFixture[str]
) -> None:
    # a second joint that IS the first motor and amplifier, its handful read through a sensor
    # 8 times noisier: the first joint's characterisation is this joint's (up to its own
    # noise), and any scaling fitted to the handful fits that noise
    first: SimRig = joints["first"]  # type: ignore[assignment]
    spec1 = joints["spec1"]
    noisy = sim_rig(
        "vr", rng=5, motor=first.motor, amplifier=first.amplifier, noise=8 * first.settings.noise
    )
    tmp: Path = joints["tmp"]  # type: ignore[assignment]
    collect_characterisation(
        noisy, spec1, tmp / "noisy.csv", Settings(position_step=43, level_step=32, progress=False)
    )  # type: ignore[arg-type]
    few = read_data(tmp / "noisy.csv", spec1, kind="characterisation")  # type: ignore[arg-type]
    data1: LinearizeData = joints["data1"]  # type: ignore[assignment]
    auto = transfer_characterisation(spec1, data1, spec1, few)  # type: ignore[arg-type]
    assert auto.model == "unchanged"
    assert (
        len(auto.warnings) == 1 and "as well (within 5 %) by the first joint's" in auto.warnings[0]
    )
    # the rows written are the first joint's, up to one common factor (the tables are blind
    # to it): its tables apply unchanged
    ratio = auto.torque / np.where(data1.torque == 0, np.nan, data1.torque)
    np.testing.assert_allclose(ratio[np.isfinite(ratio)], auto.gain[0], rtol=1e-12)
    # the choice checked against the truth: the scaling the handful's own misfit prefers is
    # farther from the joint's torque than the characterisation taken unchanged
    truth = _sensed(first, data1, spec1.ramp)  # type: ignore[attr-defined]
    ok = truth > 0.1 * truth.max()
    full = transfer_characterisation(spec1, data1, spec1, few, scaling="full")  # type: ignore[arg-type]
    assert full.residual < full.residual_unchanged  # the in-sample misfit would transfer

    def error(torque: np.ndarray, scale: float) -> float:
        return float(np.mean(np.abs(torque / scale - truth)[ok] / truth[ok]))

    unchanged_error = error(auto.torque, auto.gain[0])
    common = float(np.median(full.torque[ok] / truth[ok]))  # the tables' blindness to scale
    assert error(full.torque, common) > unchanged_error
    write_toml(tmp / "m1.toml", motor_to_dict(spec1))  # type: ignore[arg-type]
    args = [str(tmp / n) for n in ("m1.toml", "first.csv", "m1.toml", "noisy.csv")]
    assert main(["linearize", "transfer", *args, "-o", str(tmp / "w.csv")]) == 0
    captured = capsys.readouterr()
    assert "scaling unchanged" in captured.out
    assert captured.err.startswith(f"torquemap: warning: {tmp / 'm1.toml'}: the handful's")
    assert captured.err.count("\n") == 1
