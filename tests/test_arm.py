"""Identification and estimation of an arm with rigid-body dynamics, on logs simulated here.

The logs are made by inverse dynamics of a TRUE arm (the URDF's links with a 10 % heavier upper
arm and a 0.5 kg tool the URDF lacks), through gears with rotor inertia, friction of the law's
form, a PDTV line and current noise; the identified parameters are compared with the truth
they were simulated from, and the estimated wrench with the force applied.
"""

from __future__ import annotations

import dataclasses
from inspect import signature
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.errors import InputError
from torquemap.estimate_arm import ArmEstimate, estimate_arm, momentum_observer
from torquemap.excite import exciting_trajectory
from torquemap.friction_law import StribeckFriction
from torquemap.identify_arm import body_consistency, identify_arm
from torquemap.io import Log
from torquemap.model import InertiaModel, JointModel, Model, PdtvLine, pdtv_torque
from torquemap.robot import Joint, Robot
from torquemap.robots.urdf import UrdfArm, urdf_arm

# one worker runs the module (pytest -n 2 --dist loadgroup), so its module fixture `bench`
# is built once, not once per worker
pytestmark = pytest.mark.xdist_group("arm")

TWO_LINK = Path(__file__).parent / "data" / "arm" / "two_link.urdf"
GEAR = (60.0, 40.0)
KT = 0.1
ARMATURE = (2e-5, 1e-5)  # motor side [kg m^2]
NOISE = 0.02  # current noise [A]
TOOL = 0.5  # [kg] at the tip, 0.3 m along the forearm


def _law(coulomb: float) -> StribeckFriction:
    return StribeckFriction(
        coulomb_positive=coulomb,
        coulomb_negative=1.2 * coulomb,
        viscous=2e-4,
        stribeck_positive=0.3 * coulomb,
        stribeck_negative=0.3 * coulomb,
        stribeck_velocity=5.0,
        zero_velocity=0.5,
        transition="smooth",
    )


def _true_arm(nominal: UrdfArm) -> UrdfArm:
    pi = nominal.full_parameters.copy()
    pi[:10] *= 1.1  # upper arm 10 % heavier, same centre of mass and shape
    tip = np.array([0.3, 0.0, 0.0])
    pi[10] += TOOL
    pi[11:14] += TOOL * tip
    pi[4 + 10] += TOOL * (tip[1] ** 2 + tip[2] ** 2)  # point mass: Ixx, Iyy, Izz about the joint
    pi[6 + 10] += TOOL * (tip[0] ** 2 + tip[2] ** 2)
    pi[9 + 10] += TOOL * (tip[0] ** 2 + tip[1] ** 2)
    return nominal.with_full_parameters(pi)


def _robot(arm: UrdfArm) -> Robot:
    joints = tuple(
        Joint(name=n, gear_ratio=g, torque_constant=KT)
        for n, g in zip(arm.joint_names, GEAR, strict=True)
    )
    return Robot(name="two-link", kinematics="urdf", link_lengths=(), joints=joints, arm=arm)


def _joint_models(friction: bool) -> dict[str, JointModel]:
    out = {}
    for k, name in enumerate(("shoulder", "elbow")):
        law = (
            _law(0.03 if k == 0 else 0.02)
            if friction
            else _law(0.0).with_linear_parameters(np.zeros(5))
        )
        pdtv = (PdtvLine(order=2.0, amplitude=0.004, phase=0.3),) if (friction and k == 0) else ()
        out[name] = JointModel(
            inertia=InertiaModel(constant=ARMATURE[k] if friction else 0.0), friction=law, pdtv=pdtv
        )
    return out


def _simulate(
    arm: UrdfArm, seed: int, *, force: bool, duration: float = 20.0
) -> tuple[Log, np.ndarray]:
    """A log at 1 kHz and the force [N] on the end effector (zeros when ``force`` is False)."""
    traj = exciting_trajectory(
        arm, duration=duration, period=10.0, rate=1000.0, iterations=10, rng=seed
    )
    t, q, qd, qdd = traj.t, traj.q, traj.qd, traj.qdd
    rng = np.random.default_rng(seed)
    F = np.zeros((t.size, 3))
    if force:
        F[:, 0] = 4.0 + 2.0 * np.sin(0.5 * t)
        F[:, 1] = -3.0 + np.cos(0.3 * t)
    tau_ext = np.einsum("nij,ni->nj", arm.jacobian(q), F)
    joints = _joint_models(friction=True)
    tau_m = np.empty_like(q)
    rigid = arm.inverse_dynamics(q, qd, qdd)
    for k, name in enumerate(arm.joint_names):
        n = GEAR[k]
        jm = joints[name]
        tau_m[:, k] = (
            (rigid[:, k] - tau_ext[:, k]) / n
            + jm.inertia.constant * n * qdd[:, k]
            + jm.friction.torque(n * qd[:, k])
            + pdtv_torque(n * q[:, k], jm.pdtv)
            + KT * NOISE * rng.standard_normal(t.size)
        )
    log = Log(t=t, q=q, motor_torque=tau_m, joint_names=arm.joint_names, path="sim.csv")
    return log, F


@pytest.fixture(scope="module")
def bench() -> dict[str, object]:
    nominal = urdf_arm(
        TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0.0, -9.81, 0.0)
    )
    true_arm = _true_arm(nominal)
    free, _ = _simulate(true_arm, 1, force=False)
    task, force = _simulate(true_arm, 2, force=True)
    start = Model(robot=_robot(nominal), joints=_joint_models(friction=False) | {})
    # the laws start at the truth's shape (the shape search then refines it)
    start = dataclasses.replace(
        start,
        joints={n: dataclasses.replace(jm, friction=_law(0.0)) for n, jm in start.joints.items()},
    )
    result = identify_arm(start, [free], max_samples=3000, pdtv_max_order=4)
    oracle = Model(robot=_robot(true_arm), joints=_joint_models(friction=True))
    # the identified model's estimate of the task with every option at its default, which
    # five tests read (each estimated it alike before: 0.7 s each)
    estimate = estimate_arm(result.model, task)
    return {
        "nominal": nominal,
        "true": true_arm,
        "start": start,
        "result": result,
        "oracle": oracle,
        "task": task,
        "force": force,
        "free": free,
        "estimate": estimate,
    }


def test_identification_recovers_the_simulated_arm(bench: dict[str, object]) -> None:
    from torquemap.identify_arm import ArmIdentification

    result = bench["result"]
    true_arm = bench["true"]
    nominal = bench["nominal"]
    assert isinstance(result, ArmIdentification)
    assert isinstance(true_arm, UrdfArm) and isinstance(nominal, UrdfArm)
    arm = result.model.robot.arm
    assert isinstance(arm, UrdfArm)
    beta, truth, urdf = arm.parameters(), true_arm.parameters(), nominal.parameters()
    p = beta.size
    sigma = np.sqrt(np.diag(result.covariance)[:p])
    # every base parameter within 4 sigma of the truth it was simulated from ...
    assert np.all(np.abs(beta - truth) < 4 * sigma + 1e-9), (beta, truth, sigma)
    # ... and the tool the URDF lacks is found: elbow.mx moves by m_tool * 0.3 m = 0.15 kg m
    named = dict(zip(arm.parameter_names, beta, strict=True))
    assert_allclose(
        named["elbow.mx"] - dict(zip(arm.parameter_names, urdf, strict=True))["elbow.mx"],
        0.15,
        atol=0.005,
    )
    # the elbow's rotor inertia is recovered (motor side); the shoulder's shows in joint 1 only,
    # as the shoulder's ZZ1R does, so only their sum (joint side) is identifiable
    joints = result.model.joints
    assert_allclose(joints["elbow"].inertia.constant, ARMATURE[1], rtol=0.05)
    total = named["shoulder.Izz"] + GEAR[0] ** 2 * joints["shoulder"].inertia.constant
    truth_total = dict(zip(arm.parameter_names, truth, strict=True))["shoulder.Izz"]
    assert_allclose(total, truth_total + GEAR[0] ** 2 * ARMATURE[0], rtol=0.01)
    for k, name in enumerate(("shoulder", "elbow")):
        jm = joints[name]
        truth_law = _law(0.03 if k == 0 else 0.02)
        assert_allclose(jm.friction.static_levels(), truth_law.static_levels(), rtol=0.05)
    lines = result.model.joints["shoulder"].pdtv
    assert [ln.order for ln in lines] == [2.0]
    assert_allclose(lines[0].amplitude, 0.004, rtol=0.1)
    assert result.consistent
    # the residual is the current noise (K_t * 0.02 A), smoothed by the differentiator kernel
    assert np.all(result.residual_sigma < KT * NOISE)


def test_estimated_wrench_beats_the_urdf_as_given(bench: dict[str, object]) -> None:
    task = bench["task"]
    force = bench["force"]
    result = bench["result"]
    assert isinstance(task, Log) and isinstance(force, np.ndarray)

    def rms_of(est: ArmEstimate) -> float:
        assert est.wrench_axes == ("fx", "fy", "fz")
        ok = _sound(est.flag)
        err = est.wrench[ok, :2] - force[ok, :2]
        return float(np.sqrt(np.mean(np.sum(err**2, axis=1))))

    def rms(model: Model, method: str, zero_phase: bool = False) -> float:
        return rms_of(estimate_arm(model, task, method=method, zero_phase=zero_phase))  # type: ignore[arg-type]

    oracle = bench["oracle"]
    start = bench["start"]
    assert isinstance(oracle, Model) and isinstance(start, Model)
    identified = result.model  # type: ignore[attr-defined]
    e_oracle = rms(oracle, "acceleration")
    assert isinstance(bench["estimate"], ArmEstimate)
    assert signature(estimate_arm).parameters["method"].default == "acceleration"
    e_ident = rms_of(bench["estimate"])  # identified's, by acceleration (the default)
    e_urdf = rms(start, "acceleration")
    e_momentum = rms(identified, "momentum", zero_phase=True)
    # the force is 5 N; the URDF as given misses the tool, friction and armature (18.7 N);
    # noise and the 2 Hz low-pass leave 0.16 N with the true model
    assert e_ident < 1.2 * e_oracle
    assert e_urdf > 20 * e_ident
    # forward-backward observer: a gentler low-pass than the Butterworth (0.37 N)
    assert e_momentum < 0.5


def test_sigmas_cover_the_errors(bench: dict[str, object]) -> None:
    from torquemap.filters import lowpass

    task, force, true_arm = bench["task"], bench["force"], bench["true"]
    assert isinstance(task, Log) and isinstance(force, np.ndarray)
    assert isinstance(true_arm, UrdfArm)
    est = bench["estimate"]  # estimate_arm(result.model, task)
    assert isinstance(est, ArmEstimate)
    # the sigmas cover noise and parameter errors, not the 2 Hz low-pass's own attenuation of
    # fast changes: compare with the true external torque through that same low-pass
    tau = np.einsum("nij,ni->nj", true_arm.jacobian(task.q), force)
    target = np.column_stack([lowpass(task.t, tau[:, k], cutoff=est.cutoff) for k in range(2)])
    ok = _sound(est.flag)
    z = np.abs(est.tau_ext[ok] - target[ok]) / est.tau_ext_sigma[ok]
    share = float(np.mean(z < 2))
    # honest sigmas hold about 95 % of the errors within 2 sigma
    assert 0.9 < share < 0.995, share


def test_long_run_ratio_counts_correlated_rows() -> None:
    """White rows: 1; each row the sum of L consecutive white draws (a moving sum, whose
    autocovariances sum to L times its variance, a closed form): about L. 200 stretches of
    1 s: the estimate's relative standard error is about sqrt(2 / 200) = 0.1."""
    from torquemap.arm_model import ArmSignals
    from torquemap.identify_arm import long_run_ratio

    rng = np.random.default_rng(5)
    n, L = 20000, 8
    t = np.arange(n) * 0.01
    white = rng.standard_normal(n + L)
    moving = np.convolve(white, np.ones(L), mode="valid")[:n]
    sig = ArmSignals(
        t=t,
        q=np.zeros((n, 2)),
        qd=np.zeros((n, 2)),
        qdd=np.zeros((n, 2)),
        q_measured=np.zeros((n, 2)),
        motor_torque=np.zeros((n, 2)),
        gear=np.ones(2),
        window=0.05,
    )
    ratio = long_run_ratio(np.column_stack([white[:n], moving]), [sig], [np.arange(n)])
    assert_allclose(ratio, [1.0, L], rtol=0.3)


def test_extrapolation_is_warned_and_widens_the_sigmas(bench: dict[str, object]) -> None:
    """A log at poses and speeds the identification did not see: the estimate warns, its
    sigmas grow there, and the reach is the distance beyond the range in units of its width
    (the definition, checked on the log's own angles); the same with a model whose recorded
    range is cut (the shoulder to +-0.5 rad) and whose speeds are 100 times the log's."""
    task, result = bench["task"], bench["result"]
    assert isinstance(task, Log)
    model = result.model  # type: ignore[attr-defined]
    free = bench["free"]
    assert isinstance(free, Log)
    base = bench["estimate"]  # estimate_arm(model, task)
    assert isinstance(base, ArmEstimate)
    # the task's elbow bends 0.66 rad further than the free log's did (other seeds, other
    # paths): warned, with the distance the two logs show
    text = " ".join(base.warnings)
    assert "outside those the model was identified from (elbow up to" in text, text
    reported = float(text.split("(elbow up to ")[1].split(" rad")[0])
    assert_allclose(reported, free.q[:, 1].min() - task.q[:, 1].min(), atol=0.02)
    info = dict(model.notes["arm"])
    lo, hi = np.array(info["position_range"]).T
    assert_allclose(lo, free.q.min(axis=0), atol=0.02)  # of the samples drawn, smoothed
    assert_allclose(hi, free.q.max(axis=0), atol=0.02)
    narrow = [[-0.5, 0.5], [float(lo[1]), float(hi[1])]]  # the shoulder's range cut
    # as if the identification had turned the motors 100 times faster than it did: near
    # a speed v it then saw about 1/100 of the share of samples the log holds there
    faster = [[100.0 * v for v in row] for row in info["motor_speed_quantiles"]]
    cut = dataclasses.replace(
        model,
        notes={
            **model.notes,
            "arm": {**info, "position_range": narrow, "motor_speed_quantiles": faster},
        },
    )
    est = estimate_arm(cut, task)
    text = " ".join(est.warnings)
    assert "outside those the model was identified from (shoulder up to" in text
    assert "the friction is extrapolated to motor speeds the identification saw 10 times" in text
    assert "shoulder in" in text
    expected = np.maximum(np.abs(est.q[:, 0]) - 0.5, 0.0) / 1.0
    elbow = np.maximum(est.q[:, 1] - hi[1], lo[1] - est.q[:, 1]) / (hi[1] - lo[1])
    expected = np.maximum(expected, elbow)
    assert_allclose(est.extrapolation, np.maximum(expected, 0.0), atol=1e-12)
    assert np.all(est.tau_ext_sigma >= base.tau_ext_sigma * (1 - 1e-12))
    outside = est.extrapolation > 0.5
    assert outside.any()
    assert np.all(est.tau_ext_sigma[outside, 0] > base.tau_ext_sigma[outside, 0])
    assert_allclose(est.tau_ext, base.tau_ext)  # the estimate itself is unchanged


def test_a_turn_further_is_no_extrapolation(bench: dict[str, object]) -> None:
    """A revolute joint's pose repeats every turn: the task log with the shoulder one turn
    up and the elbow one turn down (encoders counting turns, a continuous joint) is the
    same motion; the rigid-body torques are equal (Pinocchio at q and q + 2 pi), and so are
    the estimate, its sigmas, its reach and its warnings (the elbow's real 0.66 rad beyond
    the identified range is still reported, not 2 pi more)."""
    task, result = bench["task"], bench["result"]
    assert isinstance(task, Log)
    model = result.model  # type: ignore[attr-defined]
    arm = model.robot.arm
    turn = np.array([2.0 * np.pi, -2.0 * np.pi])
    assert_allclose(arm.angle_period, 2.0 * np.pi)
    q, qd = task.q[::500], np.ones_like(task.q[::500])
    # the same rigid bodies one turn on: equal up to the rounding of cos and sin (1e-15)
    assert_allclose(
        arm.inverse_dynamics(q + turn, qd, qd), arm.inverse_dynamics(q, qd, qd), atol=1e-10
    )
    base = bench["estimate"]  # estimate_arm(model, task)
    assert isinstance(base, ArmEstimate)
    shifted = estimate_arm(model, dataclasses.replace(task, q=task.q + turn))
    assert shifted.warnings == base.warnings
    assert_allclose(shifted.extrapolation, base.extrapolation, atol=1e-9)
    # rounding relative to the sigmas' scale, not each sample's: where a sigma is small the
    # turn's rounding reads 1.8e-9 of it (numpy 2.4.6, scipy 1.17.1; under 1e-9 before), 4.5e-11
    # absolute against sigmas up to 2.5
    scale = float(np.nanmax(np.abs(base.tau_ext_sigma)))
    assert_allclose(shifted.tau_ext_sigma, base.tau_ext_sigma, rtol=0, atol=1e-9 * scale)
    assert_allclose(shifted.wrench, base.wrench, atol=1e-9)


def test_a_prismatic_joint_does_not_repeat(tmp_path: Path) -> None:
    """A slide's pose never repeats: its distance from the identified range is the plain
    one, a revolute joint's the distance to the range's nearest turn (closed forms)."""
    from torquemap.estimate_arm import _beyond_range

    text = TWO_LINK.read_text().replace(
        'name="elbow" type="revolute"', 'name="elbow" type="prismatic"'
    )
    assert 'type="prismatic"' in text
    (tmp_path / "slide.urdf").write_text(text)
    arm = urdf_arm(tmp_path / "slide.urdf", ["shoulder", "elbow"], end_effector="tool")
    assert_allclose(arm.angle_period, [2.0 * np.pi, np.inf])
    q = np.array([[1.0, 1.0], [5.0, 5.0], [-0.6, -0.6], [6.0, 6.0]])
    lo, hi = np.array([-0.5, -0.5]), np.array([0.5, 0.5])
    beyond = _beyond_range(q, lo, hi, arm.angle_period)
    # 5 rad turns as -1.28 rad: 0.78 rad below the range; 6 rad as -0.28 rad: inside it
    assert_allclose(beyond[:, 0], [0.5, 2.0 * np.pi - 5.0 - 0.5, 0.1, 0.0], atol=1e-12)
    assert_allclose(beyond[:, 1], [0.5, 4.5, 0.1, 5.5], atol=1e-12)
    # a range of a full turn or more holds every pose
    assert_allclose(_beyond_range(q, lo - 3.2, hi + 3.2, arm.angle_period)[:, 0], 0.0)


def _sound(flag: np.ndarray) -> np.ndarray:
    ok = flag == 0
    ok[:2000] = ok[-2000:] = False  # the filters' start-up and end effects
    return ok


def test_friction_shape_is_fitted_from_the_data(bench: dict[str, object]) -> None:
    """From the robot file's default law (linear transition 1e-3 rad/s, Stribeck 1 rad/s,
    exponent 2) the shape search finds the simulated law's (smooth 0.5 rad/s, Stribeck 5 rad/s,
    exponent 2), and the wrench is as good as with the true shape given; keeping the default
    shape is far worse."""
    free, task, force = bench["free"], bench["task"], bench["force"]
    start = bench["start"]
    assert isinstance(free, Log) and isinstance(task, Log) and isinstance(force, np.ndarray)
    assert isinstance(start, Model)
    default = dataclasses.replace(
        start,
        joints={
            n: dataclasses.replace(jm, friction=StribeckFriction())
            for n, jm in start.joints.items()
        },
    )
    fitted = identify_arm(default, [free], max_samples=1500, pdtv_max_order=4)
    for name in ("shoulder", "elbow"):
        law = fitted.model.joints[name].friction
        assert isinstance(law, StribeckFriction)
        assert law.transition == "smooth" and law.stribeck_exponent == 2.0
        assert_allclose(law.zero_velocity, 0.5, rtol=0.25)
        assert_allclose(law.stribeck_velocity, 5.0, rtol=0.25)

    def rms_of(est: ArmEstimate) -> float:
        ok = _sound(est.flag)
        return float(np.sqrt(np.mean(np.sum((est.wrench[ok, :2] - force[ok, :2]) ** 2, axis=1))))

    def rms(model: Model) -> float:
        return rms_of(estimate_arm(model, task))

    kept = identify_arm(
        default, [free], max_samples=1500, pdtv_max_order=4, fit_friction_shape=False
    )
    e_fitted = rms(fitted.model)
    true_shape = bench["estimate"]  # estimate_arm(bench["result"].model, task): the true shape
    assert isinstance(true_shape, ArmEstimate)
    assert e_fitted < 1.15 * rms_of(true_shape)
    assert rms(kept.model) > 2.0 * e_fitted


def test_consistent_parameters_is_the_nearest_consistent_point() -> None:
    """The barrier method against a second algorithm (SLSQP on the smallest eigenvalue of the
    pseudo-inertia), on one body made inconsistent: a consistent result, no farther in the
    covariance metric than SLSQP's."""
    from scipy.optimize import minimize

    from torquemap.identify_arm import _pseudo_inertia, consistent_parameters

    nominal = urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool")
    pi0 = nominal.full_parameters[10:20].copy()
    rng = np.random.default_rng(3)
    A = rng.standard_normal((10, 10))
    cov = A @ A.T * 1e-4 + np.diag(np.abs(pi0) + 1e-3) ** 2 * 0.05
    estimate = pi0.copy()
    estimate[9] -= 0.05  # Izz below what the mass and centre of mass need
    assert body_consistency(estimate, ["elbow"])
    got = consistent_parameters(estimate, cov, pi0)
    assert not body_consistency(got, ["elbow"])
    H = np.linalg.inv(cov)

    def cost(p: np.ndarray) -> float:
        return float((p - estimate) @ H @ (p - estimate))

    ref = minimize(
        cost,
        pi0,
        jac=lambda p: 2.0 * H @ (p - estimate),
        method="SLSQP",
        constraints=[{"type": "ineq", "fun": lambda p: np.linalg.eigvalsh(_pseudo_inertia(p))[0]}],
        options={"maxiter": 50, "ftol": 1e-12},
    )
    assert np.linalg.eigvalsh(_pseudo_inertia(ref.x))[0] > -1e-6
    assert cost(got) <= cost(ref.x) * (1 + 1e-3) + 1e-6
    assert cost(got) < cost(pi0)


def test_momentum_observer_is_a_first_order_lag() -> None:
    # a step of external torque at t = 0.5 s on a unit inertia at rest: p = integral of tau
    t = np.arange(3001) * 1e-3
    tau = np.where(t >= 0.5, 2.0, 0.0)
    p = np.concatenate([[0.0], np.cumsum(tau[:-1] * np.diff(t))])[:, None]
    K = 20.0
    r = momentum_observer(t, p, np.zeros((t.size, 1)), gain=K)
    expected = np.where(t >= 0.5, 2.0 * (1 - np.exp(-K * (t - 0.5))), 0.0)
    # the discretisation is exact for a torque held over each step: only rounding remains
    assert_allclose(r[:, 0], expected, atol=1e-9)


def test_consistency_check_names_the_body() -> None:
    pi = np.zeros(20)
    pi[0], pi[4], pi[6], pi[9] = 1.0, 0.01, 0.01, 0.01
    pi[10] = -0.5
    problems = body_consistency(pi, ["a", "b"])
    assert problems == ["body b: mass -0.5 kg is not positive"]
    pi[10], pi[14], pi[16], pi[19] = 1.0, 0.01, 0.01, 0.05  # Izz > Ixx + Iyy
    assert "triangle" in body_consistency(pi, ["a", "b"])[0]


def test_arm_needed() -> None:
    robot = Robot(name="", kinematics="none", link_lengths=(), joints=(Joint("a", 10.0, 0.1),))
    model = Model(robot=robot, joints={"a": JointModel()})
    log = Log(
        t=np.arange(10.0),
        q=np.zeros((10, 1)),
        motor_torque=np.zeros((10, 1)),
        joint_names=("a",),
        path="x.csv",
    )
    with pytest.raises(InputError, match="rigid-body dynamics"):
        identify_arm(model, [log])
    with pytest.raises(InputError, match="rigid-body dynamics"):
        estimate_arm(model, log)


def test_cli_identify_and_estimate(
    bench: dict[str, object], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from torquemap.cli.main import main
    from torquemap.io import read_table, write_table

    (tmp_path / "two_link.urdf").write_text(TWO_LINK.read_text())
    (tmp_path / "robot.toml").write_text(
        '[robot]\nkinematics = "urdf"\nurdf = "two_link.urdf"\nend_effector = "tool"\n'
        "gravity = [0.0, -9.81, 0.0]\n"
        "[joints.shoulder]\ngear_ratio = 60\ntorque_constant = 0.1\n"
        "[joints.shoulder.friction]\nstribeck_velocity = 5.0\nzero_velocity = 0.5\n"
        'transition = "smooth"\n'
        "[joints.elbow]\ngear_ratio = 40\ntorque_constant = 0.1\n"
        "[joints.elbow.friction]\nstribeck_velocity = 5.0\nzero_velocity = 0.5\n"
        'transition = "smooth"\n'
    )
    task = bench["task"]
    assert isinstance(task, Log)
    # a short free log: 8 s of the task's motion would hold the force, so simulate one here
    nominal = bench["nominal"]
    assert isinstance(nominal, UrdfArm)
    free, _ = _simulate(_true_arm(nominal), 3, force=False, duration=6.0)
    short = Log(
        t=task.t[:4000], q=task.q[:4000], motor_torque=task.motor_torque[:4000],
        joint_names=task.joint_names, path=task.path,
    )  # fmt: skip
    for name, log in (("free.csv", free), ("task.csv", short)):
        cols = {"t": log.t}
        for k, j in enumerate(log.joint_names):
            cols[f"q_{j}"] = log.q[:, k]
            cols[f"tau_{j}"] = log.motor_torque[:, k]
        write_table(tmp_path / name, cols)
    (tmp_path / "out").mkdir()
    model = tmp_path / "out" / "model.toml"
    assert (
        main(
            ["identify", str(tmp_path / "robot.toml"), str(tmp_path / "free.csv"), "-o", str(model)]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "physically consistent" in out and "body elbow" in out
    assert 'urdf = "../two_link.urdf"' in model.read_text()
    for method in ("acceleration", "momentum"):
        forces = tmp_path / f"forces_{method}.csv"
        argv = ["estimate", str(model), str(tmp_path / "task.csv"), "-o", str(forces)]
        assert main([*argv, "--method", method]) == 0
        cols = read_table(forces)
        assert list(cols) == [
            "t", "tau_ext_shoulder", "tau_ext_elbow", "tau_ext_shoulder_sigma",
            "tau_ext_elbow_sigma", "fx", "fy", "fz", "fx_sigma", "fy_sigma", "fz_sigma", "flag",
        ]  # fmt: skip
    assert (
        main(
            [
                "estimate",
                str(model),
                str(tmp_path / "task.csv"),
                "-o",
                str(tmp_path / "f.csv"),
                "--method",
                "paper",
            ]
        )
        == 2
    )
    assert "an arm takes acceleration or momentum" in capsys.readouterr().err
    # the report of an arm model: the estimated wrench over time, one chart per axis
    html = tmp_path / "report.html"
    assert main(["report", str(model), str(tmp_path / "task.csv"), "-o", str(html)]) == 0
    text = html.read_text()
    for axis in ("fx [N]", "fy [N]", "fz [N]"):
        assert axis in text
    assert "estimate (sound samples)" in text and "no force estimate" not in text


def test_a_robot_file_at_odds_with_the_log_is_warned(bench: dict[str, object]) -> None:
    """The torque a robot file reads twice too large (a torque constant or gear ratio off by
    2x: the UR10 bench's forces came out 13 N off, without a word), and a robot file without
    the gravity the arm moves in, are warned of or refused; the arm as simulated is not
    (found on the UR10 and Tiago benches, 2026-11-27)."""
    free, start, result = bench["free"], bench["start"], bench["result"]
    assert isinstance(free, Log) and isinstance(start, Model)
    flags = ("times the URDF's", "explains only", "negative in both directions")
    assert not [w for w in result.warnings if any(f in w for f in flags)]  # type: ignore[attr-defined]
    fast = {"max_samples": 1500, "pdtv_max_order": 0, "fit_friction_shape": False}
    doubled = dataclasses.replace(free, motor_torque=2.0 * free.motor_torque)
    scaled = identify_arm(start, [doubled], **fast)  # type: ignore[arg-type]
    gains = [w for w in scaled.warnings if "times the URDF's" in w]
    assert gains and all("robot file is too large" in w for w in gains)
    arm = start.robot.arm
    assert isinstance(arm, UrdfArm)
    flat = urdf_arm(TWO_LINK, ["shoulder", "elbow"], end_effector="tool", gravity=(0, 0, 0))
    weightless = dataclasses.replace(start, robot=dataclasses.replace(start.robot, arm=flat))
    try:
        out = identify_arm(weightless, [free], **fast)  # type: ignore[arg-type]
    except InputError as exc:
        assert "negative in both directions" in str(exc) and "gravity" in str(exc)
    else:
        assert [w for w in out.warnings if "explains only" in w and "gravity" in w]


def test_a_gap_in_the_free_log_splits_it(bench: dict[str, object]) -> None:
    """0.5 s of a free log lost: the stretches on either side are identified as two logs (the
    differentiator would fit one parabola across the gap), and the fit is as good as without
    the gap (found on a UR10 log, 2026-11-27)."""
    from torquemap.identify_arm import split_at_gaps

    free, start = bench["free"], bench["start"]
    assert isinstance(free, Log) and isinstance(start, Model)
    keep = np.ones(free.t.size, dtype=bool)
    keep[8000:8500] = False
    gapped = dataclasses.replace(
        free, t=free.t[keep], q=free.q[keep], motor_torque=free.motor_torque[keep]
    )
    parts, cut = split_at_gaps([gapped], 0.05)
    assert cut == 1 and [p.t.size for p in parts] == [8000, free.t.size - 8500]
    fast = {"max_samples": 1500, "pdtv_max_order": 0, "fit_friction_shape": False}
    out = identify_arm(start, [gapped], **fast)  # type: ignore[arg-type]
    assert any("1 gaps in time longer than 0.125 s" in w for w in out.warnings)
    ref = identify_arm(start, [free], **fast)  # type: ignore[arg-type]
    assert_allclose(out.residual_sigma, ref.residual_sigma, rtol=0.2)


def test_samples_near_a_gap_in_the_task_log_are_flagged(bench: dict[str, object]) -> None:
    """0.5 s of a task log lost: the samples within the low-pass's support (1 / cutoff) of the
    gap carry flag 8 and a warning, as the other robots' estimates do; the rest do not (the
    UR10's log with a gap was all 'sound', its error near the gap 5x its sigma, 2026-11-27)."""
    result, task = bench["result"], bench["task"]
    assert isinstance(task, Log)
    keep = np.ones(task.t.size, dtype=bool)
    keep[8000:8500] = False
    gapped = dataclasses.replace(
        task, t=task.t[keep], q=task.q[keep], motor_torque=task.motor_torque[keep]
    )
    est = estimate_arm(result.model, gapped, cutoff=2.0)  # type: ignore[attr-defined]
    before, after = gapped.t[7999], gapped.t[8000]  # 7.999 s and 8.5 s
    near = ((gapped.t > before - 0.499) & (gapped.t <= before)) | (
        (gapped.t >= after) & (gapped.t < after + 0.499)
    )
    far = (gapped.t < before - 0.501) | (gapped.t > after + 0.501)
    assert np.all(est.flag[near] & 8) and not np.any(est.flag[far] & 8)
    assert any("gap in time" in w for w in est.warnings)


def test_a_constant_load_the_urdf_lacks_is_named_with_negative_friction(
    bench: dict[str, object],
) -> None:
    """A constant torque on a joint (gravity on a vertical prismatic joint the URDF leaves
    out, a spring) adds to friction one way and takes from it the other: its level at rest comes
    out negative, and the warning names that cause beside slow reversals (the Tiago's torso,
    2026-11-27)."""
    free, start, result = bench["free"], bench["start"], bench["result"]
    assert isinstance(free, Log) and isinstance(start, Model)
    levels = result.model.joints["elbow"].friction.static_levels()  # type: ignore[attr-defined]
    loaded = free.motor_torque.copy()
    loaded[:, 1] += 3.0 * max(abs(x) for x in levels)  # beyond friction: one level < 0
    fast = {"max_samples": 1500, "pdtv_max_order": 0, "fit_friction_shape": False}
    out = identify_arm(start, [dataclasses.replace(free, motor_torque=loaded)], **fast)  # type: ignore[arg-type]
    negative = [w for w in out.warnings if "elbow: identified friction at rest is negative" in w]
    assert negative and "a constant load the URDF lacks" in negative[0], out.warnings
