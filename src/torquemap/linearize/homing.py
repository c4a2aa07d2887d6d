"""Homing from the phases' torque equilibria (Adept II paper, §4.3, §5.1 and Table 1).

The tables are indexed by table position, so they only linearise the torque if the position
counter reads the same table positions as during characterisation. An incremental encoder starts
counting from wherever the motor was at power-up; the paper zeroes the counter at the encoder's
index pulse (§5.1). The motor itself offers a reference without an index: energised alone, phase
``k`` pulls the motor to its equilibrium ``e_k`` (the positions stored in MOTOR.toml and in the
tables), so the counter's reading there, minus ``e_k``, is the counter's offset.

The routine (:func:`home_motor`) walks the phases in the order of their equilibria, forward
through one cycle and back (``2 m + 2`` settles, each phase alone at one pulse width): every phase
is reached once from below and once from above. Friction stops the motor short of the
equilibrium on the side it came from, by about ``friction / stiffness``; the mean of the two
approaches cancels that, and the circular mean over the ``2 m`` readings gives the offset. The
readings check the motor file too: a phase that does not move the motor, or rest positions that
disagree with the file's equilibria, raise :class:`~torquemap.errors.InputError`.

Within one actuation cycle only: which cycle of the revolution the joint is in needs a coarse
reference (an index pulse or a hard stop), which the tables do not care about.

This module talks to the motor only through the :class:`HomingRig` protocol; it never imports
the simulator.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.linearize.motor import MotorSpec


@runtime_checkable
class HomingRig(Protocol):
    """A motor free to turn (no constraint), its amplifier and its position counter."""

    def read_position(self) -> int:
        """The position counter, in table positions ``0 .. P - 1``."""
        ...

    def apply(self, actuation: Sequence[int]) -> None:
        """Apply one actuation (pulse width) per phase."""
        ...

    def settle(self) -> None:
        """Wait until the motor has stopped moving."""
        ...


@dataclass(frozen=True, slots=True, eq=False)
class HomingResult:
    """Where the counter's table positions are.

    Attributes
    ----------
    offset
        Counter reading minus table position [table positions], in ``[0, P)``: table position
        ``= (reading - offset) mod P``.
    forward
        Counter reading at each phase's rest reached from below (phase order), shape (m,).
    backward
        The same reached from above, shape (m,).
    phase_offset
        Each phase's offset estimate, both approaches averaged [table positions], shape (m,).
    hysteresis
        Each phase's rest from below minus from above [table positions], shape (m,) (negative:
        friction stops the motor short of the equilibrium).
    spread
        Standard deviation of the ``2 m`` single-reading offsets about ``offset``
        [table positions].
    positions_per_cycle
        ``P``.
    """

    offset: float
    forward: NDArray[np.int64]
    backward: NDArray[np.int64]
    phase_offset: NDArray[np.float64]
    hysteresis: NDArray[np.float64]
    spread: float
    positions_per_cycle: int

    def table_position(self, reading: ArrayLike) -> NDArray[np.int64]:
        """Table position(s) for counter reading(s): ``(reading - round(offset)) mod P``."""
        shift = round(self.offset)
        out: NDArray[np.int64] = np.mod(
            np.asarray(reading, dtype=np.int64) - shift, self.positions_per_cycle
        )
        return out


def circular_mean(values: ArrayLike, period: float) -> float:
    """Mean of values on a circle of circumference ``period``, in ``[0, period)``.

    Examples
    --------
    >>> circular_mean([510.0, 4.0], 512)
    1.0
    """
    v = 2.0 * np.pi * np.asarray(values, dtype=np.float64) / period
    angle = math.atan2(float(np.sin(v).sum()), float(np.cos(v).sum()))
    return float((angle * period / (2.0 * np.pi)) % period)


def circular_difference(a: ArrayLike, b: ArrayLike, period: float) -> NDArray[np.float64]:
    """``a - b`` wrapped into ``[-period/2, period/2)``.

    Examples
    --------
    >>> circular_difference([1.0, 511.0], [511.0, 1.0], 512).tolist()
    [2.0, -2.0]
    """
    d = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    out: NDArray[np.float64] = (d + period / 2.0) % period - period / 2.0
    return out


#: Counts a rest may lie from its equilibrium on any grid: the encoder rounds the reading and
#: the motor file the equilibrium, half a count each, and friction adds to one approach.
ROUNDING_COUNTS = 1.5


def rest_tolerance(spacing: float) -> float:
    """How far [table positions] a phase's rest may lie from the file's equilibrium (after the
    offset) before the file is taken for another motor's: an eighth of the phase spacing, but
    never less than :data:`ROUNDING_COUNTS`.

    On a coarse grid an eighth of the spacing is less than the counts' own rounding: with 12
    positions per cycle and 3 phases (spacing 4, an eighth 0.5) a rest one count off refused
    the right motor file as another motor's (QA stop 36, docs/linearize.md).

    Examples
    --------
    >>> rest_tolerance(512 / 3), rest_tolerance(4.0)
    (21.333333333333332, 1.5)
    """
    return max(spacing / 8.0, ROUNDING_COUNTS)


def _phase_order(spec: MotorSpec) -> list[int]:
    """Phases sorted by equilibrium (the order in which a forward walk reaches them)."""
    return sorted(range(spec.phases), key=lambda k: spec.equilibrium_positions[k])


def home_motor(
    rig: HomingRig,
    spec: MotorSpec,
    *,
    pulse_width: int | None = None,
    path: str | None = None,
) -> HomingResult:
    """Locate the table positions on the counter from the phases' equilibria.

    Parameters
    ----------
    rig
        The free motor.
    spec
        The motor file (its ``equilibrium_positions`` are the reference); at least 3 phases
        (with 2, each phase's equilibrium is the other's unstable point).
    pulse_width
        Actuation of the energised phase (default the full scale ``actuation_max``: the
        stiffest equilibrium, so friction stops the motor closest to it).
    path
        File named in error messages (the motor or tables file).

    Returns
    -------
    HomingResult
        The offset and the readings it rests on.

    Raises
    ------
    InputError
        A motor with fewer than 3 phases, a pulse width out of range, a phase
        that does not pull the motor to its equilibrium, or rest positions that disagree with
        the file's equilibria by more than :func:`rest_tolerance` (an eighth of the phase
        spacing, at least 1.5 counts).

    Notes
    -----
    With friction band ``f`` and torque slope ``k`` at equilibrium ``e``, the motor rests at
    ``e - f/k`` reached from below and ``e + f/k`` from above; the mean of both is ``e``.
    """
    m, n = spec.phases, spec.positions_per_cycle
    if m < 3:
        raise InputError(
            f"homing from the equilibria needs at least 3 phases, the motor has {m}", path=path
        )
    width = spec.actuation_max if pulse_width is None else int(pulse_width)
    if not 1 <= width <= spec.actuation_max:
        raise InputError(
            f"homing pulse width must be in 1 .. {spec.actuation_max}, got {pulse_width}",
            path=path,
        )
    eq = np.asarray(spec.equilibrium_positions, dtype=np.float64)
    order = _phase_order(spec)
    spacing = n / m

    def energise(k: int) -> int:
        act = [0] * m
        act[k] = width
        rig.apply(act)
        rig.settle()
        return rig.read_position()

    forward = np.zeros(m, dtype=np.int64)
    backward = np.zeros(m, dtype=np.int64)
    energise(order[-2])  # from anywhere to a phase's rest, then to the last phase's
    previous, last = energise(order[-1]), order[-1]
    walk = [(k, forward) for k in order]
    walk += [(k, backward) for k in [*reversed(order[:-1]), order[-1]]]
    for k, store in walk:
        reading = energise(k)
        expected = float(circular_difference(eq[k], eq[last], n))
        moved = float(circular_difference(reading, previous, n))
        if abs(moved) < spacing / 4:  # it stayed at the previous phase's rest
            raise InputError(
                f"phase {k + 1} did not pull the motor to its equilibrium (moved {moved:+.0f} "
                f"of {expected:+.0f} table positions): a phase that produces no torque, or a "
                "load or friction it cannot overcome?"
                + (
                    f" Or a pulse width ({width}) too small to move it (the default is full "
                    f"scale, {spec.actuation_max})"
                    if width < spec.actuation_max
                    else ""
                ),
                path=path,
            )
        store[k] = reading
        previous, last = reading, k
    single = np.concatenate([forward - eq, backward - eq]) % n
    offset = circular_mean(single, n)
    residual = circular_difference(single, offset, n)
    worst = float(np.max(np.abs(residual)))
    tolerance = rest_tolerance(spacing)
    if worst > tolerance:
        within = (
            "an eighth of the phase spacing"
            if tolerance > ROUNDING_COUNTS
            else f"{ROUNDING_COUNTS:g} counts, the encoder's and the file's rounding"
        )
        raise InputError(
            f"the phases rest up to {worst:.0f} table positions away from the equilibria in "
            f"the motor file (more than {within}): the file or tables are for another motor?",
            path=path,
        )
    phase_offset = np.array(
        [circular_mean([single[k], single[m + k]], n) for k in range(m)], dtype=np.float64
    )
    return HomingResult(
        offset=offset,
        forward=forward,
        backward=backward,
        phase_offset=phase_offset,
        hysteresis=circular_difference(forward, backward, n),
        spread=float(np.sqrt(np.mean(residual**2))),
        positions_per_cycle=n,
    )
