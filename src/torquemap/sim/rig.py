"""A simulated motor characterisation bench (Adept II paper, §4.3 and Fig 11) implementing ``Rig``.

The primary joint's motor presses against an inclined constraint through a force sensor; a
secondary joint steps the contact point, and so the primary motor's table position, through
one actuation cycle. What the bench adds to the motor physics (:mod:`torquemap.sim.motors`):

* Compliance: the robot, the constraint and the sensor comply as a spring of ``stiffness``
  [N m per table position]; the motor sits at ``base + force / stiffness`` and the encoder
  reads that position rounded (wrapped into the cycle). The torque is that of the deflected
  position: the settled contact force solves ``f = T(base + f / k)``.
* Friction: a static friction band of half width ``friction`` [N m] between motor and
  constraint (a play operator): the contact force only follows the motor torque once the
  torque leaves the band ``[f - friction, f + friction]`` around the current force. Stepping
  the secondary joint unloads the contact.
* Force sensor: one reading is ``bias(base) + f + noise``, clipped at ``+-saturation``; the
  bias (gravity, preload) depends on the secondary joint's configuration, i.e. on ``base``.

:meth:`SimRig.true_torque` is the noise-free physics (motor and amplifier only) for benchmarks.
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.io import atomic_outputs, output_folder, toml_writer
from torquemap.linearize.collect import (
    CollectionSettings,
    CollectResult,
    collect_characterisation,
    collect_verification,
    read_tables_npz,
)
from torquemap.linearize.motor import MotorSpec, RampKind, motor_spec, motor_to_dict
from torquemap.linearize.resume import read_record, record_path, write_record
from torquemap.sim.motors import (
    Amplifier,
    BrushlessDcMotor,
    Motor,
    VariableReluctanceMotor,
    amplifier_current,
    motor_torque,
    torque_at,
)


@dataclasses.dataclass(frozen=True, slots=True, eq=False)
class RigSettings:
    """Everything about the bench except the motor physics.

    Attributes
    ----------
    stiffness
        Combined stiffness of robot, constraint and sensor [N m per table position].
    friction
        Half width of the static friction band [N m].
    noise
        Standard deviation of one sensor reading [N m].
    saturation
        Sensor range [N m]; readings are clipped at +-saturation.
    bias
        Mean sensor bias [N m].
    bias_variation
        Amplitude of the bias's change over the cycle [N m].
    secondary_step
        How far one step of the secondary joint moves the primary motor [table positions].
    start_position
        Where the primary motor starts [table positions].
    """

    stiffness: float
    friction: float
    noise: float
    saturation: float
    bias: float
    bias_variation: float
    secondary_step: float = 0.4
    start_position: float = 0.0


class SimRig:
    """A simulated characterisation bench: a motor, its amplifier, compliance, friction, sensor.

    Implements :class:`torquemap.linearize.collect.Rig`. Build one with
    :func:`variable_reluctance_rig` or :func:`brushless_dc_rig`.

    Parameters
    ----------
    motor
        The motor physics.
    amplifier
        The amplifier (its ``actuation_max`` is the full-scale pulse width).
    settings
        Compliance, friction and sensor.
    rng
        Noise source (Generator, seed, or None for fresh entropy).
    name
        Motor name for :meth:`motor_spec`.
    """

    def __init__(
        self,
        motor: Motor,
        amplifier: Amplifier,
        settings: RigSettings,
        *,
        rng: np.random.Generator | int | None = None,
        name: str = "sim",
    ) -> None:
        self.motor = motor
        self.amplifier = amplifier
        self.settings = settings
        self.name = name
        self.rng = np.random.default_rng(rng)
        self.phases = len(motor.equilibrium)
        self.positions_per_cycle = motor.positions_per_cycle
        self.saturation = settings.saturation
        self.base = float(settings.start_position)
        self.actuation = np.zeros(self.phases, dtype=np.int64)
        self.force = 0.0

    # -- physics ---------------------------------------------------------------------------
    def true_torque(self, position: ArrayLike, actuation: ArrayLike) -> NDArray[np.float64]:
        """Noise-free motor torque [N m] for per-phase actuations at table position(s).

        Motor and amplifier only: no compliance, friction, bias, noise or sensor saturation.

        Parameters
        ----------
        position
            Table position(s), shape ``(...)`` broadcasting with ``actuation[..., 0]``.
        actuation
            Pulse width per phase, shape ``(..., m)``.

        Returns
        -------
        ndarray
            Torque in the positive direction [N m].
        """
        return motor_torque(self.motor, position, amplifier_current(actuation, self.amplifier))

    def equilibrium_positions(self) -> tuple[int, ...]:
        """Where each phase, energised alone at full scale, settles [table positions].

        The zero of that phase's torque with a restoring (negative) slope, found on a grid of
        1/16 table position and rounded.
        """
        n = self.positions_per_cycle
        x = np.arange(0.0, n, 1.0 / 16.0)
        out = []
        for k in range(self.phases):
            act = np.zeros(self.phases)
            act[k] = self.amplifier.actuation_max
            t = self.true_torque(x, act)
            down = np.flatnonzero((t > 0) & (np.roll(t, -1) <= 0))
            # the crossing with the largest slope (cogging can add shallow ones)
            slope = t[down] - np.roll(t, -1)[down]
            j = down[int(np.argmax(slope))]
            root = x[j] + t[j] / (t[j] - t[(j + 1) % x.size]) / 16.0
            out.append(round(root) % n)
        return tuple(out)

    def motor_spec(self, *, ramping: RampKind = "wide") -> MotorSpec:
        """The :class:`MotorSpec` of this motor, with equilibria from the physics."""
        return motor_spec(
            self.name,
            phases=self.phases,
            positions_per_cycle=self.positions_per_cycle,
            equilibrium_positions=self.equilibrium_positions(),
            ramping=ramping,
            actuation_max=self.amplifier.actuation_max,
        )

    def bias_at(self, base: float) -> float:
        """Sensor bias [N m] with the secondary joint at ``base`` [table positions]."""
        s = self.settings
        return s.bias + s.bias_variation * math.sin(
            2.0 * math.pi * base / self.positions_per_cycle + 0.3
        )

    # -- the Rig protocol ------------------------------------------------------------------
    def read_position(self) -> int:
        """Encoder: the deflected motor position, rounded, in ``0 .. P - 1``."""
        x = self.base + self.force / self.settings.stiffness
        return math.floor(x + 0.5) % self.positions_per_cycle

    def apply(self, actuation: Sequence[int]) -> None:
        """Set the pulse width of every phase (takes effect at :meth:`settle`)."""
        act = np.asarray(actuation, dtype=np.int64)
        if act.shape != (self.phases,):
            raise ValueError(f"need {self.phases} actuations, got {act.shape}")
        if act.min() < 0 or act.max() > self.amplifier.actuation_max:
            raise ValueError(f"actuation outside 0 .. {self.amplifier.actuation_max}: {act}")
        self.actuation = act

    def settle(self) -> None:
        """Let the contact force settle: the fixed point of compliance and friction."""
        s = self.settings
        held = self.force
        f = held
        current = amplifier_current(self.actuation, self.amplifier).tolist()
        for _ in range(60):
            t = torque_at(self.motor, self.base + f / s.stiffness, current)
            if t - s.friction > held:
                new = t - s.friction
            elif t + s.friction < held:
                new = t + s.friction
            else:
                new = held
            new = max(new, 0.0)  # the constraint only pushes
            if abs(new - f) < 1e-10:
                f = new
                break
            f = new
        self.force = f

    def read_torque(self) -> float:
        """One force-sensor reading as torque [N m]: bias + contact torque + noise, clipped."""
        s = self.settings
        r = self.bias_at(self.base) + self.force + s.noise * float(self.rng.standard_normal())
        return float(min(max(r, -s.saturation), s.saturation))

    def open_contact(self) -> None:
        """Lift the motor off the constraint: the contact unloads until the next settle (the
        optional hook of ``collect_characterisation(..., bias_open=True)``)."""
        self.force = 0.0

    def step_secondary(self) -> None:
        """Move the secondary joint one step; the contact unloads."""
        self.base = (self.base + self.settings.secondary_step) % self.positions_per_cycle
        self.force = 0.0


_VR_SETTINGS = RigSettings(
    stiffness=15.0,
    friction=0.8,
    noise=0.25,
    saturation=60.0,
    bias=3.0,
    bias_variation=1.5,
)
_BLDC_SETTINGS = RigSettings(
    stiffness=4.0,
    friction=0.06,
    noise=0.02,
    saturation=12.0,
    bias=0.6,
    bias_variation=0.2,
)


def _build(
    kind: Literal["vr", "bldc"],
    rng: np.random.Generator | int | None,
    overrides: dict[str, Any],
) -> SimRig:
    motor: Motor = VariableReluctanceMotor() if kind == "vr" else BrushlessDcMotor()
    amplifier = Amplifier() if kind == "vr" else Amplifier(dead_band=12.0, curve=0.4)
    settings = _VR_SETTINGS if kind == "vr" else _BLDC_SETTINGS
    name = "sim-vr" if kind == "vr" else "sim-bldc"
    fields = {f.name for f in dataclasses.fields(RigSettings)}
    rest: dict[str, Any] = {}
    for key, value in overrides.items():
        if key == "motor":
            motor = value
        elif key == "amplifier":
            amplifier = value
        elif key == "name":
            name = value
        elif key in fields:
            rest[key] = value
        else:
            raise TypeError(f"unknown rig option {key!r}")
    settings = dataclasses.replace(settings, **rest)
    return SimRig(motor, amplifier, settings, rng=rng, name=name)


def variable_reluctance_rig(
    *, rng: np.random.Generator | int | None = None, **overrides: Any
) -> SimRig:
    """The rig with the VR motor (Adept II joints 1/2 style) and its default bench.

    Parameters
    ----------
    rng
        Sensor noise source.
    **overrides
        ``motor``, ``amplifier``, ``name`` or any :class:`RigSettings` field.

    Examples
    --------
    >>> rig = variable_reluctance_rig(rng=0)
    >>> rig.motor_spec().equilibrium_positions
    (213, 387, 41)
    >>> float(rig.true_torque(100, [255, 0, 0])) > 50.0  # phase 1 near its peak [N m]
    True
    """
    return _build("vr", rng, overrides)


def brushless_dc_rig(*, rng: np.random.Generator | int | None = None, **overrides: Any) -> SimRig:
    """The rig with the brushless DC motor (Adept II joints 3/4 style) and its default bench.

    Parameters
    ----------
    rng
        Sensor noise source.
    **overrides
        ``motor``, ``amplifier``, ``name`` or any :class:`RigSettings` field.
    """
    return _build("bldc", rng, overrides)


def sim_rig(
    kind: Literal["vr", "bldc"], *, rng: np.random.Generator | int | None = None, **overrides: Any
) -> SimRig:
    """:func:`variable_reluctance_rig` (``"vr"``) or :func:`brushless_dc_rig` (``"bldc"``)."""
    if kind not in ("vr", "bldc"):
        raise InputError(f"unknown simulated motor {kind!r} (use vr or bldc)")
    return _build(kind, rng, overrides)


def _check_seed(seed: int) -> None:
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")


def collect_on_sim(
    spec: MotorSpec,
    out_csv: str | os.PathLike[str],
    *,
    sim: Literal["vr", "bldc"],
    seed: int = 0,
    tables: str | os.PathLike[str] | None = None,
    settings: CollectionSettings | None = None,
) -> CollectResult:
    """Run ``linearize collect`` against a simulated rig (resuming ``out_csv`` if it exists).

    Parameters
    ----------
    spec
        The motor file; its phases and cycle length must match the simulated motor's.
    out_csv
        DATA.csv (characterisation) or the verification data (with ``tables``).
    sim
        ``"vr"`` or ``"bldc"``.
    seed
        Sensor noise seed (>= 0).
    tables
        TABLES.npz (``phase_1 .. phase_m``, shape ``(P, 2**bits)``) for a verification run.
    settings
        The collection's settings (default: the paper's, :class:`CollectionSettings`).

    Returns
    -------
    CollectResult
        What was collected.

    Raises
    ------
    InputError
        On a bad seed, a spec that does not match the rig, a bad tables file, or a data file
        that cannot be resumed.
    """
    _check_seed(seed)
    rig = sim_rig(sim, rng=seed)
    return collect_on_rig(
        rig, spec, out_csv, f"simulated {sim} motor", tables=tables, settings=settings
    )


def check_rig_fits(rig: SimRig, spec: MotorSpec, what: str) -> None:
    """Raise InputError (naming the motor file) if ``spec`` does not fit ``rig``."""
    if (spec.phases, spec.positions_per_cycle) != (rig.phases, rig.positions_per_cycle):
        raise InputError(
            f"the motor file has {spec.phases} phases and {spec.positions_per_cycle} positions "
            f"per cycle; the {what} has {rig.phases} and {rig.positions_per_cycle}",
            path=spec.path,
        )
    if spec.actuation_max != rig.amplifier.actuation_max:
        raise InputError(
            f"actuation_max {spec.actuation_max} does not match the simulated amplifier's "
            f"{rig.amplifier.actuation_max}",
            path=spec.path,
        )
    check_family_name(spec.name, rig.name, what, spec.path)


def check_family_name(
    file_name: str, rig_name: str, what: str, path: str | os.PathLike[str] | None
) -> None:
    """Refuse a motor file of one bench of the family (``random-N``) on another's rig.

    Benches of the family share shapes (304 and 321: 3 phases x 128 positions, full scale
    255), so a mistyped ``--random`` collected or homed another motor under this file without a
    word; the file's name is the bench it was written for.
    """
    family = file_name.startswith("random-") and rig_name.startswith("random-")
    if family and file_name != rig_name:
        raise InputError(
            f"the motor file is {file_name!r} (simulate rig --random "
            f"{file_name.removeprefix('random-')}); the {what} is {rig_name!r}",
            path=path,
        )


def collect_on_rig(
    rig: SimRig,
    spec: MotorSpec,
    out_csv: str | os.PathLike[str],
    what: str,
    *,
    tables: str | os.PathLike[str] | None = None,
    settings: CollectionSettings | None = None,
) -> CollectResult:
    """Characterise (or, with ``tables``, verify) on ``rig`` after checking that ``spec`` fits.

    ``what`` names the rig in the message when the motor file does not match it.
    """
    check_rig_fits(rig, spec, what)
    s = CollectionSettings() if settings is None else settings
    if tables is None:
        return collect_characterisation(rig, spec, out_csv, s)
    return collect_verification(rig, spec, read_tables_npz(tables, spec), out_csv, s)


#: Most readings per row (or per bias measurement) a simulated run takes.


def write_rig_data(
    out_dir: str | os.PathLike[str],
    *,
    motor: Literal["vr", "bldc"] = "vr",
    seed: int = 0,
    ramping: RampKind = "wide",
    settings: CollectionSettings | None = None,
) -> CollectResult:
    """A full characterisation run on a simulated rig: ``motor.toml`` and ``data.csv`` in a folder.

    The data is collected into a temporary file and renamed onto ``data.csv`` at the end, so an
    existing ``data.csv`` is replaced whole or not at all.

    Parameters
    ----------
    out_dir
        Output folder (created).
    motor
        ``"vr"`` or ``"bldc"``.
    seed
        Sensor noise seed (>= 0); the output is a function of the arguments alone.
    ramping
        Ramping function written into motor.toml and used for the collection.
    settings
        The collection's settings (default: the paper's, without a progress bar).

    Returns
    -------
    CollectResult
        What was collected (its ``path`` is the final data.csv).

    Raises
    ------
    InputError
        On a bad seed or ramping, or an output path that is not a folder.
    """
    _check_seed(seed)
    rig = sim_rig(motor, rng=seed)
    return write_rig_folder(out_dir, rig, ramping=ramping, settings=settings)


def write_rig_folder(
    out_dir: str | os.PathLike[str],
    rig: SimRig,
    *,
    ramping: RampKind = "wide",
    settings: CollectionSettings | None = None,
) -> CollectResult:
    """Characterise ``rig`` into ``out_dir/motor.toml`` and ``out_dir/data.csv`` (whole or not at all).

    Parameters
    ----------
    out_dir
        Output folder (created).
    rig
        The simulated bench.
    ramping
        Ramping function written into motor.toml and used for the collection.
    settings
        The collection's settings (default: the paper's, without a progress bar).

    Returns
    -------
    CollectResult
        What was collected (its ``path`` is the final data.csv).
    """
    if ramping not in ("narrow", "wide"):
        raise InputError(f"ramping must be narrow or wide, got {ramping!r}")
    s = CollectionSettings(progress=False) if settings is None else settings
    spec = rig.motor_spec(ramping=ramping)
    out = Path(out_dir)
    target = out / "data.csv"
    # data.csv and motor.toml both or neither; a folder created here is removed on failure
    with output_folder(out), atomic_outputs([target, out / "motor.toml"]) as (tmp, tmp_motor):
        partial = tmp.with_name(tmp.name + ".csv")  # still a recognisable temporary
        try:
            result = collect_characterisation(rig, spec, partial, s)
            record = read_record(partial)
            os.replace(partial, tmp)
        finally:
            partial.unlink(missing_ok=True)
            record_path(partial).unlink(missing_ok=True)
        toml_writer(motor_to_dict(spec))(tmp_motor)
    if record is not None:
        # the record stays beside data.csv as a real collection's does: `linearize build` reads
        # the bias readings' weight from it, and a later `linearize collect` resumes from it
        write_record(target, record)
    return dataclasses.replace(result, path=os.fspath(target))
