"""The limit cycle of §5.6 of the Adept II paper: table look-up, compliance and a constraint.

A motor under a constant torque command presses against a constraint. Every servo period
(10 kHz on the paper's joint interface boards) the current table position and the command index
the phase tables; the motor's torque loads the compliant robot, constraint and sensor
(Hooke: ``dx = f / k``), so the motor moves and the next look-up uses the new position. When the
entry at the next position is smaller than the one at the current position (a non-monotonic
table), the torque drops, the motor moves back, and the cycle repeats: the position toggles
between adjacent table positions and the force buzzes. The monotonicity filter (each position's
entries made non-decreasing in the command) removes many of the dips that cause it.

The contact force follows the motor torque through a first-order lag (the mechanics' time
constant); the constraint only pushes (force >= 0). Friction, sensor noise and bias play no part.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.linearize.motor import MotorSpec
from torquemap.sim.rig import SimRig

if TYPE_CHECKING:
    from matplotlib.figure import Figure


@dataclass(frozen=True, slots=True, eq=False)
class PressingResult:
    """One pressing run at a constant torque command.

    Attributes
    ----------
    time
        [s], shape (steps,).
    position
        Table position used for each look-up, shape (steps,).
    torque
        Contact force as torque [N m] after each servo period, shape (steps,).
    toggle_fraction
        Fraction of servo periods in the second half of the run where the position changed.
    amplitude
        Peak-to-peak torque over the second half [N m].
    position_amplitude
        Peak-to-peak position over the second half [table positions] (circular).
    oscillating
        True when the position still toggles in the second half (a limit cycle).
    """

    time: NDArray[np.float64]
    position: NDArray[np.int64]
    torque: NDArray[np.float64]
    toggle_fraction: float
    amplitude: float
    position_amplitude: int
    oscillating: bool


@dataclass(frozen=True, slots=True, eq=False)
class PressingStudy:
    """Pressing runs over many commands (and base positions).

    Attributes
    ----------
    commands
        Command of each run, shape (n,).
    base_positions
        Zero-force position of each run [table positions], shape (n,).
    oscillating
        Shape (n,).
    toggle_fraction
        Shape (n,).
    amplitude
        Peak-to-peak torque [N m], shape (n,).
    fraction_oscillating
        Share of runs with a limit cycle.
    """

    commands: NDArray[np.int64]
    base_positions: NDArray[np.float64]
    oscillating: NDArray[np.bool_]
    toggle_fraction: NDArray[np.float64]
    amplitude: NDArray[np.float64]
    fraction_oscillating: float


def _stack(table_phases: Mapping[str, ArrayLike], spec: MotorSpec) -> NDArray[np.int64]:
    shape = (spec.positions_per_cycle, 2**spec.command_bits)
    out = np.empty((spec.phases, *shape), dtype=np.int64)
    for k in range(spec.phases):
        table = np.asarray(table_phases[f"phase_{k + 1}"])
        if table.shape != shape:
            raise ValueError(f"table phase_{k + 1} has shape {table.shape}, expected {shape}")
        out[k] = table
    return out


def _press(
    stack: NDArray[np.int64],
    motor: SimRig,
    *,
    commands: NDArray[np.int64],
    base_positions: NDArray[np.float64],
    stiffness: float,
    steps: int,
    servo_rate: float,
    time_constant: float,
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Positions and contact torques, shape (steps, runs), of runs advanced together."""
    n = stack.shape[1]
    columns = commands % stack.shape[2]
    alpha = -math.expm1(-1.0 / (servo_rate * time_constant))
    position = np.empty((steps, commands.size), dtype=np.int64)
    torque = np.empty((steps, commands.size))
    f = np.zeros(commands.size)
    for j in range(steps):
        x = base_positions + f / stiffness
        p = np.floor(x + 0.5).astype(np.int64) % n
        t = motor.true_torque(x, stack[:, p, columns].T)
        f = f + alpha * (np.maximum(t, 0.0) - f)
        position[j] = p
        torque[j] = f
    return position, torque


def _measures(
    position: NDArray[np.int64], torque: NDArray[np.float64], n: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], NDArray[np.bool_]]:
    half = position.shape[0] // 2
    tail = position[half:]
    moves = np.diff(tail, axis=0) != 0
    unwrapped = (tail - tail[:1] + n // 2) % n - n // 2
    toggle = moves.mean(axis=0) if moves.shape[0] else np.zeros(tail.shape[1])
    return (
        toggle,
        np.ptp(torque[half:], axis=0),
        np.ptp(unwrapped, axis=0).astype(np.int64),
        moves.sum(axis=0) >= 2,
    )


def simulate_pressing(
    table_phases: Mapping[str, ArrayLike],
    spec: MotorSpec,
    motor: SimRig,
    *,
    command: int,
    stiffness: float,
    steps: int = 2000,
    base_position: float = 0.0,
    servo_rate: float = 10_000.0,
    time_constant: float = 3e-4,
) -> PressingResult:
    """Press against a constraint at a constant command, looking up the tables every period.

    Parameters
    ----------
    table_phases
        ``phase_1 .. phase_m``: pulse-width tables, shape ``(P, 2**command_bits)``, entry
        ``[p, c mod 2**bits]``.
    spec
        The motor the tables are for.
    motor
        The simulated motor and amplifier (:meth:`SimRig.true_torque`; the rig's friction,
        bias, noise and its own stiffness are not used).
    command
        The constant torque command.
    stiffness
        Combined stiffness of robot, constraint and sensor [N m per table position].
    steps
        Servo periods to simulate.
    base_position
        Motor position at zero force [table positions].
    servo_rate
        Look-up rate [Hz].
    time_constant
        Time constant of the contact force following the motor torque [s].

    Returns
    -------
    PressingResult
        Traces and the limit-cycle measures (over the second half of the run).
    """
    position, torque = _press(
        _stack(table_phases, spec),
        motor,
        commands=np.array([int(command)]),
        base_positions=np.array([float(base_position)]),
        stiffness=stiffness,
        steps=steps,
        servo_rate=servo_rate,
        time_constant=time_constant,
    )
    toggle, amp, pos_amp, osc = _measures(position, torque, spec.positions_per_cycle)
    return PressingResult(
        time=np.arange(steps) / servo_rate,
        position=position[:, 0],
        torque=torque[:, 0],
        toggle_fraction=float(toggle[0]),
        amplitude=float(amp[0]),
        position_amplitude=int(pos_amp[0]),
        oscillating=bool(osc[0]),
    )


def pressing_study(
    table_phases: Mapping[str, ArrayLike],
    spec: MotorSpec,
    motor: SimRig,
    *,
    commands: Sequence[int] | NDArray[np.integer],
    base_positions: Sequence[float] | NDArray[np.floating],
    stiffness: float,
    steps: int = 600,
    servo_rate: float = 10_000.0,
    time_constant: float = 3e-4,
) -> PressingStudy:
    """:func:`simulate_pressing` for every command at every base position (run together).

    Returns
    -------
    PressingStudy
        Per-run measures and the share of runs with a limit cycle.
    """
    c, b = np.meshgrid(
        np.asarray(commands, dtype=np.int64), np.asarray(base_positions, dtype=np.float64)
    )
    position, torque = _press(
        _stack(table_phases, spec),
        motor,
        commands=c.ravel(),
        base_positions=b.ravel(),
        stiffness=stiffness,
        steps=steps,
        servo_rate=servo_rate,
        time_constant=time_constant,
    )
    toggle, amp, _, osc = _measures(position, torque, spec.positions_per_cycle)
    return PressingStudy(
        commands=c.ravel(),
        base_positions=b.ravel(),
        oscillating=osc,
        toggle_fraction=toggle,
        amplitude=amp,
        fraction_oscillating=float(osc.mean()) if osc.size else 0.0,
    )


def oscillation_figure(
    runs: Mapping[str, PressingResult],
    *,
    studies: Mapping[str, PressingStudy] | None = None,
) -> Figure:
    """Position and torque traces of pressing runs, and optionally the study summaries.

    Parameters
    ----------
    runs
        Label (e.g. ``"raw"``, ``"monotonic"``) to a run.
    studies
        Label to a study: adds a panel of the share of oscillating runs and the mean torque
        amplitude.

    Returns
    -------
    matplotlib.figure.Figure
        Save it with ``fig.savefig``.
    """
    from matplotlib.figure import Figure

    rows = 3 if studies else 2
    fig = Figure(figsize=(7.0, 2.4 * rows), layout="constrained")
    ax_pos, ax_tau = fig.add_subplot(rows, 1, 1), fig.add_subplot(rows, 1, 2)
    for label, run in runs.items():
        ax_pos.step(run.time * 1e3, run.position, where="post", label=label)
        ax_tau.plot(run.time * 1e3, run.torque, label=label)
    ax_pos.set_ylabel("table position")
    ax_tau.set_ylabel("contact torque [N m]")
    ax_tau.set_xlabel("time [ms]")
    ax_pos.legend(loc="best")
    ax_pos.set_title("Pressing at a constant command (Adept II paper §5.6)")
    if studies:
        ax = fig.add_subplot(rows, 1, 3)
        labels = list(studies)
        share = [100.0 * studies[k].fraction_oscillating for k in labels]
        ax.bar(labels, share)
        for i, k in enumerate(labels):
            amp = studies[k].amplitude[studies[k].oscillating]
            text = f"{amp.mean():.2f} N m p-p" if amp.size else "none"
            ax.annotate(text, (i, share[i]), ha="center", va="bottom")
        ax.set_ylabel("runs oscillating [%]")
    return fig
