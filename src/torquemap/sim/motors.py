"""Motor and amplifier physics of the simulated characterisation rig (Adept II paper, §4).

Two three-phase motors like the Adept II's: a variable reluctance (VR) motor (joints 1 and 2:
150 actuation cycles per revolution, 512 table positions per cycle) and a brushless DC (BLDC)
motor (joints 3 and 4: 10 actuation cycles per revolution, 256 table positions per cycle). Both
are driven through a pulse-width modulation amplifier whose pulse-width to current transfer is
nonlinear (dead band, a curve, saturation) and unknown to the table builder.

Position ``x`` is in table positions (continuous, periodic over one actuation cycle of ``P``
positions). With ``u_k = 2 pi (x - e_k) / P`` for phase ``k`` with equilibrium ``e_k``:

* VR: ``T_k = T0 g_k f(i_k) / f(i_max) s_vr(u_k) / (1 + mu sum_{j != k} (i_j / i_max)^2)``, with
  ``f(i) = i^2 / sqrt(1 + (i / i_s)^2)`` (``~ i^2`` at low current, ``~ i i_s`` when saturated)
  and ``s_vr(u) = -(sin u + b2 sin 2u) / max``. The last factor is mutual saturation: with two
  phases energised (the transition regions) the torque is less than the sum of the phases'.
* BLDC: ``T_k = T0 g_k (i_k / i_max) s_bldc(u_k) (1 - mu sum_{j != k} i_j / i_max)`` with the
  trapezoidal back-EMF shape ``s_bldc(u) = -(sin u + b3 sin 3u + b5 sin 5u) / max``, plus cogging
  ``c sin(6 * 2 pi x / P + phi)`` that does not depend on the currents.

Each phase's torque is zero at its own equilibrium with a restoring slope and peaks between the
equilibria; the phases differ by small gains ``g_k`` and equilibrium offsets. Every default is
chosen (the paper gives no motor constants) so that the uncompensated APMD of the paper's Eq 1
lands in the paper's range (Table 2: VR 58 to 76 %, BLDC 9 to 36 %).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True, slots=True, eq=False)
class Amplifier:
    """PWM amplifier: pulse width to phase current, the same law for every phase.

    ``i = min(i_max (1 - exp(-a x)) / (1 - exp(-a)), i_limit)`` with
    ``x = clip((u - u0) / (u_max - u0), 0, 1)``: a dead band, a curve (concave for ``a > 0``,
    convex for ``a < 0``, linear for ``a = 0``) and a current limit.

    Attributes
    ----------
    actuation_max
        Full-scale pulse width ``u_max``.
    dead_band
        Pulse widths up to ``u0`` give no current.
    curve
        ``a``: > 0 concave, < 0 convex, 0 linear.
    current_max
        Current the curve reaches at full scale [A].
    current_limit
        The amplifier's current limit [A].
    onset
        Width ``w`` [pulse-width units] of a smooth onset past the dead band: the drive
        ``d = u - u0`` is replaced by ``d^2 / (2 w)`` below ``w`` and ``d - w / 2`` above (0: a
        sharp corner).
    soft_limit
        ``n`` of a soft current limit ``i / (1 + (i / i_limit)^n)^(1/n)`` (0: the hard
        ``min(i, i_limit)``).
    """

    actuation_max: int = 255
    dead_band: float = 20.0
    curve: float = -0.6
    current_max: float = 10.0
    current_limit: float = 9.5
    onset: float = 0.0
    soft_limit: float = 0.0


def amplifier_current(actuation: ArrayLike, amplifier: Amplifier) -> NDArray[np.float64]:
    """Phase current [A] for pulse width(s) ``actuation`` (any shape).

    Examples
    --------
    >>> amp = Amplifier()
    >>> amplifier_current([0, 20, 255], amp).round(3).tolist()  # dead band, current limit
    [0.0, 0.0, 9.5]
    """
    u = np.asarray(actuation, dtype=np.float64)
    d = np.maximum(u - amplifier.dead_band, 0.0)
    w = amplifier.onset
    if w > 0.0:
        d = np.where(d < w, d * d / (2.0 * w), d - 0.5 * w)
    x = np.clip(d / (amplifier.actuation_max - amplifier.dead_band), 0, 1)
    a = amplifier.curve
    shape = x if a == 0.0 else np.expm1(-a * x) / math.expm1(-a)
    raw = amplifier.current_max * shape
    n = amplifier.soft_limit
    out: NDArray[np.float64]
    if n > 0.0:
        out = raw / (1.0 + (raw / amplifier.current_limit) ** n) ** (1.0 / n)
    else:
        out = np.minimum(raw, amplifier.current_limit)
    return out


@dataclass(frozen=True, slots=True, eq=False)
class VariableReluctanceMotor:
    """Three-phase VR motor (Adept II joints 1 and 2).

    Attributes
    ----------
    positions_per_cycle
        Table positions ``P`` per actuation cycle.
    cycles_per_revolution
        Actuation cycles per motor revolution.
    equilibrium
        Nominal equilibrium ``e_k`` of each phase [table positions]; the defaults put each
        phase's torque peak at the centre of its third of the cycle (the ramps' centres).
    phase_offset
        Deviation of each phase's equilibrium from nominal [table positions].
    phase_gain
        ``g_k``, relative strength of each phase.
    peak_torque
        ``T0``, one phase's peak torque at full current [N m].
    saturation_current
        ``i_s`` [A]: below it torque grows as ``i^2``, above it about linearly.
    current_max
        Current at which ``T0`` is reached [A].
    second_harmonic
        ``b2``, skews each phase's torque curve.
    mutual_saturation
        ``mu``, the two-phase interaction.
    cogging, cogging_periods, cogging_phase
        Detent torque ``c sin(n 2 pi x / P + phi)`` [N m] that does not depend on the currents
        (0 by default: the Adept II's VR motors).
    """

    positions_per_cycle: int = 512
    cycles_per_revolution: int = 150
    equilibrium: tuple[float, ...] = (213.33, 384.0, 42.67)
    phase_offset: tuple[float, ...] = (0.0, 3.0, -2.0)
    phase_gain: tuple[float, ...] = (1.0, 0.95, 1.04)
    peak_torque: float = 80.0
    saturation_current: float = 8.0
    current_max: float = 10.0
    second_harmonic: float = 0.15
    mutual_saturation: float = 0.3
    cogging: float = 0.0
    cogging_periods: int = 6
    cogging_phase: float = 0.4


@dataclass(frozen=True, slots=True, eq=False)
class BrushlessDcMotor:
    """Three-phase brushless DC motor (Adept II joints 3 and 4).

    Attributes
    ----------
    positions_per_cycle, cycles_per_revolution, equilibrium, phase_offset, phase_gain
        As for :class:`VariableReluctanceMotor`.
    peak_torque
        ``T0``, one phase's peak torque at full current [N m].
    current_max
        [A].
    harmonics
        ``(b3, b5)``, the trapezoidal back-EMF shape.
    cogging
        Cogging amplitude ``c`` [N m].
    cogging_phase
        ``phi`` [rad].
    mutual_saturation
        ``mu``, the two-phase interaction (armature reaction).
    cogging_periods
        ``n``, cogging periods per actuation cycle (the cogging is
        ``c sin(n 2 pi x / P + phi)``).
    """

    positions_per_cycle: int = 256
    cycles_per_revolution: int = 10
    equilibrium: tuple[float, ...] = (106.67, 192.0, 21.33)
    phase_offset: tuple[float, ...] = (0.0, 1.5, -1.0)
    phase_gain: tuple[float, ...] = (1.0, 0.96, 1.03)
    peak_torque: float = 6.0
    current_max: float = 10.0
    harmonics: tuple[float, float] = (0.2, 0.06)
    cogging: float = 0.12
    cogging_phase: float = 0.4
    mutual_saturation: float = 0.08
    cogging_periods: int = 6


Motor = VariableReluctanceMotor | BrushlessDcMotor


def _angles(motor: Motor, position: NDArray[np.float64]) -> NDArray[np.float64]:
    e = np.asarray(motor.equilibrium) + np.asarray(motor.phase_offset)
    angles: NDArray[np.float64] = (
        2.0 * np.pi * (position[..., None] - e) / motor.positions_per_cycle
    )
    return angles


@functools.lru_cache(maxsize=256)
def _shape_max(coefficients: tuple[tuple[int, float], ...]) -> float:
    u = np.linspace(0.0, 2.0 * np.pi, 4096, endpoint=False)
    s = sum(b * np.sin(n * u) for n, b in coefficients)
    return float(np.max(np.abs(s)))


def motor_torque(motor: Motor, position: ArrayLike, current: ArrayLike) -> NDArray[np.float64]:
    """Electromagnetic (plus cogging) torque [N m] for phase currents at table positions.

    Parameters
    ----------
    motor
        The motor.
    position
        Table position(s), continuous, shape ``(...)`` broadcasting with ``current[..., 0]``.
    current
        Phase currents [A], shape ``(..., m)``, >= 0.

    Returns
    -------
    ndarray
        Torque in the positive direction [N m], the broadcast shape of ``(...)``.

    Examples
    --------
    >>> m = VariableReluctanceMotor(phase_offset=(0, 0, 0))
    >>> abs(float(motor_torque(m, 213.33, [10.0, 0.0, 0.0]))) < 1e-9  # phase 1 equilibrium
    True
    """
    x = np.asarray(position, dtype=np.float64)
    i = np.asarray(current, dtype=np.float64)
    x = np.broadcast_arrays(x, i[..., 0])[0]
    i = np.broadcast_to(i, (*x.shape, i.shape[-1]))
    u = _angles(motor, x)
    g = np.asarray(motor.phase_gain)
    if isinstance(motor, VariableReluctanceMotor):
        coefficients: tuple[tuple[int, float], ...] = ((1, 1.0), (2, motor.second_harmonic))
        shape = -(np.sin(u) + motor.second_harmonic * np.sin(2 * u)) / _shape_max(coefficients)
        i_s = motor.saturation_current

        def f(c: NDArray[np.float64] | float) -> NDArray[np.float64]:
            return np.asarray(c, dtype=np.float64) ** 2 / np.sqrt(1 + (np.asarray(c) / i_s) ** 2)

        sq = (i / motor.current_max) ** 2
        others = sq.sum(axis=-1, keepdims=True) - sq
        per_phase = (motor.peak_torque * g * f(i) / f(motor.current_max) * shape) / (
            1.0 + motor.mutual_saturation * others
        )
        out: NDArray[np.float64] = per_phase.sum(axis=-1)
        if motor.cogging:
            out = out + motor.cogging * np.sin(
                2.0 * np.pi * motor.cogging_periods * x / motor.positions_per_cycle
                + motor.cogging_phase
            )
        return out
    b3, b5 = motor.harmonics
    coefficients = ((1, 1.0), (3, b3), (5, b5))
    shape = -(np.sin(u) + b3 * np.sin(3 * u) + b5 * np.sin(5 * u)) / _shape_max(coefficients)
    lin = i / motor.current_max
    others = lin.sum(axis=-1, keepdims=True) - lin
    per_phase = motor.peak_torque * g * lin * shape * (1.0 - motor.mutual_saturation * others)
    cog = motor.cogging * np.sin(
        2.0 * np.pi * motor.cogging_periods * x / motor.positions_per_cycle + motor.cogging_phase
    )
    total: NDArray[np.float64] = per_phase.sum(axis=-1) + cog
    return total


def torque_at(motor: Motor, position: float, current: list[float]) -> float:
    """:func:`motor_torque` at one position for one set of phase currents, in plain floats.

    The same law term by term, without numpy's per-call cost: the rig's settling loop calls it
    thousands of times per collection.

    Examples
    --------
    >>> m = VariableReluctanceMotor()
    >>> a = torque_at(m, 100.3, [9.0, 2.0, 0.0])
    >>> abs(a - float(motor_torque(m, 100.3, [9.0, 2.0, 0.0]))) < 1e-9
    True
    """
    n = motor.positions_per_cycle
    two_pi = 2.0 * math.pi
    total = 0.0
    if isinstance(motor, VariableReluctanceMotor):
        b2 = motor.second_harmonic
        norm = _shape_max(((1, 1.0), (2, b2)))
        i_s = motor.saturation_current
        imax = motor.current_max
        f_max = imax * imax / math.sqrt(1.0 + (imax / i_s) ** 2)
        sq = [(c / imax) ** 2 for c in current]
        sq_sum = sum(sq)
        for k, c in enumerate(current):
            if c == 0.0:
                continue
            u = two_pi * (position - motor.equilibrium[k] - motor.phase_offset[k]) / n
            shape = -(math.sin(u) + b2 * math.sin(2.0 * u)) / norm
            f = c * c / math.sqrt(1.0 + (c / i_s) ** 2)
            total += (motor.peak_torque * motor.phase_gain[k] * f / f_max * shape) / (
                1.0 + motor.mutual_saturation * (sq_sum - sq[k])
            )
        if motor.cogging:
            total += motor.cogging * math.sin(
                two_pi * motor.cogging_periods * position / n + motor.cogging_phase
            )
        return total
    b3, b5 = motor.harmonics
    norm = _shape_max(((1, 1.0), (3, b3), (5, b5)))
    lin = [c / motor.current_max for c in current]
    lin_sum = sum(lin)
    for k, x in enumerate(lin):
        if x == 0.0:
            continue
        u = two_pi * (position - motor.equilibrium[k] - motor.phase_offset[k]) / n
        shape = -(math.sin(u) + b3 * math.sin(3.0 * u) + b5 * math.sin(5.0 * u)) / norm
        total += (
            motor.peak_torque * motor.phase_gain[k] * x * shape
            * (1.0 - motor.mutual_saturation * (lin_sum - x))
        )  # fmt: skip
    total += motor.cogging * math.sin(
        two_pi * motor.cogging_periods * position / n + motor.cogging_phase
    )
    return total
