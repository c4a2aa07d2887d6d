"""The simulated SCARA bench's two scenarios and its files (docs/formats.md).

``simulate_sweep`` runs scenario (a), the no-load identification sweeps; ``simulate_circle``
scenario (b), the paper's 130 mm circle about a 3.5 N spring. ``write_scara_bench`` writes
robot.toml, sweep.csv, circle.csv, truth.csv and truth.toml.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.sim.engine import EngineOutput, run_engine
from torquemap.sim.logger import delayed_ticks, logged_ticks
from torquemap.sim.scara import (
    ScaraBench,
    default_bench,
    dynamics_constants,
    joint_torque_from_force,
)
from torquemap.sim.trajectory import Reference, circle_reference, sweep_reference


@dataclass(frozen=True, slots=True, eq=False)
class SimRun:
    """One simulated run: what the log holds, and the hidden truth (for tests only).

    Every array holds the logged samples (every servo tick for the paper's bench; a jittered,
    gapped subset for a bench whose :class:`~torquemap.sim.scara.Logging` says so).

    Attributes
    ----------
    t
        Time [s], ``tick / servo_rate``, shape (n,).
    q
        Measured joint angles [rad]: quantised motor angle / gear ratio, shape (n, 2).
    current
        Measured motor currents [A] (sensor noise included), shape (n, 2).
    q_true, velocity
        True joint angle [rad] and velocity [rad/s], shape (n, 2).
    reference
        The reference the controller tracked, at every servo tick.
    tick
        Servo tick of each sample, shape (n,).
    current_tick
        Servo tick whose current each sample holds (``tick`` less the current delay).
    motor_torque
        True motor torque applied from the sample's tick to the next, ``torque_constant *
        current`` without sensor noise (ripple included: it is a real current) [N m], motor
        side, shape (n, 2). Not delayed: ``current`` holds it ``current_delay`` late.
    friction, pdtv
        True motor-side friction and PDTV torques at each sample [N m], shape (n, 2).
    force
        External force exerted by the environment (the spring) on the end effector [N], base
        frame, shape (n, 2); zero for the sweeps.
    tau_ext
        Joint-side external torque ``J(q)^T force`` [N m], shape (n, 2).
    friction_work
        Energy dissipated by friction since the start [J], shape (n,).
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    current: NDArray[np.float64]
    q_true: NDArray[np.float64]
    velocity: NDArray[np.float64]
    reference: Reference
    tick: NDArray[np.int64]
    current_tick: NDArray[np.int64]
    motor_torque: NDArray[np.float64]
    friction: NDArray[np.float64]
    pdtv: NDArray[np.float64]
    force: NDArray[np.float64]
    tau_ext: NDArray[np.float64]
    friction_work: NDArray[np.float64]


def _run(
    bench: ScaraBench, reference: Reference, *, spring: bool, rng: np.random.Generator | int | None
) -> SimRun:
    gen = np.random.default_rng(rng)
    out: EngineOutput = run_engine(bench, reference, spring=spring, rng=gen)
    rate = bench.controller.servo_rate
    k = logged_ticks(reference.t.size, rate, bench.logging, gen)
    kc = delayed_ticks(k, rate, bench.logging.current_delay)
    kt = np.array([ax.torque_constant for ax in bench.axes])
    return SimRun(
        t=reference.t[k],
        q=out.q_measured[k],
        current=out.current_measured[kc],
        q_true=out.q[k],
        velocity=out.qd[k],
        reference=reference,
        tick=k,
        current_tick=kc,
        motor_torque=out.current[k] * kt,
        friction=out.friction[k],
        pdtv=out.pdtv[k],
        force=out.force[k],
        tau_ext=joint_torque_from_force(bench, out.q[k], out.force[k]),
        friction_work=out.friction_work[k],
    )


def simulate_sweep(bench: ScaraBench, *, rng: np.random.Generator | int | None = None) -> SimRun:
    """Scenario (a): the no-load identification sweeps (:class:`torquemap.sim.scara.Sweep`).

    Parameters
    ----------
    bench
        The bench.
    rng
        Random generator or seed for the sensor noise and ripple phases.

    Returns
    -------
    SimRun
        Log columns and hidden truth.
    """
    return _run(bench, sweep_reference(bench), spring=False, rng=rng)


def simulate_circle(bench: ScaraBench, *, rng: np.random.Generator | int | None = None) -> SimRun:
    """Scenario (b): the circle tracked about the spring's anchor (:class:`~.scara.Circle`).

    Parameters
    ----------
    bench
        The bench.
    rng
        Random generator or seed for the sensor noise and ripple phases.

    Returns
    -------
    SimRun
        Log columns and hidden truth (the spring force at every sample).
    """
    return _run(bench, circle_reference(bench), spring=True, rng=rng)


def robot_document(bench: ScaraBench) -> dict[str, Any]:
    """The robot file of the bench (docs/formats.md), as a TOML-ready dict."""
    return {
        "robot": {
            "name": bench.name,
            "kinematics": "planar2r",
            "link_lengths": list(bench.links.lengths),
        },
        "joints": {
            ax.name: {
                "gear_ratio": ax.gear_ratio,
                "torque_constant": ax.torque_constant,
                "encoder_counts_per_rev": ax.encoder_counts_per_rev,
            }
            for ax in bench.axes
        },
    }


def truth_document(bench: ScaraBench, *, seed: int) -> dict[str, Any]:
    """truth.toml: a model file holding the bench's true motor-side parameters.

    Per joint ``[joints.<j>.inertia]`` (the diagonal motor-side inertia
    ``constant + cos_elbow * cos(q_b)`` the dynamics imply), ``[joints.<j>.friction]`` and
    ``[[joints.<j>.pdtv]]``; everything else under ``[identification.bench]``.

    A friction law the model file cannot hold (a LuGre law, per-direction viscous friction or
    Stribeck velocity) is written as its closest static law in the model's form (its steady
    state, with the two directions' viscous coefficients and Stribeck velocities averaged) and in full under
    ``[identification.bench.friction.<j>]``; a delayed current channel as
    ``[identification.joints.<j>] channel_delay`` (what identification records), so that the
    file used as a model undoes it.
    """
    doc = robot_document(bench)
    dc = dynamics_constants(bench)
    a, b = bench.axes
    inertia = {
        a.name: {
            "constant": dc.alpha / a.gear_ratio**2,
            "cos_elbow": 2 * dc.beta / a.gear_ratio**2,
        },
        b.name: {"constant": dc.delta_b / b.gear_ratio**2, "cos_elbow": 0.0},
    }
    for ax in bench.axes:
        f = ax.friction
        spec = doc["joints"][ax.name]
        spec["inertia"] = inertia[ax.name]
        _, _, vs_neg, visc_neg = f.direction_parameters(-1)
        spec["friction"] = {
            "coulomb_positive": f.coulomb_positive,
            "coulomb_negative": f.coulomb_negative,
            "viscous": f.viscous if f.viscous_negative is None else 0.5 * (f.viscous + visc_neg),
            "stribeck_positive": f.stribeck_positive,
            "stribeck_negative": f.stribeck_negative,
            "stribeck_velocity": f.stribeck_velocity
            if f.stribeck_velocity_negative is None
            else math.sqrt(f.stribeck_velocity * vs_neg),
            "zero_velocity": f.zero_velocity,
        }
        if f.stribeck_exponent != 2.0:
            spec["friction"]["stribeck_exponent"] = f.stribeck_exponent
        spec["pdtv"] = [
            {"order": h.order, "amplitude": h.amplitude, "phase": h.phase, "direction": h.direction}
            for h in ax.pdtv
        ]
    lk, ctl, c = bench.links, bench.controller, bench.circle
    doc["identification"] = {
        "source": "torquemap simulate scara (true parameters, not identified)",
        "bench": {
            "seed": seed,
            "link_masses": list(lk.masses),
            "link_centres_of_mass": list(lk.centres_of_mass),
            "link_inertias": list(lk.inertias),
            "rotor_inertias": [ax.rotor_inertia for ax in bench.axes],
            "coupling_inertia": [dc.delta, dc.beta],
            "current_noise": [ax.current_noise for ax in bench.axes],
            "ripple_amplitude": [ax.ripple_amplitude for ax in bench.axes],
            "ripple_frequency": [ax.ripple_frequency for ax in bench.axes],
            "servo_rate": ctl.servo_rate,
            "substeps": ctl.substeps,
            "bandwidth": ctl.bandwidth,
            "sweep_speeds": list(bench.sweep.speeds),
            "sweep_elbow_angles": list(bench.sweep.elbow_angles),
            "circle_centre": list(c.centre),
            "circle_radius": c.radius,
            "circle_angular_speed": c.angular_speed,
            "spring_anchor": list(c.centre),
            "spring_stiffness": c.spring_stiffness,
            "spring_free_length": c.free_length,
            "spring_force": c.spring_force,
        },
    }
    doc["identification"]["bench"].update(_family_notes(bench))
    delay = round(bench.logging.current_delay * ctl.servo_rate) / ctl.servo_rate
    if delay:
        doc["identification"]["joints"] = {ax.name: {"channel_delay": delay} for ax in bench.axes}
    return doc


def _family_notes(bench: ScaraBench) -> dict[str, Any]:
    """Truth notes of what departs from the paper's bench (nothing for the paper's bench)."""
    out: dict[str, Any] = {}
    if bench.random_seed is not None:
        out["random_seed"] = bench.random_seed
        out["gear_ratios"] = [ax.gear_ratio for ax in bench.axes]
        out["encoder_counts_per_rev"] = [ax.encoder_counts_per_rev for ax in bench.axes]
        out["controller_friction_feedforward"] = bench.controller.friction_feedforward
        out["sweep_revolutions"] = bench.sweep.revolutions
        out["sweep_acceleration"] = bench.sweep.acceleration
    lg = bench.logging
    if lg.rate is not None or lg.gaps or lg.current_delay:
        out["log_rate"] = lg.rate if lg.rate is not None else bench.controller.servo_rate
        out["log_jitter"] = lg.jitter
        out["log_gaps"] = lg.gaps
        out["log_gap_durations"] = list(lg.gap_durations)
        out["current_delay"] = lg.current_delay
    laws: dict[str, Any] = {}
    for ax in bench.axes:
        f = ax.friction
        if f.is_paper_law:
            continue
        entry: dict[str, Any] = {
            "law": "lugre" if f.lugre is not None else "static",
            "coulomb_positive": f.coulomb_positive,
            "coulomb_negative": f.coulomb_negative,
            "stribeck_positive": f.stribeck_positive,
            "stribeck_negative": f.stribeck_negative,
            "stribeck_exponent": f.stribeck_exponent,
        }
        for sign, tag in ((1, "positive"), (-1, "negative")):
            _, _, vs, visc = f.direction_parameters(sign)
            entry[f"stribeck_velocity_{tag}"] = vs
            entry[f"viscous_{tag}"] = visc
        entry["zero_velocity"] = f.zero_velocity
        if f.lugre is not None:
            entry["bristle_stiffness"] = f.lugre.bristle_stiffness
            entry["bristle_damping"] = f.lugre.bristle_damping
            entry["damping_velocity"] = f.lugre.damping_velocity
        laws[ax.name] = entry
    if laws:
        out["friction"] = laws
    return out


def _log_columns(run: SimRun, bench: ScaraBench) -> dict[str, NDArray[np.float64]]:
    cols = {"t": run.t}
    for k, ax in enumerate(bench.axes):
        cols[f"q_{ax.name}"] = run.q[:, k]
    for k, ax in enumerate(bench.axes):
        cols[f"i_{ax.name}"] = run.current[:, k]
    return cols


@dataclass(frozen=True, slots=True, eq=False)
class BenchFiles:
    """The content of a bench folder, before it is written (docs/formats.md).

    Attributes
    ----------
    robot
        robot.toml, as a TOML-ready dict.
    truth
        truth.toml (:func:`truth_document`).
    sweep, circle
        The logs' columns (``t``, ``q_<j>``, ``i_<j>``).
    truth_columns
        truth.csv's columns (``t``, ``fx``, ``fy``, ``tau_ext_<j>``) at every circle sample.
    """

    robot: dict[str, Any]
    truth: dict[str, Any]
    sweep: dict[str, NDArray[np.float64]]
    circle: dict[str, NDArray[np.float64]]
    truth_columns: dict[str, NDArray[np.float64]]


def simulate_bench(bench: ScaraBench | None = None, *, seed: int = 0) -> BenchFiles:
    """Simulate both scenarios of ``bench`` with noise seed ``seed``; nothing is written.

    Parameters
    ----------
    bench
        Parameters; default :func:`~torquemap.sim.scara.default_bench`.
    seed
        Seed of the noise (the sweep and the circle use independent streams), >= 0.

    Returns
    -------
    BenchFiles

    Raises
    ------
    InputError
        On a negative seed.
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    bench = default_bench() if bench is None else bench
    sweep_rng, circle_rng = np.random.default_rng(seed).spawn(2)
    sweep = simulate_sweep(bench, rng=sweep_rng)
    circle = simulate_circle(bench, rng=circle_rng)
    names = [ax.name for ax in bench.axes]
    return BenchFiles(
        robot=robot_document(bench),
        truth=truth_document(bench, seed=seed),
        sweep=_log_columns(sweep, bench),
        circle=_log_columns(circle, bench),
        truth_columns={
            "t": circle.t,
            "fx": circle.force[:, 0],
            "fy": circle.force[:, 1],
            f"tau_ext_{names[0]}": circle.tau_ext[:, 0],
            f"tau_ext_{names[1]}": circle.tau_ext[:, 1],
        },
    )


def write_scara_bench(
    out_dir: str | os.PathLike[str], *, seed: int = 0, bench: ScaraBench | None = None
) -> None:
    """Simulate both scenarios and write the bench files into ``out_dir`` (created if missing).

    Files: robot.toml (robot file), sweep.csv and circle.csv (logs: ``t``, ``q_a``, ``q_b``,
    ``i_a``, ``i_b``), truth.csv (``t``, ``fx``, ``fy``, ``tau_ext_a``, ``tau_ext_b`` for every
    sample of circle.csv) and truth.toml (a model file with the true parameters). Each file is
    written atomically; the output is a function of ``bench`` and ``seed`` alone.

    Parameters
    ----------
    out_dir
        Output folder.
    seed
        Seed of the noise (the sweep and the circle use independent streams).
    bench
        Parameters; default :func:`~torquemap.sim.scara.default_bench` (the paper's);
        :func:`torquemap.sim.family.random_bench` draws others.

    Raises
    ------
    InputError
        On a negative seed, or when ``out_dir`` exists and is not a folder or cannot be
        created.
    """
    from torquemap.io import write_table, write_toml

    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("output path exists and is not a folder", path=out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder ({exc.strerror})", path=out) from None
    files = simulate_bench(bench, seed=seed)
    write_toml(out / "robot.toml", files.robot)
    write_table(out / "sweep.csv", files.sweep)
    write_table(out / "circle.csv", files.circle)
    write_table(out / "truth.csv", files.truth_columns)
    write_toml(out / "truth.toml", files.truth)
