"""Automated torque data collection on a characterisation rig (Adept II paper, §4.3, Fig 12).

Two nested loops. The outer loop steps the primary motor through one actuation cycle by
stepping a secondary joint until the motor's table position reaches the next target; at each
target, with all phases off, it measures the force-sensor bias. The inner loop steps the level
(the base pulse width for characterisation, the torque command for verification) from 0 up to
full scale or until the sensor saturates; at each level it consults the ramping function (or the
tables) at the CURRENT position, applies the per-phase actuations, lets the position settle,
averages ``readings`` sensor readings, subtracts the bias (itself the mean of ``bias_readings``,
by default ten times as many, since its error is common to the whole block) and appends the
row, stored under the current position, with the bias it subtracted in a fourth column ``bias``
(so that the table builder can see what the bias held: read at rest, it holds the torque at rest
where cogging alone loads the contact, :mod:`torquemap.linearize.bias`). If the position moves while settling (compliance), the
actuation is looked up again at the new position before measuring (up to 8 times), and the row
is stored under the position the actuation was looked up at, so every row satisfies the DATA.csv
contract.

The collection's settings travel as one :class:`CollectionSettings`. Rows are appended and
flushed as they are measured; after each target's block the record ``DATA.csv.collect.json``
beside the file notes the settings, the motor and the targets done (with their row counts).
Run the same call again on the same file to resume: the targets the record lists are kept,
anything after them (a block cut short) is dropped and every target not yet done is measured,
by position, never by count. A run whose settings or motor differ from the record's is
refused, naming them. A lock file ``DATA.csv.lock`` (created exclusively, holding the pid)
keeps a second run off the same file; a lock left by a killed run is taken over
(docs/linearize-collect.md).

This module talks to hardware only through the :class:`Rig` protocol; it never imports the
simulator.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, TextIO, cast, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.io import atomic_output
from torquemap.linearize.count import check_grid_fits
from torquemap.linearize.motor import MotorSpec, ramped_actuation
from torquemap.linearize.resume import (
    CollectionRecord,
    adaptive_record_path,
    check_same_settings,
    collection_lock,
    motor_identity,
    read_record,
    tables_digest,
    write_record,
)
from torquemap.progress import NULL, Progress, reporter

CHARACTERISATION_COLUMNS = ("position", "pulse_width", "torque")
VERIFICATION_COLUMNS = ("position", "command", "torque")
#: The column after those: the bias subtracted from the row [N m] (an extension of the
#: contract: files without it are still read, and resumed without it).
BIAS_COLUMN = "bias"
#: Default bias readings per target, in multiples of the readings per row.
BIAS_READINGS_FACTOR = 10


@runtime_checkable
class Rig(Protocol):
    """A characterisation bench: the primary motor, its amplifier, a force sensor, a secondary joint.

    Implement these five methods for a real rig (docs/linearize-collect.md has an example).
    A rig that can also lift the primary joint off its constraint may add ``open_contact()``
    (see :func:`collect_characterisation`); it is optional and not part of the protocol.
    """

    def read_position(self) -> int:
        """The primary motor's table position, ``0 .. P - 1``."""
        ...

    def apply(self, actuation: Sequence[int]) -> None:
        """Apply one actuation (pulse width) per phase."""
        ...

    def read_torque(self) -> float:
        """One force-sensor reading, as torque about the primary joint [N m]."""
        ...

    def step_secondary(self) -> None:
        """Move the secondary joint one step (the primary's position moves forward)."""
        ...

    def settle(self) -> None:
        """Wait until the position and the force have settled."""
        ...


@dataclass(frozen=True, slots=True, eq=False)
class CollectResult:
    """What a collection run did.

    Attributes
    ----------
    path
        The data file.
    rows
        Data rows in the file at the end.
    new_rows
        Rows measured by this call.
    targets
        Target positions of the whole run, shape (n_targets,).
    resumed_targets
        Targets found complete in the file and skipped.
    saturated_targets
        Targets (of this call) whose inner loop stopped at sensor saturation.
    elapsed
        Wall time of this call [s].
    bias_column
        Whether the file has the ``bias`` column (False: an older file resumed in its own
        three-column format).
    """

    path: str
    rows: int
    new_rows: int
    targets: NDArray[np.int64]
    resumed_targets: int
    saturated_targets: int
    elapsed: float
    bias_column: bool = True


def collection_targets(
    spec: MotorSpec, *, positions: int | None = None, transitions: bool = False
) -> NDArray[np.int64]:
    """The outer loop's target table positions: ``positions`` evenly spaced over the cycle.

    Parameters
    ----------
    spec
        The motor.
    positions
        How many evenly spaced targets (1 .. P); None for every table position.
    transitions
        Also target every position where the ramp differs from a neighbour's: the phases'
        hand-over, where two phases share the actuation and the torque surface has the most
        structure between positions.

    Returns
    -------
    ndarray of int64
        ``floor(j P / positions)`` for ``j = 0 .. positions - 1`` (with ``transitions``, joined
        with the hand-over positions), ascending.

    Examples
    --------
    >>> from torquemap.linearize.motor import motor_spec
    >>> spec = motor_spec("m", phases=3, positions_per_cycle=512, equilibrium_positions=(0, 1, 2))
    >>> collection_targets(spec, positions=128)[:4].tolist()
    [0, 4, 8, 12]
    """
    n = spec.positions_per_cycle
    k = n if positions is None else int(positions)
    if not 1 <= k <= n:
        raise ValueError(f"positions must be in 1 .. {n}, got {positions}")
    even = (np.arange(k, dtype=np.int64) * n) // k
    if not transitions:
        return even
    ramp = np.asarray(spec.ramp)
    changes = np.any(ramp != np.roll(ramp, 1, axis=0), axis=1)
    changes |= np.any(ramp != np.roll(ramp, -1, axis=0), axis=1)
    return np.union1d(even, np.flatnonzero(changes)).astype(np.int64)


#: Most readings averaged per row or per bias: a guard against typos (days of collection).
MAX_READINGS = 100_000


@dataclass(frozen=True, slots=True, eq=False)
class CollectionSettings:
    """How a collection measures: one object for collect, the CLI, the simulated rig and benchmarks.

    Attributes
    ----------
    readings
        Sensor readings averaged per row (the paper: 10).
    bias_readings
        Sensor readings averaged for the bias at each target; None for
        ``BIAS_READINGS_FACTOR * readings``. The bias is subtracted from every row of the
        target's block, so its error is common to all of them and no later averaging removes
        it: it is measured more precisely than a row.
    bias_open
        Read the bias with the contact open: call the rig's ``open_contact()`` (lift the primary
        joint off its constraint) before the bias readings; the first level closes it again.
        Without it (the paper's procedure) the bias is read at rest, all phases off, and where
        the motor's torque at zero current (cogging) alone pushes the contact beyond its
        friction, that torque is read as bias too: the rows are then relative to the torque at
        rest.
    position_step
        Table positions between targets: ``ceil(P / position_step)`` evenly spaced targets
        (:func:`collection_targets`); 1 for every position (the paper: 4).
    level_step
        Step of the inner loop's level: the base pulse width for characterisation, the torque
        command for verification (``0, k, 2k, ...`` and finally the top; the paper: 4).
    transitions
        Also target every position where the ramp changes (the phases' hand-over).
    progress
        Where progress goes (:mod:`torquemap.progress`): a hook, ``True`` for a bar on stderr
        (plain lines when it is not a terminal), ``False`` for none. Does not change the data.

    Raises
    ------
    InputError
        On a count or step that is not a positive integer.

    Examples
    --------
    >>> s = CollectionSettings(readings=40, position_step=2, level_step=2)
    >>> s.bias_count, s.paper().readings
    (400, 10)
    """

    readings: int = 10
    bias_readings: int | None = None
    bias_open: bool = False
    position_step: int = 4
    level_step: int = 4
    transitions: bool = False
    progress: bool | Progress = True

    def __post_init__(self) -> None:
        for name in ("readings", "position_step", "level_step", "bias_readings"):
            value = getattr(self, name)
            if name == "bias_readings" and value is None:
                continue
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise InputError(
                    f"{name.replace('_', ' ')} must be a positive integer, got {value!r}"
                )
        for name in ("readings", "bias_readings"):
            value = getattr(self, name)
            if value is not None and value > MAX_READINGS:
                raise InputError(
                    f"{name.replace('_', ' ')} must be at most {MAX_READINGS}, got {value}"
                )
        for name in ("bias_open", "transitions"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"{name.replace('_', ' ')} must be true or false")

    @staticmethod
    def paper(**changes: Any) -> CollectionSettings:
        """The paper's collection (§4.3): 10 readings a row, every 4th position and pulse width."""
        return CollectionSettings(
            **{"readings": 10, "position_step": 4, "level_step": 4, **changes}
        )

    @property
    def bias_count(self) -> int:
        """Readings averaged for the bias at each target."""
        return (
            BIAS_READINGS_FACTOR * self.readings
            if self.bias_readings is None
            else int(self.bias_readings)
        )

    def positions(self, spec: MotorSpec) -> int:
        """Number of evenly spaced targets: ``ceil(P / position_step)`` (at most P)."""
        n = spec.positions_per_cycle
        return min(n, -(-n // int(self.position_step)))

    def targets(self, spec: MotorSpec) -> NDArray[np.int64]:
        """The outer loop's targets for ``spec`` (:func:`collection_targets`)."""
        return collection_targets(
            spec, positions=self.positions(spec), transitions=self.transitions
        )

    def as_record(self) -> dict[str, Any]:
        """The settings that change the data, for the collection record (not ``progress``)."""
        return {
            "readings": int(self.readings),
            "bias_readings": int(self.bias_count),
            "bias_open": bool(self.bias_open),
            "position_step": int(self.position_step),
            "level_step": int(self.level_step),
            "transitions": bool(self.transitions),
        }


def _levels(top: int, step: int) -> list[int]:
    levels = list(range(0, top + 1, step))
    if levels[-1] != top:
        levels.append(top)
    return levels


def parse_data_rows(
    path: Path, columns: tuple[str, ...], levels: list[int]
) -> tuple[list[str], bool]:
    """The data lines of ``path`` (a last line torn by an interruption dropped), checked, and
    whether the file has the ``bias`` column (an older file has the three columns alone; an
    empty or absent file gets it)."""
    if not path.exists() or path.stat().st_size == 0:
        return [], True
    lines = path.read_text().splitlines()
    header = ",".join((*columns, BIAS_COLUMN))
    old = ",".join(columns)
    if not lines or lines[0].strip() not in (header, old):
        raise InputError(
            f"existing file is not collection data (header must be {header!r} or, from an "
            f"older version, {old!r})",
            path=path,
        )
    has_bias = lines[0].strip() == header
    width = len(columns) + has_bias
    allowed = set(levels)
    rows: list[str] = []
    for number, line in enumerate(lines[1:], start=2):
        parts = line.split(",")
        try:
            if len(parts) != width:
                raise ValueError
            int(parts[0])
            level = int(parts[1])
            if not all(np.isfinite(float(v)) for v in parts[2:]):
                raise ValueError
        except ValueError:
            if number == len(lines):
                break  # a row torn by the interruption
            raise InputError(f"cannot resume: malformed row at line {number}", path=path) from None
        if level not in allowed:
            raise InputError(
                f"cannot resume: level {level} at line {number} is not on this run's grid "
                "(was the file collected with other settings?)",
                path=path,
            )
        rows.append(line)
    return rows, has_bias or not rows


def _infer_done(
    path: Path, rows: list[str], targets: NDArray[np.int64], n: int
) -> tuple[tuple[int, int], ...]:
    """Targets done in a file without a record (an older run): by the positions in its blocks.

    A block starts at level 0; its target is the last target at or before the block's first
    position (the outer loop may step over a target). The last block may be cut short: it is
    dropped and measured again.
    """
    starts = [i for i, line in enumerate(rows) if line.split(",")[1] == "0"]
    if rows and (not starts or starts[0] != 0):
        raise InputError("cannot resume: line 2 does not start at level 0", path=path)
    done: list[tuple[int, int]] = []
    seen: set[int] = set()
    for a, b in itertools.pairwise(starts):
        position = int(rows[a].split(",")[0])
        behind = (position - targets) % n
        target = int(targets[int(np.argmin(behind))])
        if target in seen:
            raise InputError(
                f"cannot resume: two blocks for target position {target} (line {a + 2}); was "
                "the file collected with other settings?",
                path=path,
            )
        seen.add(target)
        done.append((target, b - a))
    return tuple(done)


def move_to_target(rig: Rig, target: int, n: int, off: list[int], max_steps: int) -> None:
    """Phases off; step the secondary joint until the position reaches ``target``."""
    rig.apply(off)
    rig.settle()
    distance = (target - rig.read_position()) % n
    steps = 0
    while distance != 0:
        rig.step_secondary()
        rig.settle()
        new = (target - rig.read_position()) % n
        if new > distance:
            break  # stepped over the target: store under the position reached
        distance = new
        steps += 1
        if steps > max_steps:
            raise RuntimeError(
                f"the position did not reach {target} after {max_steps} secondary steps"
            )


def _resume_state(
    path: Path,
    columns: tuple[str, ...],
    levels: list[int],
    targets: NDArray[np.int64],
    record: CollectionRecord,
    n: int,
) -> tuple[list[str], tuple[tuple[int, int], ...], bool]:
    """Rows to keep, targets done and whether the file has the bias column, from the file and
    its record; refuses other settings."""
    rows, has_bias = parse_data_rows(path, columns, levels)
    old = read_record(path) if path.exists() else None  # no data: a record left alone is stale
    if old is None:
        if not rows:
            return [], (), True
        if adaptive_record_path(path).exists():
            raise InputError(
                f"cannot resume: the file is an adaptive collection (its record "
                f"{adaptive_record_path(path).name}): resume it with --adaptive",
                path=path,
            )
        done = _infer_done(path, rows, targets, n)
    else:
        kind = (
            [f"kind (this run {record.kind}, the file's {old.kind})"]
            if old.kind != record.kind
            else []
        )
        check_same_settings(
            (record.settings, record.motor), (old.settings, old.motor), path, problems=kind
        )
        done = old.done
    wanted = set(int(t) for t in targets)
    stray = [t for t, _ in done if t not in wanted]
    if stray:
        raise InputError(
            f"cannot resume: the file holds target position {stray[0]}, which is not among this "
            "run's targets (was it collected with other settings?)",
            path=path,
        )
    total = sum(r for _, r in done)
    if total > len(rows):
        raise InputError(
            f"cannot resume: the collection record lists {total} rows, the file holds "
            f"{len(rows)} (was the file edited?)",
            path=path,
        )
    return rows[:total], done, has_bias or total == 0


def data_header(columns: Sequence[str], *, bias: bool) -> str:
    """DATA.csv's header line: ``columns`` and, with ``bias``, the :data:`BIAS_COLUMN`.

    Examples
    --------
    >>> data_header(CHARACTERISATION_COLUMNS, bias=True)
    'position,pulse_width,torque,bias'
    """
    return ",".join((*columns, BIAS_COLUMN) if bias else columns)


def bias_opener(rig: Rig, settings: CollectionSettings) -> Callable[[], None] | None:
    """The rig's ``open_contact()`` when ``settings.bias_open`` (None when the bias is read at
    rest).

    Raises
    ------
    InputError
        If the settings read the bias on an open contact and the rig has no ``open_contact()``.
    """
    if not settings.bias_open:
        return None
    opener = getattr(rig, "open_contact", None)
    if not callable(opener):
        raise InputError("reading the bias on an open contact needs a rig with open_contact()")
    return cast("Callable[[], None]", opener)


def measure_block(
    rig: Rig,
    handle: TextIO,
    levels: Sequence[int],
    actuation: Callable[[int, int], Sequence[int]],
    settings: CollectionSettings,
    *,
    limit: float | None,
    bias_column: bool,
    open_contact: Callable[[], None] | None,
) -> tuple[list[tuple[int, int, float]], bool]:
    """One block at the target the rig stands at (phases off): the bias, then the levels.

    The bias is the mean of ``settings.bias_count`` readings (after ``open_contact()`` when
    given: the sensor then reads its bias alone, without the torque at rest). Each level's
    actuation is looked up at the current position, applied and settled (looked up again at
    the new position if it moved, up to 8 times); the mean of ``settings.readings`` readings
    minus the bias is appended to ``handle`` as a row ``position,level,torque`` (and ``,bias``
    with ``bias_column``) and flushed. A reading at or beyond ``limit`` [N m] ends the block,
    unstored. The caller syncs the file.

    Returns
    -------
    rows, saturated
        The rows written, as (position, level, torque [N m]) with the torque as written (10
        significant digits), and whether the block stopped at the sensor's saturation.
    """
    if open_contact is not None:
        open_contact()
    bias = float(np.mean([rig.read_torque() for _ in range(settings.bias_count)]))
    tail = f",{bias:.10g}" if bias_column else ""
    rows: list[tuple[int, int, float]] = []
    for level in levels:
        position = rig.read_position()
        for _ in range(8):
            consulted = position
            rig.apply(actuation(level, consulted))
            rig.settle()
            position = rig.read_position()
            if position == consulted:
                break
        values = [rig.read_torque() for _ in range(settings.readings)]
        if limit is not None and max(abs(v) for v in values) >= limit:
            return rows, True
        torque = f"{float(np.mean(values)) - bias:.10g}"
        handle.write(f"{consulted},{level},{torque}{tail}\n")
        handle.flush()
        rows.append((consulted, level, float(torque)))  # as written: a resume reads the same
    return rows, False


def _collect(
    rig: Rig,
    spec: MotorSpec,
    out_csv: str | os.PathLike[str],
    settings: CollectionSettings,
    *,
    columns: tuple[str, str, str],
    levels: list[int],
    actuation: Callable[[int, int], Sequence[int]],
    saturation: float | None,
    extra: Mapping[str, Any],
) -> CollectResult:
    start = time.perf_counter()
    open_contact = bias_opener(rig, settings)
    path = Path(out_csv)
    if not path.parent.exists():
        raise InputError("output folder does not exist", path=path.parent)
    n = spec.positions_per_cycle
    targets = settings.targets(spec)
    kind = "characterisation" if columns == CHARACTERISATION_COLUMNS else "verification"
    record = CollectionRecord(
        kind=kind,
        settings=settings.as_record(),
        motor={**motor_identity(spec), **extra},
        done=(),
    )
    limit = saturation if saturation is not None else getattr(rig, "saturation", None)
    off = [0] * spec.phases
    new_rows = 0
    saturated = 0
    with collection_lock(path):
        kept, done, has_bias = _resume_state(path, columns, levels, targets, record, n)
        header = data_header(columns, bias=has_bias)
        with atomic_output(path) as tmp:
            tmp.write_text("\n".join([header, *kept]) + "\n")
        finished = {t for t, _ in done}
        todo = [int(t) for t in targets if int(t) not in finished]
        resumed = len(done)
        done_list = list(done)
        write_record(path, dataclasses.replace(record, done=tuple(done_list)))
        label = f"collect {targets.size} positions" + (
            f" (resuming after {resumed})" if resumed else ""
        )
        with (
            path.open("a") as handle,
            _progress(settings.progress).step(label, total=int(targets.size)) as bar,
        ):
            bar.advance(resumed)
            for target in todo:
                move_to_target(rig, target, n, off, max_steps=100 * n)
                measured, stopped = measure_block(
                    rig,
                    handle,
                    levels,
                    actuation,
                    settings,
                    limit=limit,
                    bias_column=has_bias,
                    open_contact=open_contact,
                )
                saturated += stopped
                block = len(measured)
                os.fsync(handle.fileno())
                done_list.append((target, block))
                write_record(path, dataclasses.replace(record, done=tuple(done_list)))
                new_rows += block
                bar.advance()
                bar.describe(f"position {target}/{n}")
            rig.apply(off)
    return CollectResult(
        path=os.fspath(path),
        rows=len(kept) + new_rows,
        new_rows=new_rows,
        targets=targets,
        resumed_targets=resumed,
        saturated_targets=saturated,
        elapsed=time.perf_counter() - start,
        bias_column=has_bias,
    )


def _progress(progress: bool | Progress | None) -> Progress:
    """A hook as given; ``True`` for the default reporter on stderr, ``False``/``None`` for none."""
    if isinstance(progress, Progress):
        return progress
    return reporter() if progress else NULL


def collect_characterisation(
    rig: Rig,
    spec: MotorSpec,
    out_csv: str | os.PathLike[str],
    settings: CollectionSettings | None = None,
    *,
    saturation: float | None = None,
) -> CollectResult:
    """Collect the motor's torque vs position vs pulse width into DATA.csv (paper Fig 12).

    Parameters
    ----------
    rig
        The bench.
    spec
        The motor: cycle length, phases, full-scale pulse width, ramp.
    out_csv
        DATA.csv: columns ``position, pulse_width, torque, bias`` [N m], appended row by row
        (``bias``: the bias subtracted from the row's torque); resumed if it exists (by the
        targets its record lists, see the module docstring). An older file without the
        ``bias`` column is resumed in its own format.
    settings
        Readings, bias, steps, transitions, progress (default: the paper's,
        :class:`CollectionSettings`). ``level_step`` is the base pulse width's step.
    saturation
        Sensor range [N m]: a reading at or beyond it ends the inner loop, unstored. None: the
        rig's ``saturation`` attribute if it has one, else no check.

    Returns
    -------
    CollectResult
        Rows, targets, resume and saturation counts, time.

    Raises
    ------
    InputError
        If the existing file cannot be resumed (other header, other settings or motor than
        its record's, malformed rows), another run holds the file's lock, the bias is to be
        read on an open contact on a rig without ``open_contact()``, or the motor file's grid
        is larger than the tables are built on (:func:`~torquemap.linearize.count.
        check_grid_fits`, before any reading).
    """
    check_grid_fits(spec.positions_per_cycle, spec.actuation_max, path=spec.path)
    s = CollectionSettings() if settings is None else settings
    ramp = spec.ramp
    return _collect(
        rig,
        spec,
        out_csv,
        s,
        columns=CHARACTERISATION_COLUMNS,
        levels=_levels(spec.actuation_max, s.level_step),
        actuation=lambda level, position: ramped_actuation(level, position, ramp).tolist(),
        saturation=saturation,
        extra={},
    )


def _phase_tables(spec: MotorSpec, tables: Mapping[str, NDArray[np.integer]]) -> NDArray[np.int64]:
    shape = (spec.positions_per_cycle, 2**spec.command_bits)
    out = np.empty((spec.phases, *shape), dtype=np.int64)
    for k in range(spec.phases):
        name = f"phase_{k + 1}"
        if name not in tables:
            raise InputError(
                f"tables lack {name!r} (have {', '.join(sorted(tables))}): the motor has "
                f"{spec.phases} phases; are the tables for another motor?"
            )
        table = np.asarray(tables[name])
        if table.shape != shape:
            raise InputError(
                f"table {name!r} has shape {table.shape}, expected {shape} (positions per "
                "cycle x commands): are the tables for another motor?"
            )
        if not np.issubdtype(table.dtype, np.integer):
            raise InputError(f"table {name!r} must hold integers, got {table.dtype}")
        if table.min() < 0 or table.max() > spec.actuation_max:
            raise InputError(f"table {name!r} holds values outside 0 .. {spec.actuation_max}")
        out[k] = table
    extra = sorted(
        name
        for name in tables
        if name.startswith("phase_")
        and name[6:].isdigit()
        and not 1 <= int(name[6:]) <= spec.phases
    )
    if extra:
        raise InputError(
            f"tables hold {', '.join(extra)} but the motor has {spec.phases} phases: are the "
            "tables for another motor?"
        )
    return out


def collect_verification(
    rig: Rig,
    spec: MotorSpec,
    tables: Mapping[str, NDArray[np.integer]],
    out_csv: str | os.PathLike[str],
    settings: CollectionSettings | None = None,
    *,
    saturation: float | None = None,
) -> CollectResult:
    """Collect torque vs position vs torque command through the tables (paper §5.3 "after").

    As :func:`collect_characterisation`, but the inner loop steps the torque command
    ``c = 0 .. 2**(bits - 1) - 1`` (by ``settings.level_step``) and phase ``k`` receives
    ``tables["phase_k"][p, c mod 2**bits]`` at the current position ``p``. Writes
    ``position, command, torque, bias``. A resumed run must use the same tables (their digest is in
    the record).

    Parameters
    ----------
    tables
        ``phase_1 .. phase_m``: integer arrays of shape ``(P, 2**command_bits)``.
    rig, spec, out_csv, settings, saturation
        As for :func:`collect_characterisation`.

    Raises
    ------
    InputError
        On missing tables, a wrong shape, non-integer or out-of-range entries, or a file that
        cannot be resumed.
    """
    s = CollectionSettings() if settings is None else settings
    stack = _phase_tables(spec, tables)
    width = 2**spec.command_bits
    return _collect(
        rig,
        spec,
        out_csv,
        s,
        columns=VERIFICATION_COLUMNS,
        levels=_levels(width // 2 - 1, s.level_step),
        actuation=lambda level, position: stack[
            :, position % spec.positions_per_cycle, level % width
        ].tolist(),
        saturation=saturation,
        extra={"tables_sha256": tables_digest(stack)},
    )


def read_tables_npz(path: str | os.PathLike[str], spec: MotorSpec) -> dict[str, NDArray[np.int64]]:
    """Read phase tables from ``.npz`` for :func:`collect_verification`.

    Parameters
    ----------
    path
        A numpy ``.npz`` with integer arrays ``phase_1 .. phase_m`` of shape
        ``(P, 2**command_bits)``, entry ``[p, c mod 2**bits]``.
    spec
        The motor the tables are for.

    Returns
    -------
    dict of str to ndarray
        ``phase_k`` to its table.

    Raises
    ------
    InputError
        On a missing or unreadable file, a missing table, a wrong shape, entries that are
        not integers in ``0 .. actuation_max``, or tables of ``linearize build`` (with their
        metadata) built for another motor (:func:`torquemap.linearize.metrics.check_tables_fit`)
        or with entries in other units than the motor's pulse widths (``actuation_bits``).
    """
    from torquemap.linearize.export import load_tables, read_npz_arrays
    from torquemap.linearize.metrics import check_tables_fit

    p = os.fspath(path)
    tables = read_npz_arrays(p)
    if "motor_name" in tables:  # a TABLES.npz of `linearize build`: for this motor?
        built = load_tables(p)
        check_tables_fit(spec, built, path=p)
        if built.actuation_max != spec.actuation_max:
            # entries rescaled to 2**bits - 1 (build --actuation-bits) are not pulse widths:
            # applied as such, 6-bit tables drove the motor at a quarter scale (APMD 1475 %)
            raise InputError(
                f"table entries run 0 .. {built.actuation_max} (built with --actuation-bits), "
                f"the motor's pulse widths 0 .. {spec.actuation_max}: the verification applies "
                "entries as pulse widths; verify the tables built without --actuation-bits",
                path=p,
            )
    try:
        stack = _phase_tables(spec, tables)
    except InputError as exc:
        raise InputError(exc.message, path=p) from None
    return {f"phase_{k + 1}": stack[k] for k in range(spec.phases)}
