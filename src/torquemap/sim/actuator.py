"""A single actuator on a test stand: position holds (quasi-static calibration) and slow sweeps.

The anti-cogging loop of ODrive and moteus users: calibrate on-device by holding the motor at
many positions and averaging the holding torque, export a table, load it as a feed-forward, and
verify with a sweep. This bench simulates one axis of the SCARA (its motor, friction, PDTV,
encoder and current sensor, :class:`torquemap.sim.scara.Axis`) with an inertial load and its
own servo:

``tau = J_ff acc_ref + Kp (theta_ref - theta_enc) + Kd (w_ref - w_est) + comp(theta_enc)``

where ``comp`` is an optional anti-cogging table (torque per bin over one motor revolution,
looked up at the encoder angle, as firmware does). For holds the gains are raised (a stiff
calibration loop, ``hold_bandwidth``), as the on-device calibrations do.

Physics: ``J dw/dt = tau - friction(w) - pdtv(theta)``, motor side, integrated in ``substeps``
steps per servo tick with the velocity implicit in the friction (Newton on the piecewise law,
whose steep blend through zero velocity stands for stiction), position by the trapezoidal rule.
Independent runs (the holds) are integrated side by side as the lanes of numpy arrays: each
hold starts at rest exactly at the previous hold's position (the small settling error of the
previous hold is not carried over). The friction and PDTV laws are written out here
again on purpose: this module imports nothing from the estimators.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.sim.scara import Axis, default_bench
from torquemap.sim.trajectory import trapezoid

TWO_PI = 2.0 * math.pi


def _default_axis() -> Axis:
    return default_bench().axes[0]


@dataclass(frozen=True, slots=True, eq=False)
class Actuator:
    """One motor and its load on a test stand, and its servo.

    Attributes
    ----------
    axis
        Motor, encoder, current sensor, friction and PDTV (default: the SCARA's axis ``a``,
        PDTV lines of 1, 2, 3, 4, 21 and 48 CPR).
    load_inertia
        Load inertia [kg m^2], motor side (chosen: about the rotor's).
    servo_rate
        [Hz]; the log is written at this rate.
    substeps
        Physics steps per servo period.
    bandwidth
        Position-loop bandwidth of the sweeps [Hz] (a tuned, not stiff, servo).
    hold_bandwidth
        Position-loop bandwidth of the holds [Hz]: the calibration loop is stiffer, so that the
        rotor creeps to its equilibrium through the stiction band within the hold (at 30 Hz
        the mean holding torque over a hold's second half follows the PDTV with a gain of
        0.99-1.02 and 0.4 mN m scatter, 0.4 s holds).
    damping
        Damping ratio [-].
    velocity_cutoff
        Cut-off of the velocity estimate's low-pass [Hz] (low: the derivative of a quantised
        encoder would otherwise kick the stiff hold loop count by count).
    """

    axis: Axis = field(default_factory=_default_axis)
    load_inertia: float = 1.0e-4
    servo_rate: float = 2000.0
    substeps: int = 2
    bandwidth: float = 15.0
    hold_bandwidth: float = 30.0
    damping: float = 0.8
    velocity_cutoff: float = 30.0

    @property
    def inertia(self) -> float:
        """Rotor plus load [kg m^2], motor side."""
        return self.axis.rotor_inertia + self.load_inertia


@dataclass(frozen=True, slots=True, eq=False)
class ActuatorRun:
    """One simulated run: log columns and hidden truth (for tests only).

    Attributes
    ----------
    t
        Time [s], shape (n,).
    motor_angle
        Encoder reading [rad], motor side (quantised), shape (n,).
    current
        Measured motor current [A] (command, feed-forward included, plus sensor noise),
        shape (n,).
    true_angle, velocity
        True motor angle [rad] and velocity [rad/s], shape (n,).
    pdtv
        True PDTV torque at each sample [N m], shape (n,).
    compensation
        Anti-cogging feed-forward torque applied at each sample [N m], shape (n,).
    """

    t: NDArray[np.float64]
    motor_angle: NDArray[np.float64]
    current: NDArray[np.float64]
    true_angle: NDArray[np.float64]
    velocity: NDArray[np.float64]
    pdtv: NDArray[np.float64]
    compensation: NDArray[np.float64]


def _friction(w: NDArray[np.float64], ax: Axis) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Friction [N m] and its slope d/dw at motor velocity ``w`` (the SCARA bench's law)."""
    f = ax.friction
    x = w / f.stribeck_velocity
    s = np.exp(-x * x)
    ds = -2.0 * x / f.stribeck_velocity * s
    pos = f.coulomb_positive + f.stribeck_positive * s
    neg = -f.coulomb_negative - f.stribeck_negative * s
    w0 = f.zero_velocity
    blend = np.clip((w + w0) / (2.0 * w0), 0.0, 1.0)
    inside = np.abs(w) < w0
    value = blend * pos + (1.0 - blend) * neg + f.viscous * w
    slope = (
        np.where(inside, (pos - neg) / (2.0 * w0), 0.0)
        + blend * f.stribeck_positive * ds
        - (1.0 - blend) * f.stribeck_negative * ds
        + f.viscous
    )
    return value, slope


def _pdtv(theta: NDArray[np.float64], ax: Axis) -> NDArray[np.float64]:
    out = np.zeros_like(theta)
    for h in ax.pdtv:
        out += h.amplitude * np.cos(h.order * theta + h.phase)
    return out


def _lookup(table: NDArray[np.float64] | None, theta: NDArray[np.float64]) -> NDArray[np.float64]:
    """The table's bin at each angle (bin k spans ``[k, k + 1) 2 pi / bins``), as firmware."""
    if table is None:
        return np.zeros_like(theta)
    nb = table.size
    k = np.floor(np.mod(theta, TWO_PI) / (TWO_PI / nb)).astype(np.int64) % nb
    out: NDArray[np.float64] = table[k]
    return out


def _simulate(
    act: Actuator,
    ref: NDArray[np.float64],
    ref_w: NDArray[np.float64],
    ref_a: NDArray[np.float64],
    *,
    bandwidth: float,
    compensation: NDArray[np.float64] | None,
    rng: np.random.Generator,
) -> dict[str, NDArray[np.float64]]:
    """Integrate lanes side by side; references shape (n, lanes), every lane starts at rest."""
    ax = act.axis
    n, lanes = ref.shape
    period = 1.0 / act.servo_rate
    dt = period / act.substeps
    j = act.inertia
    wc = TWO_PI * bandwidth
    kp = j * wc * wc
    kd = 2.0 * act.damping * j * wc
    step = TWO_PI / ax.encoder_counts_per_rev
    vel_gain = 1.0 - math.exp(-TWO_PI * act.velocity_cutoff * period)
    rec = {k: np.empty((n, lanes)) for k in ("meas", "cur", "theta", "w", "pdtv", "comp")}
    theta = ref[0].copy()
    w = np.zeros(lanes)
    prev = np.floor(theta / step) * step
    west = np.zeros(lanes)
    for k in range(n):
        meas = np.floor(theta / step) * step
        west += vel_gain * ((meas - prev) / period - west)
        prev = meas
        comp = _lookup(compensation, meas)
        tau = j * ref_a[k] + kp * (ref[k] - meas) + kd * (ref_w[k] - west) + comp
        cur = np.clip(tau / ax.torque_constant, -ax.max_current, ax.max_current)
        tm = ax.torque_constant * cur
        rec["meas"][k] = meas
        rec["cur"][k] = cur
        rec["theta"][k] = theta
        rec["w"][k] = w
        rec["pdtv"][k] = _pdtv(theta, ax)
        rec["comp"][k] = comp
        for _ in range(act.substeps):
            g = tm - _pdtv(theta, ax)
            x = np.zeros(lanes)
            for _it in range(3):
                f, s = _friction(w + x, ax)
                r = j * x - dt * (g - f)
                x -= r / (j + dt * s)
            nw = w + x
            theta = theta + 0.5 * dt * (w + nw)
            w = nw
    rec["cur"] = rec["cur"] + rng.normal(0.0, ax.current_noise, size=(n, lanes))
    return rec


def _simulate_one(
    act: Actuator,
    ref: NDArray[np.float64],
    ref_w: NDArray[np.float64],
    ref_a: NDArray[np.float64],
    *,
    compensation: NDArray[np.float64] | None,
    rng: np.random.Generator,
) -> dict[str, NDArray[np.float64]]:
    """One lane in scalar ``math`` (numpy's per-call overhead dominates a 1-element array)."""
    ax = act.axis
    fr = ax.friction
    n = ref.size
    period = 1.0 / act.servo_rate
    dt = period / act.substeps
    j = act.inertia
    wc = TWO_PI * act.bandwidth
    kp = j * wc * wc
    kd = 2.0 * act.damping * j * wc
    step = TWO_PI / ax.encoder_counts_per_rev
    vel_gain = 1.0 - math.exp(-TWO_PI * act.velocity_cutoff * period)
    lines = [(h.order, h.amplitude, h.phase) for h in ax.pdtv]
    kt, imax = ax.torque_constant, ax.max_current
    w0 = fr.zero_velocity
    table = None if compensation is None else [float(x) for x in compensation]
    nb = 0 if table is None else len(table)

    def pdtv(theta: float) -> float:
        return sum(a * math.cos(o * theta + p) for o, a, p in lines)

    def friction(w: float) -> tuple[float, float]:
        x = w / fr.stribeck_velocity
        s = math.exp(-x * x)
        ds = -2.0 * x / fr.stribeck_velocity * s
        pos = fr.coulomb_positive + fr.stribeck_positive * s
        neg = -fr.coulomb_negative - fr.stribeck_negative * s
        if w > w0:
            return pos + fr.viscous * w, fr.stribeck_positive * ds + fr.viscous
        if w < -w0:
            return neg + fr.viscous * w, -fr.stribeck_negative * ds + fr.viscous
        blend = (w + w0) / (2.0 * w0)
        value = blend * pos + (1.0 - blend) * neg + fr.viscous * w
        slope = (
            (pos - neg) / (2.0 * w0)
            + blend * fr.stribeck_positive * ds
            - (1.0 - blend) * fr.stribeck_negative * ds
            + fr.viscous
        )
        return value, slope

    out = {k: np.empty(n) for k in ("meas", "cur", "theta", "w", "pdtv", "comp")}
    theta = float(ref[0])
    w = 0.0
    prev = math.floor(theta / step) * step
    west = 0.0
    for k in range(n):
        meas = math.floor(theta / step) * step
        west += vel_gain * ((meas - prev) / period - west)
        prev = meas
        comp = 0.0
        if table is not None:
            comp = table[int((meas % TWO_PI) / TWO_PI * nb) % nb]
        tau = j * ref_a[k] + kp * (ref[k] - meas) + kd * (ref_w[k] - west) + comp
        cur = min(max(tau / kt, -imax), imax)
        tm = kt * cur
        out["meas"][k] = meas
        out["cur"][k] = cur
        out["theta"][k] = theta
        out["w"][k] = w
        out["pdtv"][k] = pdtv(theta)
        out["comp"][k] = comp
        for _ in range(act.substeps):
            g = tm - pdtv(theta)
            x = 0.0
            for _it in range(3):
                f, sl = friction(w + x)
                x -= (j * x - dt * (g - f)) / (j + dt * sl)
            nw = w + x
            theta += 0.5 * dt * (w + nw)
            w = nw
    out["cur"] = out["cur"] + rng.normal(0.0, ax.current_noise, size=n)
    return out


def simulate_holds(
    actuator: Actuator | None = None,
    *,
    positions: int = 128,
    hold: float = 0.4,
    move: float = 0.05,
    start: float = 0.0,
    rng: np.random.Generator | int | None = None,
) -> ActuatorRun:
    """Quasi-static calibration: hold at ``positions`` angles over one motor revolution.

    The motor steps forward through one revolution and back, stopping at each of ``positions``
    evenly spaced angles (``start + k 2 pi / positions``) for ``hold`` seconds after a
    ``move`` seconds trapezoidal step. The rotor creeps through the stiction band towards
    its equilibrium: the holding torque approaches the PDTV plus a friction offset that
    depends on the direction of approach.

    Parameters
    ----------
    actuator
        The bench; default :class:`Actuator`.
    positions
        Hold positions per motor revolution (>= 8).
    hold, move
        Hold and step durations [s].
    start
        Motor angle of the first hold [rad].
    rng
        Random generator or seed (current-sensor noise).

    Returns
    -------
    ActuatorRun
        ``2 * positions`` holds, forward then back, in time order.
    """
    act = Actuator() if actuator is None else actuator
    if positions < 8:
        raise ValueError("positions must be at least 8")
    gen = np.random.default_rng(rng)
    spacing = TWO_PI / positions
    targets = start + spacing * np.concatenate(
        [np.arange(1, positions + 1), np.arange(positions - 1, -1, -1)]
    )
    origins = np.concatenate([[start], targets[:-1]])
    rate = act.servo_rate
    n = round((move + hold) * rate)
    tt = np.arange(n) / rate
    prof = trapezoid(tt, 1.0, speed=1.5 / move, acceleration=6.0 / move**2)
    delta = targets - origins
    ref = origins[None, :] + prof.position[:, None] * delta[None, :]
    ref_w = prof.velocity[:, None] * delta[None, :]
    ref_a = prof.acceleration[:, None] * delta[None, :]
    rec = _simulate(
        act, ref, ref_w, ref_a, bandwidth=act.hold_bandwidth, compensation=None, rng=gen
    )
    lanes = targets.size

    def flat(a: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(a.T.reshape(-1), dtype=np.float64)

    return ActuatorRun(
        t=np.arange(n * lanes) / rate,
        motor_angle=flat(rec["meas"]),
        current=flat(rec["cur"]),
        true_angle=flat(rec["theta"]),
        velocity=flat(rec["w"]),
        pdtv=flat(rec["pdtv"]),
        compensation=flat(rec["comp"]),
    )


def simulate_sweep(
    actuator: Actuator | None = None,
    *,
    speed: float = 3.0,
    revolutions: float = 2.0,
    compensation: ArrayLike | None = None,
    rng: np.random.Generator | int | None = None,
) -> ActuatorRun:
    """A constant-speed sweep forward and back, with or without an anti-cogging table.

    Parameters
    ----------
    actuator
        The bench; default :class:`Actuator`.
    speed
        Cruise speed [rad/s], motor side.
    revolutions
        Motor revolutions at cruise, each way.
    compensation
        Anti-cogging feed-forward torque [N m] per bin over one motor revolution, bin ``k``
        spanning ``[k, k + 1) 2 pi / bins`` from the encoder zero; None: none.
    rng
        Random generator or seed (current-sensor noise).

    Returns
    -------
    ActuatorRun
        The sweep; ``current`` includes the feed-forward (as a drive reports it).
    """
    act = Actuator() if actuator is None else actuator
    gen = np.random.default_rng(rng)
    table = None if compensation is None else np.asarray(compensation, dtype=np.float64).ravel()
    rate = act.servo_rate
    acc = 20.0 * speed
    travel = TWO_PI * revolutions + speed * speed / acc
    dur = travel / speed + speed / acc
    n1 = math.ceil(dur * rate)
    dwell = round(0.2 * rate)
    tt = np.arange(n1) / rate
    p = trapezoid(tt, travel, speed=speed, acceleration=acc)
    zeros = np.zeros(dwell)
    ref = np.concatenate([zeros, p.position, np.full(dwell, travel), travel - p.position, zeros])
    ref_w = np.concatenate([zeros, p.velocity, zeros, -p.velocity, zeros])
    ref_a = np.concatenate([zeros, p.acceleration, zeros, -p.acceleration, zeros])
    rec = _simulate_one(act, ref, ref_w, ref_a, compensation=table, rng=gen)
    return ActuatorRun(
        t=np.arange(ref.size) / rate,
        motor_angle=rec["meas"],
        current=rec["cur"],
        true_angle=rec["theta"],
        velocity=rec["w"],
        pdtv=rec["pdtv"],
        compensation=rec["comp"],
    )


def robot_document(actuator: Actuator | None = None) -> dict[str, Any]:
    """The robot file of the test stand (one joint, no kinematics), as a TOML-ready dict."""
    ax = (Actuator() if actuator is None else actuator).axis
    return {
        "robot": {"name": "simulated actuator on a test stand", "kinematics": "none"},
        "joints": {
            ax.name: {
                "gear_ratio": ax.gear_ratio,
                "torque_constant": ax.torque_constant,
                "encoder_counts_per_rev": ax.encoder_counts_per_rev,
            }
        },
    }


def log_columns(run: ActuatorRun, actuator: Actuator | None = None) -> dict[str, NDArray[Any]]:
    """Log columns of a run for the robot of :func:`robot_document`: ``t``, ``q_<j>``, ``i_<j>``."""
    ax = (Actuator() if actuator is None else actuator).axis
    return {
        "t": run.t,
        f"q_{ax.name}": run.motor_angle / ax.gear_ratio,
        f"i_{ax.name}": run.current,
    }


def truth_document(actuator: Actuator | None = None) -> dict[str, Any]:
    """truth.toml: the robot file plus the true PDTV lines (friction and inertia left out)."""
    act = Actuator() if actuator is None else actuator
    doc = robot_document(act)
    doc["joints"][act.axis.name]["pdtv"] = [
        {"order": h.order, "amplitude": h.amplitude, "phase": h.phase, "direction": "both"}
        for h in act.axis.pdtv
    ]
    doc["identification"] = {"source": "torquemap simulate actuator (true PDTV, not identified)"}
    return doc


def write_actuator_bench(
    out_dir: str | os.PathLike[str],
    *,
    seed: int = 0,
    compensation_path: str | os.PathLike[str] | None = None,
    positions: int = 128,
) -> list[str]:
    """Write the test stand's files: robot.toml, holds.csv, sweep.csv, truth.toml.

    With ``compensation_path`` (a map written by ``torquemap pdtv-map``: CSV or Parquet with a
    ``torque`` column [N m] per bin over one motor revolution) only sweep_after.csv is
    written: the sweep of sweep.csv, same seed, with the map applied as the drive's
    feed-forward.

    Returns
    -------
    list of str
        The files written.
    """
    from torquemap.errors import InputError
    from torquemap.io import numeric_column, read_table, write_table, write_toml

    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("output path exists and is not a folder", path=out)
    out.mkdir(parents=True, exist_ok=True)
    act = Actuator()
    holds_rng, sweep_rng = np.random.default_rng(seed).spawn(2)
    if compensation_path is not None:
        table = numeric_column(read_table(compensation_path), "torque", compensation_path)
        if table.size < 2:
            raise InputError("the map needs at least 2 bins", path=compensation_path)
        run = simulate_sweep(act, compensation=table, rng=sweep_rng)
        write_table(out / "sweep_after.csv", log_columns(run, act))
        return [os.fspath(out / "sweep_after.csv")]
    write_toml(out / "robot.toml", robot_document(act))
    write_toml(out / "truth.toml", truth_document(act))
    holds = simulate_holds(act, positions=positions, rng=holds_rng)
    write_table(out / "holds.csv", log_columns(holds, act))
    sweep = simulate_sweep(act, rng=sweep_rng)
    write_table(out / "sweep.csv", log_columns(sweep, act))
    return [os.fspath(out / n) for n in ("robot.toml", "truth.toml", "holds.csv", "sweep.csv")]
