"""A simulated free motor for homing (Adept II paper, §5.1 and Table 1): no constraint, no sensor.

The joint turns freely against its bearing friction. After power-up the incremental encoder's
counter starts at an arbitrary value, so the encoder reads ``(x + offset) mod P`` rounded, with
``x`` the motor's table position (continuous) and ``offset`` [table positions] hidden from the
homing routine. Energising phases moves the motor quasi-statically: :meth:`FreeMotorRig.settle`
moves it in the direction of the net torque ``T(x) + load`` until that torque falls inside the
static friction band, whose half width varies from one settle to the next (stiction is not a
constant). The motor stops short of a phase's equilibrium by about ``friction / stiffness`` on
the side it came from, which is what makes homing direction dependent.

This is the simulator's side: :mod:`torquemap.linearize.homing` never imports it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.linearize.homing import HomingResult, home_motor
from torquemap.linearize.motor import MotorSpec
from torquemap.sim.motors import Amplifier, Motor, amplifier_current, motor_torque


class FreeMotorRig:
    """A motor turning freely against friction, with an incremental encoder of unknown offset.

    Implements :class:`torquemap.linearize.homing.HomingRig`.

    Parameters
    ----------
    motor
        The motor physics.
    amplifier
        The amplifier.
    friction
        Mean half width of the static friction band [N m].
    friction_spread
        Relative standard deviation of the band from one settle to the next.
    load
        Constant external torque (gravity, cable) [N m].
    encoder_offset
        The encoder reading minus the table position [table positions] (hidden truth).
    start_position
        Where the motor is at power-up [table positions].
    rng
        Source of the friction's variation.
    """

    def __init__(
        self,
        motor: Motor,
        amplifier: Amplifier,
        *,
        friction: float,
        friction_spread: float = 0.3,
        load: float = 0.0,
        encoder_offset: float = 0.0,
        start_position: float = 0.0,
        rng: np.random.Generator | int | None = None,
    ) -> None:
        self.motor = motor
        self.amplifier = amplifier
        self.friction = float(friction)
        self.friction_spread = float(friction_spread)
        self.load = float(load)
        self.encoder_offset = float(encoder_offset)
        self.positions_per_cycle = motor.positions_per_cycle
        self.phases = len(motor.equilibrium)
        self.x = float(start_position)
        self.actuation = np.zeros(self.phases, dtype=np.int64)
        self.rng = np.random.default_rng(rng)

    def torque(self, position: float | NDArray[np.float64]) -> NDArray[np.float64]:
        """Net torque [N m] (motor plus load) at table position(s) with the applied actuation."""
        current = amplifier_current(self.actuation, self.amplifier)
        return motor_torque(self.motor, position, current) + self.load

    def read_position(self) -> int:
        """Encoder: ``(x + offset)`` rounded, in ``0 .. P - 1``."""
        return math.floor(self.x + self.encoder_offset + 0.5) % self.positions_per_cycle

    def apply(self, actuation: Sequence[int]) -> None:
        """Set the pulse width of every phase (takes effect at :meth:`settle`)."""
        act = np.asarray(actuation, dtype=np.int64)
        if act.shape != (self.phases,):
            raise ValueError(f"need {self.phases} actuations, got {act.shape}")
        if act.min() < 0 or act.max() > self.amplifier.actuation_max:
            raise ValueError(f"actuation outside 0 .. {self.amplifier.actuation_max}: {act}")
        self.actuation = act

    def settle(self) -> None:
        """Move with the net torque until it falls inside this settle's friction band."""
        band = self.friction * max(0.0, 1.0 + self.friction_spread * self.rng.standard_normal())
        t = float(self.torque(self.x))
        if abs(t) <= band:
            return
        direction = 1.0 if t > 0 else -1.0
        step = 1.0 / 16.0
        path = self.x + direction * step * np.arange(1.0, 16 * self.positions_per_cycle + 1)
        inside = np.flatnonzero(direction * self.torque(path) <= band)
        if inside.size == 0:
            return  # spins: cannot happen with a restoring phase torque
        j = int(inside[0])
        lo, hi = (self.x if j == 0 else float(path[j - 1])), float(path[j])
        for _ in range(20):  # the stop lies between: bisect it
            mid = 0.5 * (lo + hi)
            if direction * float(self.torque(mid)) <= band:
                hi = mid
            else:
                lo = mid
        x = hi
        self.x = x % self.positions_per_cycle

    def table_position(self) -> float:
        """The motor's true table position [table positions] (hidden truth, for benchmarks)."""
        return self.x


def free_motor_rig(
    kind: Literal["vr", "bldc"],
    *,
    motor: Motor | None = None,
    amplifier: Amplifier | None = None,
    rng: np.random.Generator | int | None = None,
    friction_fraction: float = 0.01,
    friction_spread: float = 0.3,
) -> FreeMotorRig:
    """A free motor like the characterisation rig's, powered up at a random position and offset.

    Parameters
    ----------
    kind
        ``"vr"`` or ``"bldc"``: the default motor and amplifier of
        :func:`torquemap.sim.rig.sim_rig` (unless ``motor`` / ``amplifier`` are given).
    motor, amplifier
        Override the motor or the amplifier.
    rng
        Draws the power-up position and encoder offset, then the friction's variation.
    friction_fraction
        Bearing friction as a fraction of one phase's peak torque.
    friction_spread
        Relative standard deviation of the friction band from settle to settle.

    Examples
    --------
    >>> rig = free_motor_rig("vr", rng=0)
    >>> 0 <= rig.encoder_offset < 512
    True
    """
    from torquemap.sim.rig import sim_rig

    base = sim_rig(kind, rng=0)
    m = base.motor if motor is None else motor
    amp = base.amplifier if amplifier is None else amplifier
    gen = np.random.default_rng(rng)
    n = m.positions_per_cycle
    return FreeMotorRig(
        m,
        amp,
        friction=friction_fraction * m.peak_torque,
        friction_spread=friction_spread,
        encoder_offset=float(gen.uniform(0, n)),
        start_position=float(gen.uniform(0, n)),
        rng=gen,
    )


def home_on_sim(
    spec: MotorSpec,
    *,
    sim: Literal["vr", "bldc"],
    seed: int = 0,
    repeats: int = 10,
    pulse_width: int | None = None,
    friction_fraction: float = 0.01,
    path: str | None = None,
    random: int | None = None,
) -> tuple[list[HomingResult], float]:
    """Home a simulated free motor ``repeats`` times, displaced to a random position in between.

    The encoder is powered up once (one hidden offset); before every homing the motor is moved
    by hand to a random table position, as in the paper's Table 1 experiment.

    Parameters
    ----------
    spec
        The motor file (its equilibria are the reference).
    sim
        ``"vr"`` or ``"bldc"``.
    seed
        Draws the power-up, the displacements and the friction (>= 0).
    repeats
        Homings (>= 1).
    pulse_width
        Actuation of the energised phase (default full scale).
    friction_fraction
        Bearing friction as a fraction of one phase's peak torque.
    path
        The motor or tables file, named in error messages.
    random
        Home the motor and amplifier of the family's bench ``random``
        (:func:`torquemap.sim.family.random_bench`, ``simulate rig --random``) instead of the
        default ``sim`` motor.

    Returns
    -------
    (list of HomingResult, float)
        The homings and the true encoder offset [table positions] (for comparison).

    Raises
    ------
    InputError
        On a bad seed or repeat count, a motor file that does not match the simulated motor,
        or a failed homing (:func:`torquemap.linearize.homing.home_motor`).
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    if isinstance(repeats, bool) or not isinstance(repeats, int) or repeats < 1:
        raise InputError(f"repeats must be a positive integer, got {repeats!r}")
    if not 0 <= friction_fraction < 1:
        raise InputError(f"friction fraction must be in [0, 1), got {friction_fraction}")
    what = f"simulated {sim} motor"
    motor = amplifier = None
    if random is not None:
        from torquemap.sim.family import random_bench

        bench = random_bench(random)
        motor, amplifier, what = bench.rig.motor, bench.rig.amplifier, f"random motor {random}"
    rig = free_motor_rig(
        sim, motor=motor, amplifier=amplifier, rng=seed, friction_fraction=friction_fraction
    )
    if (spec.phases, spec.positions_per_cycle) != (rig.phases, rig.positions_per_cycle):
        raise InputError(
            f"the motor has {spec.phases} phases and {spec.positions_per_cycle} positions "
            f"per cycle; the {what} has {rig.phases} and {rig.positions_per_cycle}",
            path=path,
        )
    if spec.actuation_max != rig.amplifier.actuation_max:
        raise InputError(
            f"actuation_max {spec.actuation_max} does not match the {what}'s amplifier's "
            f"{rig.amplifier.actuation_max}",
            path=path,
        )
    if random is not None:
        from torquemap.sim.rig import check_family_name

        check_family_name(spec.name, f"random-{random}", what, path)
    results = []
    for _ in range(repeats):
        rig.x = float(rig.rng.uniform(0, rig.positions_per_cycle))
        results.append(home_motor(rig, spec, pulse_width=pulse_width, path=path))
    return results, rig.encoder_offset
