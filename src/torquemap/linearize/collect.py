"""Automated torque data collection on a characterisation rig (Adept II paper, §4.3, Fig 12).

Two nested loops. The outer loop steps the primary motor through one actuation cycle by
stepping a secondary joint until the motor's table position reaches the next target; at each
target, with all phases off, it measures the force-sensor bias. The inner loop steps the level
(the base pulse width for characterisation, the torque command for verification) from 0 up to
full scale or until the sensor saturates; at each level it consults the ramping function (or the
tables) at the CURRENT position, applies the per-phase actuations, lets the position settle,
averages ``readings`` sensor readings, subtracts the bias (itself the mean of ``bias_readings``,
by default ten times as many, since its error is common to the whole block) and appends the
row, stored under the current position. If the position moves while settling (compliance), the
actuation is looked up again at the new position before measuring (up to 8 times), and the row
is stored under the position the actuation was looked up at, so every row satisfies the DATA.csv
contract.

Rows are appended and flushed as they are measured. Run the same call again on the same file to
resume: complete position blocks are kept, the last block (possibly cut short) is measured
again, and collection continues with the next target (docs/linearize-collect.md).

This module talks to hardware only through the :class:`Rig` protocol; it never imports the
simulator.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.io import atomic_output
from torquemap.linearize.motor import MotorSpec, ramped_actuation
from torquemap.progress import NULL, Progress, reporter

CHARACTERISATION_COLUMNS = ("position", "pulse_width", "torque")
VERIFICATION_COLUMNS = ("position", "command", "torque")
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
    """

    path: str
    rows: int
    new_rows: int
    targets: NDArray[np.int64]
    resumed_targets: int
    saturated_targets: int
    elapsed: float


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


def _levels(top: int, step: int, what: str) -> list[int]:
    if step < 1:
        raise ValueError(f"{what} must be >= 1, got {step}")
    levels = list(range(0, top + 1, step))
    if levels[-1] != top:
        levels.append(top)
    return levels


def _existing_rows(path: Path, header: str, levels: list[int]) -> list[str]:
    """Lines of complete blocks already in ``path`` (the last block is dropped: redo it)."""
    if not path.exists() or path.stat().st_size == 0:
        return []
    lines = path.read_text().splitlines()
    if not lines or lines[0].strip() != header:
        raise InputError(
            f"existing file is not collection data (header must be {header!r})", path=path
        )
    allowed = set(levels)
    rows: list[str] = []
    starts: list[int] = []
    for number, line in enumerate(lines[1:], start=2):
        parts = line.split(",")
        try:
            if len(parts) != 3:
                raise ValueError
            int(parts[0])
            level = int(parts[1])
            float(parts[2])
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
        if level == 0:
            starts.append(len(rows))
        elif not starts:
            raise InputError(f"cannot resume: line {number} does not start at level 0", path=path)
        rows.append(line)
    return rows[: starts[-1]] if starts else []


def _move_to(rig: Rig, target: int, n: int, off: list[int], max_steps: int) -> None:
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


def _collect(
    rig: Rig,
    spec: MotorSpec,
    out_csv: str | os.PathLike[str],
    *,
    columns: tuple[str, str, str],
    levels: list[int],
    actuation: Callable[[int, int], Sequence[int]],
    readings: int,
    bias_readings: int | None,
    bias_open: bool,
    positions: int | None,
    transitions: bool,
    saturation: float | None,
    progress: bool | Progress | None,
) -> CollectResult:
    start = time.perf_counter()
    if readings < 1:
        raise ValueError(f"readings must be >= 1, got {readings}")
    bias_count = BIAS_READINGS_FACTOR * readings if bias_readings is None else bias_readings
    if bias_count < 1:
        raise ValueError(f"bias_readings must be >= 1, got {bias_count}")
    if bias_open and not callable(getattr(rig, "open_contact", None)):
        raise ValueError("bias_open needs a rig with an open_contact() method")
    path = Path(out_csv)
    if not path.parent.exists():
        raise InputError("output folder does not exist", path=path.parent)
    n = spec.positions_per_cycle
    targets = collection_targets(spec, positions=positions, transitions=transitions)
    header = ",".join(columns)
    kept = _existing_rows(path, header, levels)
    done = sum(1 for line in kept if line.split(",")[1] == "0")
    if done > targets.size:
        raise InputError(
            f"cannot resume: the file holds {done} position blocks, the run has {targets.size} "
            "targets (was it collected with other settings?)",
            path=path,
        )
    with atomic_output(path) as tmp:
        tmp.write_text("\n".join([header, *kept]) + "\n")
    limit = saturation if saturation is not None else getattr(rig, "saturation", None)
    open_contact = getattr(rig, "open_contact", None) if bias_open else None
    off = [0] * spec.phases
    new_rows = 0
    saturated = 0
    label = f"collect {targets.size} positions" + (f" (resuming after {done})" if done else "")
    with path.open("a") as handle, _progress(progress).step(label, total=targets.size) as bar:
        bar.advance(done)
        for target in targets[done:]:
            _move_to(rig, int(target), n, off, max_steps=100 * n)
            if open_contact is not None:
                open_contact()  # the sensor reads its bias alone, without the torque at rest
            bias = float(np.mean([rig.read_torque() for _ in range(bias_count)]))
            for level in levels:
                position = rig.read_position()
                for _ in range(8):
                    consulted = position
                    rig.apply(actuation(level, consulted))
                    rig.settle()
                    position = rig.read_position()
                    if position == consulted:
                        break
                values = [rig.read_torque() for _ in range(readings)]
                if limit is not None and max(abs(v) for v in values) >= limit:
                    saturated += 1
                    break
                torque = float(np.mean(values)) - bias
                handle.write(f"{consulted},{level},{torque:.10g}\n")
                handle.flush()
                new_rows += 1
            bar.advance()
            bar.describe(f"position {int(target)}/{n}")
        rig.apply(off)
    return CollectResult(
        path=os.fspath(path),
        rows=len(kept) + new_rows,
        new_rows=new_rows,
        targets=targets,
        resumed_targets=done,
        saturated_targets=saturated,
        elapsed=time.perf_counter() - start,
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
    *,
    readings: int = 10,
    bias_readings: int | None = None,
    bias_open: bool = False,
    pulse_step: int = 1,
    positions: int | None = None,
    transitions: bool = False,
    saturation: float | None = None,
    progress: bool | Progress | None = True,
) -> CollectResult:
    """Collect the motor's torque vs position vs pulse width into DATA.csv (paper Fig 12).

    Parameters
    ----------
    rig
        The bench.
    spec
        The motor: cycle length, phases, full-scale pulse width, ramp.
    out_csv
        DATA.csv: columns ``position, pulse_width, torque`` [N m], appended row by row;
        resumed if it exists.
    readings
        Sensor readings averaged per row.
    bias_readings
        Sensor readings averaged for the bias at each target (default ``10 * readings``). The
        bias is subtracted from every row of the target's block, so its error is common to all
        of them and no later averaging removes it: it is measured more precisely than a row.
    bias_open
        Read the bias with the contact open: call the rig's ``open_contact()`` (lift the primary
        joint off its constraint) before the bias readings; the first level closes it again.
        Without it (the paper's procedure) the bias is read at rest, all phases off, and where
        the motor's torque at zero current (cogging) alone pushes the contact beyond its
        friction, that torque is read as bias too: the rows are then relative to the torque at
        rest.
    pulse_step
        Step of the base pulse width (``0, k, 2k, ...`` and finally ``actuation_max``).
    positions
        Number of evenly spaced target positions in the cycle (None: all ``P``).
    transitions
        Also target every position where the ramp changes (:func:`collection_targets`).
    saturation
        Sensor range [N m]: a reading at or beyond it ends the inner loop, unstored. None: the
        rig's ``saturation`` attribute if it has one, else no check.
    progress
        Where progress goes (:mod:`torquemap.progress`): a hook, or ``True`` for a bar on
        stderr (plain lines when it is not a terminal), ``False``/``None`` for none.

    Returns
    -------
    CollectResult
        Rows, targets, resume and saturation counts, time.

    Raises
    ------
    InputError
        If the existing file cannot be resumed (other header, other grid, malformed rows).
    """
    ramp = spec.ramp
    return _collect(
        rig,
        spec,
        out_csv,
        columns=CHARACTERISATION_COLUMNS,
        levels=_levels(spec.actuation_max, pulse_step, "pulse_step"),
        actuation=lambda level, position: ramped_actuation(level, position, ramp).tolist(),
        readings=readings,
        bias_readings=bias_readings,
        bias_open=bias_open,
        positions=positions,
        transitions=transitions,
        saturation=saturation,
        progress=progress,
    )


def _phase_tables(spec: MotorSpec, tables: Mapping[str, NDArray[np.integer]]) -> NDArray[np.int64]:
    shape = (spec.positions_per_cycle, 2**spec.command_bits)
    out = np.empty((spec.phases, *shape), dtype=np.int64)
    for k in range(spec.phases):
        name = f"phase_{k + 1}"
        if name not in tables:
            raise InputError(f"tables lack {name!r} (have {', '.join(sorted(tables))})")
        table = np.asarray(tables[name])
        if table.shape != shape:
            raise InputError(f"table {name!r} has shape {table.shape}, expected {shape}")
        if not np.issubdtype(table.dtype, np.integer):
            raise InputError(f"table {name!r} must hold integers, got {table.dtype}")
        if table.min() < 0 or table.max() > spec.actuation_max:
            raise InputError(f"table {name!r} holds values outside 0 .. {spec.actuation_max}")
        out[k] = table
    return out


def collect_verification(
    rig: Rig,
    spec: MotorSpec,
    tables: Mapping[str, NDArray[np.integer]],
    out_csv: str | os.PathLike[str],
    *,
    readings: int = 10,
    bias_readings: int | None = None,
    bias_open: bool = False,
    command_step: int = 1,
    positions: int | None = None,
    transitions: bool = False,
    saturation: float | None = None,
    progress: bool | Progress | None = True,
) -> CollectResult:
    """Collect torque vs position vs torque command through the tables (paper §5.3 "after").

    As :func:`collect_characterisation`, but the inner loop steps the torque command
    ``c = 0 .. 2**(bits - 1) - 1`` and phase ``k`` receives ``tables["phase_k"][p, c mod 2**bits]``
    at the current position ``p``. Writes ``position, command, torque``.

    Parameters
    ----------
    tables
        ``phase_1 .. phase_m``: integer arrays of shape ``(P, 2**command_bits)``.
    command_step
        Step of the torque command.
    readings, bias_readings, bias_open, positions, transitions, saturation, progress
        As for :func:`collect_characterisation`.

    Raises
    ------
    InputError
        On missing tables, a wrong shape, non-integer or out-of-range entries, or a file that
        cannot be resumed.
    """
    stack = _phase_tables(spec, tables)
    width = 2**spec.command_bits
    return _collect(
        rig,
        spec,
        out_csv,
        columns=VERIFICATION_COLUMNS,
        levels=_levels(width // 2 - 1, command_step, "command_step"),
        actuation=lambda level, position: stack[
            :, position % spec.positions_per_cycle, level % width
        ].tolist(),
        readings=readings,
        bias_readings=bias_readings,
        bias_open=bias_open,
        positions=positions,
        transitions=transitions,
        saturation=saturation,
        progress=progress,
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
        On a missing or unreadable file, a missing table, a wrong shape, or entries that are
        not integers in ``0 .. actuation_max``.
    """
    p = os.fspath(path)
    try:
        with np.load(p, allow_pickle=False) as npz:
            tables = {name: np.asarray(npz[name]) for name in npz.files}
    except FileNotFoundError:
        raise InputError("file not found", path=p) from None
    except (OSError, ValueError) as exc:
        raise InputError(f"cannot read tables ({exc})", path=p) from None
    try:
        stack = _phase_tables(spec, tables)
    except InputError as exc:
        raise InputError(exc.message, path=p) from None
    return {f"phase_{k + 1}": stack[k] for k in range(spec.phases)}
