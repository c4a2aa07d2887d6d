"""A family of simulated characterisation benches: one random motor, amplifier and rig per seed.

:func:`random_bench` draws, from one seed, everything the table builder must not assume:

* the motor: variable reluctance (torque ~ current squared, saturating) or brushless DC (torque
  ~ current, cogging), 3 or 4 phases, 128 to 512 table positions per cycle, equilibria off
  their nominal places by up to 3 % of a cycle, phase gains 0.85 .. 1.15, shared-iron coupling
  (mutual saturation) 0 .. 0.4 (VR) or 0 .. 0.12 (BLDC), magnetic saturation, harmonics of
  the torque shape, cogging 0 .. 4 % of peak torque;
* the amplifier: a dead zone of 0 .. 15 % of full scale, a curved pulse-width to current law
  (convex or concave), a smooth onset past the dead zone, a hard or soft current limit;
* the rig: static friction 0 .. 3 % of one phase's full torque, sensor noise 0.2 .. 1 % of it
  per reading, a bias that drifts over the cycle, compliance (1 .. 8 table positions of
  deflection at full torque), a sensor range of 1.3 .. 2 times one phase's full torque;
* the ramp (narrow or wide) and collection settings from the paper's (10 readings, every 4th
  position and pulse width) to dense (40 readings, every 2nd, the ramp's transitions).

:func:`paper_bench` is the same bench with the paper's collection settings. Only tests and
benchmarks look at the truth (:meth:`SimRig.true_torque`, ``settings.friction``).
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from torquemap.errors import InputError
from torquemap.linearize.collect import CollectionSettings, CollectResult
from torquemap.linearize.motor import MotorSpec, RampKind
from torquemap.sim.motors import (
    Amplifier,
    BrushlessDcMotor,
    Motor,
    VariableReluctanceMotor,
    amplifier_current,
    motor_torque,
)
from torquemap.sim.rig import RigSettings, SimRig, collect_on_rig


@dataclasses.dataclass(frozen=True, slots=True, eq=False)
class Bench:
    """One member of the family.

    Attributes
    ----------
    rig
        The simulated bench (motor, amplifier, friction, compliance, sensor).
    ramping
        ``"narrow"`` or ``"wide"``.
    settings
        Collection settings drawn for it (paper's to dense).
    seed
        The seed it was drawn from.
    kind
        ``"vr"`` or ``"bldc"``.
    """

    rig: SimRig
    ramping: RampKind
    settings: CollectionSettings
    seed: int
    kind: str

    def describe(self) -> str:
        """One line: kind, phases, positions, friction and noise relative to full torque."""
        r, s = self.rig, self.rig.settings
        full = _full_torque(r.motor, r.amplifier)
        return (
            f"seed {self.seed}: {self.kind} {r.phases} phases x {r.positions_per_cycle} positions, "
            f"{self.ramping} ramp, dead zone {r.amplifier.dead_band:.0f}, friction "
            f"{100 * s.friction / full:.1f} %, noise {100 * s.noise / full:.2f} % of "
            f"{full:.3g} N m"
        )


def _full_torque(motor: Motor, amplifier: Amplifier) -> float:
    """Largest single-phase torque at full scale over the cycle [N m]."""
    x = np.arange(0.0, motor.positions_per_cycle, 0.5)
    i = amplifier_current(amplifier.actuation_max, amplifier)
    m = len(motor.equilibrium)
    best = 0.0
    for k in range(m):
        cur = np.zeros(m)
        cur[k] = i
        best = max(best, float(np.max(np.abs(motor_torque(motor, x, cur)))))
    return best


def _check(seed: int, what: str = "random seed") -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"{what} must be a non-negative integer, got {seed!r}")
    return int(seed)


def random_bench(seed: int, *, noise_seed: int | None = None) -> Bench:
    """Draw one bench of the family from ``seed`` (deterministic).

    Parameters
    ----------
    seed
        Which member (>= 0).
    noise_seed
        Sensor noise seed of the rig (default: ``seed``).

    Returns
    -------
    Bench
        The rig, its ramping and collection settings.

    Examples
    --------
    >>> b = random_bench(3)
    >>> b.rig.phases in (3, 4) and b.kind in ("vr", "bldc")
    True
    """
    seed = _check(seed)
    if noise_seed is not None:
        _check(noise_seed, "seed")
    g = np.random.default_rng([seed, 0x7E51])
    kind = "vr" if g.random() < 0.5 else "bldc"
    m = int(g.choice([3, 4]))
    n = int(g.choice([128, 192, 256, 384, 512]))
    w = n / m
    # phase k (1-based) drives the positive direction around (k - 1/2) W: its restoring zero
    # lies a quarter cycle on
    nominal = tuple(((k + 0.5) * w + n / 4.0) % n for k in range(m))
    offset = tuple(float(v) for v in g.uniform(-0.03, 0.03, m) * n)
    gain = tuple(float(v) for v in g.uniform(0.85, 1.15, m))
    cogging_periods = int(g.choice([2 * m, 3 * m, 4 * m]))
    motor: Motor
    if kind == "vr":
        peak = float(g.uniform(10.0, 100.0))
        motor = VariableReluctanceMotor(
            positions_per_cycle=n,
            equilibrium=nominal,
            phase_offset=offset,
            phase_gain=gain,
            peak_torque=peak,
            saturation_current=float(g.uniform(5.0, 30.0)),
            second_harmonic=float(g.uniform(-0.25, 0.25)),
            mutual_saturation=float(g.uniform(0.0, 0.4)),
            cogging=float(g.uniform(0.0, 0.02)) * peak,
            cogging_periods=cogging_periods,
            cogging_phase=float(g.uniform(0, 2 * np.pi)),
        )
    else:
        peak = float(g.uniform(1.0, 20.0))
        motor = BrushlessDcMotor(
            positions_per_cycle=n,
            equilibrium=nominal,
            phase_offset=offset,
            phase_gain=gain,
            peak_torque=peak,
            harmonics=(float(g.uniform(0.0, 0.25)), float(g.uniform(0.0, 0.08))),
            cogging=float(g.uniform(0.0, 0.04)) * peak,
            cogging_phase=float(g.uniform(0, 2 * np.pi)),
            mutual_saturation=float(g.uniform(0.0, 0.12)),
            cogging_periods=cogging_periods,
        )
    amplifier = Amplifier(
        dead_band=float(g.uniform(0.0, 0.15)) * 255,
        curve=float(g.uniform(-1.0, 1.0)),
        current_max=10.0,
        current_limit=float(g.uniform(8.5, 10.0)),
        onset=float(g.choice([0.0, float(g.uniform(2.0, 20.0))])),
        soft_limit=float(g.choice([0.0, float(g.uniform(2.0, 8.0))])),
    )
    full = _full_torque(motor, amplifier)
    settings = RigSettings(
        stiffness=full / float(g.uniform(1.0, 8.0)),
        friction=float(g.uniform(0.0, 0.03)) * full,
        noise=float(g.uniform(0.002, 0.01)) * full,
        saturation=float(g.uniform(1.3, 2.0)) * full,
        bias=float(g.uniform(-0.1, 0.1)) * full,
        bias_variation=float(g.uniform(0.0, 0.05)) * full,
        secondary_step=float(g.uniform(0.2, 0.5)),
    )
    ramping: RampKind = "wide" if g.random() < 0.5 else "narrow"
    dense = float(g.random())
    collection = CollectionSettings(
        readings=round(10 + 30 * dense),
        position_step=4 if dense < 0.5 else 2,
        level_step=4 if dense < 0.5 else 2,
        transitions=dense >= 0.75,
        progress=False,
    )
    rig = SimRig(
        motor,
        amplifier,
        settings,
        rng=seed if noise_seed is None else noise_seed,
        name=f"random-{seed}",
    )
    return Bench(rig=rig, ramping=ramping, settings=collection, seed=seed, kind=kind)


def paper_bench(seed: int, *, noise_seed: int | None = None) -> Bench:
    """:func:`random_bench` with the paper's collection: 10 readings, every 4th position and
    pulse width (§4.3)."""
    b = random_bench(seed, noise_seed=noise_seed)
    return dataclasses.replace(b, settings=CollectionSettings.paper(progress=False))


def collect_on_random(
    spec: MotorSpec,
    out_csv: str | os.PathLike[str],
    *,
    random: int,
    seed: int = 0,
    tables: str | os.PathLike[str] | None = None,
    settings: CollectionSettings | None = None,
) -> CollectResult:
    """``linearize collect --random SEED``: collect on the family's bench ``random`` (resumable).

    Parameters
    ----------
    spec
        The motor file (from ``simulate rig --random SEED``): its phases and cycle must match.
    out_csv
        The data file.
    random
        Which bench of the family.
    seed
        Sensor noise seed.
    tables
        TABLES.npz for a verification run.
    settings
        The collection's settings (default: the paper's).

    Returns
    -------
    CollectResult
        What was collected.
    """
    bench = random_bench(random, noise_seed=seed)
    return collect_on_rig(
        bench.rig, spec, out_csv, f"random motor {random}", tables=tables, settings=settings
    )
