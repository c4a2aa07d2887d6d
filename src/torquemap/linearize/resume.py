"""The collection's record and lock beside a data file: resume by position, one writer at a time.

A collection into ``DATA.csv`` keeps two companions beside it:

* ``DATA.csv.collect.json``, the record: the collection's kind (``characterisation`` or
  ``verification``), its settings, the motor (phases, cycle, actuation range, ramp), for a
  verification run a digest of the tables, and the targets done so far with the number of rows
  each left in the file, in file order. It is rewritten atomically after every target's block,
  after the block's rows are flushed, so the rows it lists are always in the file: a run cut
  anywhere leaves at most one block the record does not list, and the next run drops it.
* ``DATA.csv.lock``, the lock: created exclusively (``O_CREAT | O_EXCL``) holding the writer's
  pid, removed when the run ends. A second run on the same file is refused while that process
  lives; a lock whose process is gone (a killed run) is taken over.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from torquemap.errors import InputError
from torquemap.io import atomic_output
from torquemap.linearize.motor import MotorSpec

RECORD_SUFFIX = ".collect.json"
LOCK_SUFFIX = ".lock"


def record_path(path: str | os.PathLike[str]) -> Path:
    """``DATA.csv`` -> ``DATA.csv.collect.json``."""
    p = Path(path)
    return p.with_name(p.name + RECORD_SUFFIX)


def adaptive_record_path(path: str | os.PathLike[str]) -> Path:
    """``DATA.csv`` -> ``DATA.csv.adaptive.json``, the adaptive collection's record
    (:mod:`torquemap.linearize.adaptive`)."""
    p = Path(path)
    return p.with_name(p.name + ".adaptive.json")


def lock_path(path: str | os.PathLike[str]) -> Path:
    """``DATA.csv`` -> ``DATA.csv.lock``."""
    p = Path(path)
    return p.with_name(p.name + LOCK_SUFFIX)


def _alive(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's live process
    return not _zombie(pid)


def _zombie(pid: int) -> bool:
    """A process that has exited (killed: ``kill -9``, ``timeout -s KILL``) but whose parent has
    not reaped it yet still answers ``kill(pid, 0)``; Linux's /proc says so (state Z or X)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False  # no /proc (not Linux) or gone meanwhile: kill(pid, 0) decides
    state = stat.rpartition(")")[2].split()[:1]  # the name in parentheses may hold spaces
    return state in (["Z"], ["X"])


@contextlib.contextmanager
def collection_lock(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Hold ``DATA.csv.lock`` for the block: one collection per data file.

    Parameters
    ----------
    path
        The data file.

    Yields
    ------
    Path
        The lock file.

    Raises
    ------
    InputError
        If a live process (another run) holds the lock, or the lock cannot be created.
    """
    lock = lock_path(path)
    for _ in range(3):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                text = lock.read_text().strip()
            except FileNotFoundError:
                continue  # released meanwhile: try again
            pid = int(text) if text.isdigit() else -1
            if pid == os.getpid() or _alive(pid):
                raise InputError(
                    f"another collection (pid {pid}) is writing this file; wait for it or "
                    f"remove {lock.name} if that run is gone",
                    path=path,
                ) from None
            lock.unlink(missing_ok=True)  # stale: its run was killed
            continue
        except OSError as exc:
            raise InputError(f"cannot create the lock file ({exc.strerror})", path=lock) from None
        with os.fdopen(fd, "w") as handle:
            handle.write(f"{os.getpid()}\n")
        break
    else:
        raise InputError("cannot take the collection lock", path=lock)
    try:
        yield lock
    finally:
        lock.unlink(missing_ok=True)


def motor_identity(spec: MotorSpec) -> dict[str, Any]:
    """What of the motor a collection depends on (compared on resume)."""
    return {
        "phases": spec.phases,
        "positions_per_cycle": spec.positions_per_cycle,
        "actuation_max": spec.actuation_max,
        "command_bits": spec.command_bits,
        "ramp_sha256": hashlib.sha256(
            np.ascontiguousarray(np.asarray(spec.ramp, dtype=np.float64)).tobytes()
        ).hexdigest(),
    }


def tables_digest(stack: NDArray[np.int64]) -> str:
    """SHA-256 of a phase-table stack (a verification run is resumed with the same tables)."""
    return hashlib.sha256(np.ascontiguousarray(stack, dtype=np.int64).tobytes()).hexdigest()


@dataclass(frozen=True, slots=True, eq=False)
class CollectionRecord:
    """What ``DATA.csv.collect.json`` holds.

    Attributes
    ----------
    kind
        ``"characterisation"`` or ``"verification"``.
    settings
        The settings that change the data (name -> value).
    motor
        :func:`motor_identity` (plus ``tables_sha256`` for verification).
    done
        ``(target, rows)`` for each target done, in file order.
    """

    kind: str
    settings: Mapping[str, Any]
    motor: Mapping[str, Any]
    done: tuple[tuple[int, int], ...]

    def to_json(self) -> str:
        """The record as JSON text."""
        return json.dumps(
            {
                "kind": self.kind,
                "settings": dict(self.settings),
                "motor": dict(self.motor),
                "done": [list(d) for d in self.done],
            },
            indent=1,
        )


def read_record(path: str | os.PathLike[str]) -> CollectionRecord | None:
    """The record beside data file ``path``, or None if there is none.

    Raises
    ------
    InputError
        If the record exists but cannot be read.
    """
    rp = record_path(path)
    if not rp.exists():
        return None
    try:
        raw = json.loads(rp.read_text())
        done = tuple((int(t), int(r)) for t, r in raw["done"])
        return CollectionRecord(
            kind=str(raw["kind"]),
            settings=dict(raw["settings"]),
            motor=dict(raw["motor"]),
            done=done,
        )
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise InputError(
            f"cannot read the collection record ({exc}); delete it and the data to start over",
            path=rp,
        ) from None


def write_record(path: str | os.PathLike[str], record: CollectionRecord) -> None:
    """Write the record beside data file ``path`` atomically."""
    with atomic_output(record_path(path)) as tmp:
        tmp.write_text(record.to_json() + "\n")


def differences(ours: Mapping[str, Any], theirs: Mapping[str, Any], what: str) -> list[str]:
    """``name (this run X, the file's Y)`` for every entry that differs."""
    out = []
    for key in sorted(set(ours) | set(theirs)):
        a, b = ours.get(key), theirs.get(key)
        if a != b:
            if key.endswith("sha256"):
                out.append(f"{what}{key.removesuffix('_sha256')} (differs)")
            else:
                out.append(f"{what}{key} (this run {a!r}, the file's {b!r})")
    return out


def record_beside(
    data_path: str | os.PathLike[str],
) -> tuple[str | None, dict[str, Any], Mapping[str, Any] | None]:
    """``(kind, settings, motor)`` of the collection record beside data ``data_path``: the
    grid's ``DATA.csv.collect.json``, else an adaptive run's ``DATA.csv.adaptive.json`` (kind
    ``"characterisation"``, its whole document as settings); ``(None, {}, None)`` when neither
    is there or readable (the data themselves are checked on reading)."""
    try:
        record = read_record(data_path)
    except InputError:  # the record serves resuming
        record = None
    if record is not None:
        return record.kind, dict(record.settings), record.motor
    try:
        raw = json.loads(adaptive_record_path(data_path).read_text())
    except (OSError, ValueError):
        return None, {}, None
    if not isinstance(raw, dict):
        return None, {}, None
    motor = raw.get("motor")
    return "characterisation", raw, motor if isinstance(motor, Mapping) else None


def check_same_settings(
    settings: tuple[Mapping[str, Any], Mapping[str, Any]],
    theirs: tuple[Mapping[str, Any], Mapping[str, Any]],
    path: str | os.PathLike[str],
    *,
    problems: Sequence[str] = (),
) -> None:
    """Refuse to resume data file ``path`` when this run's ``(settings, motor)`` differ from
    the file's record's ``theirs`` (each difference named, after ``problems`` found before).

    Raises
    ------
    InputError
        One line naming every difference.
    """
    found = [*problems, *differences(settings[0], theirs[0], "")]
    found += differences(settings[1], theirs[1], "motor ")
    if found:
        raise InputError(
            "cannot resume: this run's settings differ from the file's: "
            + "; ".join(found)
            + " (use the file's settings, or another output file)",
            path=path,
        )


def check_collected_through(
    data_path: str | os.PathLike[str],
    stack: NDArray[np.int64],
    tables_path: str | os.PathLike[str] | None = None,
) -> None:
    """Refuse tables other than those the verification run ``data_path`` was collected through.

    The record beside a verification run holds the digest of its tables
    (:func:`tables_digest`); rows measured through one set of tables say nothing about
    another. Silent when there is no readable record (data from elsewhere, an older run).

    Raises
    ------
    InputError
        Naming the data file, when its record holds another digest than ``stack``'s.
    """
    try:
        record = read_record(data_path)
    except InputError:
        return  # an unreadable record is resume's business, not the evaluation's
    if record is None or record.kind != "verification":
        return
    digest = record.motor.get("tables_sha256")
    if digest is None or digest == tables_digest(stack):
        return
    given = "the tables given" if tables_path is None else os.fspath(tables_path)
    raise InputError(
        f"was collected through other tables than {given} (its record "
        f"{record_path(data_path).name} holds another digest): evaluate it with the tables it "
        "ran through",
        path=data_path,
    )


#: What of the motor file the rows depend on, by kind of data: a characterisation's pulse widths
#: were ramped through the file's ramp; a verification's commands span its command bits.
_ROWS_DEPEND_ON = {
    "characterisation": ("phases", "positions_per_cycle", "actuation_max", "ramp_sha256"),
    "verification": ("phases", "positions_per_cycle", "actuation_max", "command_bits"),
}


def check_collected_for(data_path: str | os.PathLike[str], spec: MotorSpec, kind: str) -> None:
    """Refuse a motor file other than the one data ``data_path`` was collected with.

    The collection's record beside the data (``DATA.csv.collect.json``, or an adaptive run's
    ``DATA.csv.adaptive.json`` that holds its motor) names the motor it ran on
    (:func:`motor_identity`). A characterisation's rows hold base pulse widths ramped through
    the file's ramp: built with another ramp (the file edited from wide to narrow after the
    collection), the tables were 52 % APMD instead of 2 % with exit 0 (QA bench 316). Silent
    when there is no readable record or it holds no motor (data from elsewhere, older runs).

    Raises
    ------
    InputError
        Naming the data file and every difference.
    """
    found, _, motor = record_beside(data_path)
    theirs = motor if found == kind else None
    if not isinstance(theirs, Mapping):
        return
    ours = motor_identity(spec)
    problems = [
        "another ramp"
        if key == "ramp_sha256"
        else f"{key.replace('_', ' ')} {ours[key]} (the record: {theirs[key]})"
        for key in _ROWS_DEPEND_ON.get(kind, ())
        if key in theirs and ours[key] != theirs[key]
    ]
    if problems:
        named = "this one" if spec.path is None else os.fspath(spec.path)
        raise InputError(
            f"was collected with another motor file than {named} ({'; '.join(problems)}, its "
            "record says): use the motor file it was collected with",
            path=data_path,
        )
