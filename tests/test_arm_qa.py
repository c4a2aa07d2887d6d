"""New-user QA of arms through the library (stop 35, Q37; docs/arm.md "new-user QA").

A two-link arm simulated here by inverse dynamics (the URDF's links, a 0.5 kg tool the URDF
lacks, gears, rotor inertia, friction, current noise of a known level): logs as real controllers
write them, a slower logger than the identification's and time stamped in nanoseconds.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.arm_noise import arm_noise_levels
from torquemap.errors import InputError
from torquemap.estimate_arm import estimate_arm
from torquemap.excite import exciting_trajectory
from torquemap.filters import lowpass
from torquemap.friction_law import StribeckFriction
from torquemap.identify_arm import ArmIdentification, identify_arm
from torquemap.io import Log
from torquemap.model import InertiaModel, JointModel, Model
from torquemap.robot import Joint, Robot
from torquemap.robots.urdf import UrdfArm, urdf_arm

pytestmark = pytest.mark.xdist_group("arm_qa")

TWO_LINK = Path(__file__).parent / "data" / "arm" / "two_link.urdf"
GEAR = (60.0, 40.0)
KT = 0.1
NOISE = 0.02  # [A] current noise, white per sample
TOOL = 0.5  # [kg] at the tip


def _law(coulomb: float) -> StribeckFriction:
    return StribeckFriction(
        coulomb_positive=coulomb,
        coulomb_negative=coulomb,
        viscous=2e-4,
        stribeck_positive=0.3 * coulomb,
        stribeck_negative=0.3 * coulomb,
        stribeck_velocity=5.0,
        zero_velocity=0.5,
        transition="smooth",
    )


def _arms() -> tuple[UrdfArm, UrdfArm]:
    nominal = urdf_arm(
        TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0.0, -9.81, 0.0)
    )
    pi = nominal.full_parameters.copy()
    pi[10] += TOOL  # a point mass at the forearm's origin... moved to its tip:
    tip = np.array([0.3, 0.0, 0.0])
    pi[11:14] += TOOL * tip
    pi[14] += TOOL * (tip[1] ** 2 + tip[2] ** 2)
    pi[16] += TOOL * (tip[0] ** 2 + tip[2] ** 2)
    pi[19] += TOOL * (tip[0] ** 2 + tip[1] ** 2)
    return nominal, nominal.with_full_parameters(pi)


def _robot(arm: UrdfArm) -> Robot:
    joints = tuple(
        Joint(name=n, gear_ratio=g, torque_constant=KT)
        for n, g in zip(arm.joint_names, GEAR, strict=True)
    )
    return Robot(name="two-link", kinematics="urdf", link_lengths=(), joints=joints, arm=arm)


def _simulate(arm: UrdfArm, seed: int, *, force: bool, duration: float) -> tuple[Log, np.ndarray]:
    """A log at 1 kHz and the external joint torque [N m] (zeros without ``force``)."""
    traj = exciting_trajectory(
        arm, duration=duration, period=10.0, rate=1000.0, iterations=6, rng=seed
    )
    t, q, qd, qdd = traj.t, traj.q, traj.qd, traj.qdd
    rng = np.random.default_rng(seed)
    F = np.zeros((t.size, 3))
    if force:
        F[:, 0] = 4.0 + 2.0 * np.sin(0.5 * t)
        F[:, 1] = -3.0 + np.cos(0.3 * t)
    tau_ext = np.einsum("nij,ni->nj", arm.jacobian(q), F)
    rigid = arm.inverse_dynamics(q, qd, qdd)
    tau_m = np.empty_like(q)
    for k in range(2):
        n = GEAR[k]
        tau_m[:, k] = (
            (rigid[:, k] - tau_ext[:, k]) / n
            + 2e-5 * n * qdd[:, k]
            + _law(0.03 - 0.01 * k).torque(n * qd[:, k])
            + KT * NOISE * rng.standard_normal(t.size)
        )
    return Log(t=t, q=q, motor_torque=tau_m, joint_names=arm.joint_names, path="sim.csv"), tau_ext


def _identified(arm: UrdfArm, free: Log) -> ArmIdentification:
    """``identify_arm`` from a zero start on ``arm`` (no PDTV lines) over the free log."""
    start = Model(
        robot=_robot(arm),
        joints={n: JointModel(inertia=InertiaModel(constant=0.0), friction=_law(0.0), pdtv=())
                for n in arm.joint_names},
    )  # fmt: skip
    return identify_arm(start, [free], max_samples=3000, pdtv_max_order=0)


@pytest.fixture(scope="module")
def identified() -> dict[str, object]:
    nominal, true_arm = _arms()
    free, _ = _simulate(true_arm, 1, force=False, duration=20.0)
    result = _identified(nominal, free)
    task, tau_ext = _simulate(true_arm, 2, force=True, duration=20.0)
    return {"model": result.model, "task": task, "tau_ext": tau_ext, "free": free}


def _every(log: Log, step: int) -> Log:
    return dataclasses.replace(
        log, t=log.t[::step], q=log.q[::step], motor_torque=log.motor_torque[::step]
    )


def _share_within_two_sigma(model: Model, log: Log, tau_ext: np.ndarray) -> float:
    est = estimate_arm(model, log)
    # the sigmas cover noise and parameters, not the low-pass's attenuation of the force:
    # compare with the true external torque through the same low-pass
    target = np.column_stack([lowpass(log.t, tau_ext[:, k], cutoff=est.cutoff) for k in range(2)])
    inner = (log.t > log.t[0] + 1.0) & (log.t < log.t[-1] - 1.0) & (est.flag == 0)
    z = np.abs(est.tau_ext[inner] - target[inner]) / est.tau_ext_sigma[inner]
    return float(np.mean(z < 2.0))


def test_identification_records_the_current_noise_level(identified: dict[str, object]) -> None:
    """The recorded level is the simulated white current noise: PSD = sigma^2 / (fs / 2)."""
    model = identified["model"]
    assert isinstance(model, Model)
    level = np.asarray(model.notes["arm"]["noise_high_psd"])
    # the MAD of ~15000 sliding samples holds the level to a few per cent; the friction law's
    # fit error adds a little above 20 Hz at reversals (excluded) only
    assert_allclose(level, (KT * NOISE) ** 2 / 500.0, rtol=0.1)


def test_a_slower_log_widens_the_sigmas(identified: dict[str, object]) -> None:
    """A task logged at 100 Hz (every 10th sample) holds the same noise per sample in a tenth
    of the band: its force error grows by about sqrt(10) where noise dominates, and the sigmas
    must follow (before: 62 % of the errors within 2 sigma at 100 Hz; after 96 %, as at 1 kHz)."""
    model, task, tau_ext = identified["model"], identified["task"], identified["tau_ext"]
    assert isinstance(model, Model) and isinstance(task, Log)
    assert isinstance(tau_ext, np.ndarray)
    fast = _share_within_two_sigma(model, task, tau_ext)
    slow_log = _every(task, 10)
    slow = _share_within_two_sigma(model, slow_log, tau_ext[::10])
    # honest sigmas hold about 95 % of the errors within 2 sigma at either rate
    assert 0.9 < fast < 0.995, fast
    assert 0.9 < slow < 0.995, slow
    est = estimate_arm(model, slow_log)
    assert any("sampled at 100 Hz" in w for w in est.warnings), est.warnings
    assert not any("noise above 20 Hz" in w for w in estimate_arm(model, task).warnings)


def test_noise_level_of_white_noise_is_its_psd() -> None:
    """arm_noise_levels on pure white current noise of a sliding joint: sigma^2 / (fs / 2)."""
    nominal, _ = _arms()
    robot = _robot(nominal)
    from torquemap.arm_model import arm_signals

    rng = np.random.default_rng(3)
    t = np.arange(20000) / 2000.0
    q = np.column_stack([0.5 * t, -0.3 * t])  # constant speed, both sliding
    tau = 0.004 * rng.standard_normal(q.shape)
    log = Log(t=t, q=q, motor_torque=tau, joint_names=nominal.joint_names, path="w.csv")
    zero = _law(0.0).with_linear_parameters(np.zeros(5))
    joints = {n: JointModel(inertia=InertiaModel(constant=0.0), friction=zero, pdtv=())
              for n in nominal.joint_names}  # fmt: skip
    level = arm_noise_levels(robot, joints, arm_signals(log, robot, window=0.05))
    # 2 x 20000 samples: the MAD's relative error ~ 1 %; a 5 % tolerance
    assert_allclose(level, 0.004**2 / 1000.0, rtol=0.05)


@pytest.mark.parametrize("method", ["acceleration", "momentum"])
def test_time_in_nanoseconds_is_refused_naming_the_file(
    identified: dict[str, object], method: str
) -> None:
    """Before: the acceleration method refused with `low-pass cut-off 2 Hz must be in (0,
    5e-07) Hz`, no file, no cause; the momentum observer answered every sample (exit 0)."""
    model, task = identified["model"], identified["task"]
    assert isinstance(model, Model) and isinstance(task, Log)
    ns = dataclasses.replace(task, t=np.round(task.t * 1e9), path="task_ns.csv")
    with pytest.raises(
        InputError, match=r"task_ns\.csv: .*'t' must be in seconds, not ms, us or ns"
    ):
        estimate_arm(model, ns, method=method)  # type: ignore[arg-type]


def test_identify_refuses_time_in_nanoseconds_naming_the_file(
    identified: dict[str, object],
) -> None:
    """Before: `no stretch of the logs between gaps in time lasts 4 windows` (no file, no cause)."""
    model, free = identified["model"], identified["free"]
    assert isinstance(model, Model) and isinstance(free, Log)
    ns = dataclasses.replace(free, t=np.round(free.t * 1e9), path="free_ns.csv")
    with pytest.raises(InputError, match=r"free_ns\.csv: .*not ms, us or ns"):
        identify_arm(model, [ns], max_samples=500, pdtv_max_order=0)


def test_a_log_in_degrees_is_refused_naming_the_file(identified: dict[str, object]) -> None:
    """Before: identify refused blaming gravity or gear ratios, and estimate of a 6-axis arm's
    degree log answered a median 319 N against the true 12 N with exit 0."""
    model, task, free = identified["model"], identified["task"], identified["free"]
    assert isinstance(model, Model) and isinstance(task, Log) and isinstance(free, Log)
    deg = dataclasses.replace(task, q=np.degrees(task.q), path="task_deg.csv")
    with pytest.raises(InputError, match=r"task_deg\.csv: joint \w+: .* is the log in degrees"):
        estimate_arm(model, deg)
    free_deg = dataclasses.replace(free, q=np.degrees(free.q), path="free_deg.csv")
    with pytest.raises(InputError, match=r"free_deg\.csv: .* is the log in degrees"):
        identify_arm(model, [free_deg], max_samples=500, pdtv_max_order=0)


def test_a_turn_off_is_no_unit_error(identified: dict[str, object]) -> None:
    """An encoder whose zero is a turn away (q + 2 pi) is the same pose: still estimated."""
    model, task = identified["model"], identified["task"]
    assert isinstance(model, Model) and isinstance(task, Log)
    turned = dataclasses.replace(task, q=task.q + np.array([2.0 * np.pi, -2.0 * np.pi]))
    assert_allclose(estimate_arm(model, turned).wrench, estimate_arm(model, task).wrench, atol=1e-9)


def test_a_prismatic_joints_extrapolation_is_in_metres(tmp_path: Path) -> None:
    """Before: a PR2's torso lift was warned 'up to 0.0583 rad beyond the identified range'."""
    from torquemap.arm_model import arm_signals
    from torquemap.estimate_arm import _extrapolation

    text = TWO_LINK.read_text().replace(
        'name="elbow" type="revolute"', 'name="elbow" type="prismatic"'
    )
    (tmp_path / "slide.urdf").write_text(text)
    arm = urdf_arm(tmp_path / "slide.urdf", ["shoulder", "elbow"], end_effector="tool")
    robot = _robot(arm)
    t = np.arange(2000) / 1000.0
    q = np.column_stack([0.9 * np.ones_like(t), 0.9 + 0.2 * t])  # 0.4 and 0.8 beyond 0.5
    log = Log(t=t, q=q, motor_torque=np.zeros_like(q), joint_names=arm.joint_names, path="x")
    info = {"position_range": [[-0.5, 0.5], [-0.5, 0.5]]}
    _, _, warnings = _extrapolation(info, robot, {}, arm_signals(log, robot, window=0.05))
    assert len(warnings) == 1
    assert "shoulder up to 0.4 rad, elbow up to 0.8 m beyond" in warnings[0], warnings


def test_estimate_repeats_the_identifications_misfit(identified: dict[str, object]) -> None:
    """A robot file whose gravity is not the arm's (the two-link moves in its x-y plane with
    gravity -y; the file says -z): identify warns; estimate of that model used to say nothing
    (a Talos arm on a wall: 45 N against the true 9 N, exit 0)."""
    free, task = identified["free"], identified["task"]
    assert isinstance(free, Log) and isinstance(task, Log)
    wrong = urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0, 0, -9.81))
    result = _identified(wrong, free)
    assert any("explains only" in w for w in result.warnings), result.warnings
    est = estimate_arm(result.model, task)
    assert est.warnings[0].startswith("the model's identification found it at odds"), est.warnings
    assert "check the robot file's gravity" in est.warnings[0]
    # the model identified with the right gravity carries no such warning
    model = identified["model"]
    assert isinstance(model, Model)
    assert not any("at odds" in w for w in estimate_arm(model, task).warnings)


def test_a_log_wholly_outside_the_identified_poses_asks_if_it_is_this_robot() -> None:
    from torquemap.arm_model import arm_signals
    from torquemap.estimate_arm import ANOTHER_ROBOT, _extrapolation

    nominal, _ = _arms()
    robot = _robot(nominal)
    t = np.arange(2000) / 1000.0
    info = {"position_range": [[-0.5, 0.5], [-0.5, 0.5]]}
    for shoulder, asked in ((0.9, True), (0.3 + 0.4 * t, False)):  # all outside; 62 % outside
        q = np.column_stack([shoulder * np.ones_like(t), np.zeros_like(t)])
        log = Log(
            t=t, q=q, motor_torque=np.zeros_like(q), joint_names=nominal.joint_names, path="x"
        )
        _, _, warnings = _extrapolation(info, robot, {}, arm_signals(log, robot, window=0.05))
        assert len(warnings) == 1
        assert warnings[0].endswith(ANOTHER_ROBOT) is asked, warnings


def test_an_arm_held_still_is_refused_as_such(identified: dict[str, object]) -> None:
    """A servo holding a pose jitters by a few encoder counts (0.09-0.35 rad at the motors of
    a simulated 6-axis arm, more than the 0.01 rad that marks a joint that never moves):
    before, refused as 'friction negative in both directions: check the robot file's
    gravity, gear ratios...'."""
    model, free = identified["model"], identified["free"]
    assert isinstance(model, Model) and isinstance(free, Log)
    rng = np.random.default_rng(5)
    pose = np.array([0.4, -0.8])
    jitter = 0.002 * np.cumsum(rng.standard_normal(free.q.shape), axis=0) / 100.0
    held = dataclasses.replace(free, q=pose + jitter - jitter.mean(axis=0), path="held.csv")
    assert np.all(np.ptp(held.q, axis=0) * np.array(GEAR) > 0.01)  # more than "never moves"
    with pytest.raises(InputError, match=r"held\.csv: joint shoulder only jitters about a held"):
        identify_arm(model, [held], max_samples=500, pdtv_max_order=0)


def test_spectrum_of_an_excite_log_says_what_it_needs(
    identified: dict[str, object], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An arm's free log from `torquemap excite` has no steady-speed pass. Before, spectrum
    said `no joint moves at a steady speed in the logs; identification needs constant-speed
    sweeps` (a Talos arm's log, following docs/arm.md)."""
    from torquemap.cli.main import main
    from torquemap.io import write_table

    free = identified["free"]
    assert isinstance(free, Log)
    (tmp_path / "two_link.urdf").write_text(TWO_LINK.read_text())
    (tmp_path / "robot.toml").write_text(
        '[robot]\nkinematics = "urdf"\nurdf = "two_link.urdf"\nend_effector = "tool"\n'
        "gravity = [0.0, -9.81, 0.0]\n"
        "[joints.shoulder]\ngear_ratio = 60\ntorque_constant = 0.1\n"
        "[joints.elbow]\ngear_ratio = 40\ntorque_constant = 0.1\n"
    )
    cols = {"t": free.t[:5000]}
    for k, j in enumerate(free.joint_names):
        cols[f"q_{j}"] = free.q[:5000, k]
        cols[f"tau_{j}"] = free.motor_torque[:5000, k]
    write_table(tmp_path / "free.csv", cols)
    argv = ["-q", "spectrum", str(tmp_path / "robot.toml"), str(tmp_path / "free.csv")]
    assert main([*argv, "--joint", "elbow"]) == 2
    err = capsys.readouterr().err
    assert "free.csv: joint elbow has no slow constant-speed pass" in err, err
    assert "identification needs" not in err


def _counts_robot(tmp_path: Path) -> Path:
    (tmp_path / "two_link.urdf").write_text(TWO_LINK.read_text())
    joint = "gear_ratio = {g}\ntorque_constant = 0.1\nencoder_counts_per_rev = 16384\n"
    joint += 'position_unit = "counts"\n'
    path = tmp_path / "robot.toml"
    path.write_text(
        '[robot]\nkinematics = "urdf"\nurdf = "two_link.urdf"\nend_effector = "tool"\n'
        "[joints.shoulder]\n" + joint.format(g=60) + "[joints.elbow]\n" + joint.format(g=40)
    )
    return path


@pytest.mark.parametrize("reader", ["whole", "chunks"])
def test_single_turn_counts_of_an_arm_are_refused(tmp_path: Path, reader: str) -> None:
    """Counts that wrap each motor turn hold an arm's joint angles only modulo 2 pi / N.
    Before: unwrapped from the first sample, a Talos arm's task log read every pose near zero
    (all 10 000 samples singular, exit 0); another pose would be silently wrong."""
    from torquemap.io import iter_log_chunks, read_log, write_table
    from torquemap.robot import load_robot

    robot = load_robot(_counts_robot(tmp_path))
    t = np.arange(3000) / 1000.0
    q = np.column_stack([0.8 + 0.3 * np.sin(t), -1.1 + 0.2 * np.cos(2 * t)])  # [rad]
    counts = np.floor(q * np.array([60.0, 40.0]) * 16384 / (2 * np.pi))
    cols = {"t": t, "q_shoulder": counts[:, 0], "q_elbow": counts[:, 1]}
    cols |= {"i_shoulder": np.zeros_like(t), "i_elbow": np.zeros_like(t)}
    write_table(tmp_path / "multi.csv", cols)
    # multi-turn counts: the joint angles, to a count
    assert_allclose(read_log(tmp_path / "multi.csv", robot).q, q, atol=2 * np.pi / 16384 / 40)
    wrapped = cols | {"q_shoulder": np.mod(counts[:, 0], 16384), "q_elbow": counts[:, 1]}
    write_table(tmp_path / "wrapped.csv", wrapped)
    with pytest.raises(
        InputError, match=r"wrapped\.csv: joint shoulder: q_shoulder wraps by a motor turn"
    ):
        if reader == "whole":
            read_log(tmp_path / "wrapped.csv", robot)
        else:
            list(iter_log_chunks(tmp_path / "wrapped.csv", robot, rows=700))
