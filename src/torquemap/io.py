"""Log files (CSV and Parquet), robot-aware log reading, and atomic writes (docs/formats.md).

Every writer goes through :func:`atomic_output`: the file appears whole or not at all.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.robot import Robot

Columns = dict[str, NDArray[Any]]


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` only on success.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_output(d / "x.txt") as tmp:
    ...     _ = tmp.write_text("hello")
    >>> (d / "x.txt").read_text()
    'hello'
    """
    target = Path(path)
    if target.parent and not target.parent.exists():
        raise InputError("output folder does not exist", path=target.parent)
    fd, name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent or ".")
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        os.replace(tmp, target)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def _suffix(path: Path) -> str:
    s = path.suffix.lower()
    if s not in (".csv", ".parquet"):
        raise InputError("unknown table format (use .csv or .parquet)", path=path)
    return s


def read_table(path: str | os.PathLike[str]) -> Columns:
    """Read a CSV or Parquet table into a dict of column arrays.

    Parameters
    ----------
    path
        ``.csv`` (header row, comma separated) or ``.parquet``.

    Returns
    -------
    dict of str to ndarray
        Column name to values, in file order.

    Raises
    ------
    InputError
        On a missing, empty, truncated or malformed file.
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    p = Path(path)
    kind = _suffix(p)
    if not p.exists():
        raise InputError("file not found", path=p)
    if p.stat().st_size == 0:
        raise InputError("file is empty", path=p)
    try:
        if kind == ".csv":
            table = pacsv.read_csv(p)
        else:
            table = pq.read_table(p)
    except (pa.ArrowException, OSError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"cannot parse table, truncated or malformed ({first})", path=p) from None
    if table.num_rows == 0:
        raise InputError("table has no rows", path=p)
    out: Columns = {}
    for name in table.column_names:
        column = table.column(name)
        try:
            out[name] = column.to_numpy(zero_copy_only=False)
        except (pa.ArrowException, ValueError):
            out[name] = np.asarray(column.to_pylist(), dtype=object)
    return out


def numeric_column(
    columns: Columns, name: str, path: str | os.PathLike[str]
) -> NDArray[np.float64]:
    """Column ``name`` as finite float64; InputError naming the column and the first bad row."""
    if name not in columns:
        raise InputError(f"missing column {name!r}", path=path)
    raw = columns[name]
    try:
        values = np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"column {name!r} is not numeric", path=path) from None
    bad = ~np.isfinite(values)
    if bad.any():
        row = int(np.argmax(bad))
        raise InputError(
            f"column {name!r} holds NaN or inf (first at data row {row + 1})", path=path
        )
    return values


def write_table(path: str | os.PathLike[str], columns: Mapping[str, ArrayLike]) -> None:
    """Write columns to ``.csv`` or ``.parquet``, atomically.

    Parameters
    ----------
    path
        Output file; the suffix chooses the format.
    columns
        Column name to 1-D values of equal length.
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    p = Path(path)
    kind = _suffix(p)
    arrays = {k: np.asarray(v) for k, v in columns.items()}
    table = pa.table(arrays)
    with atomic_output(p) as tmp:
        if kind == ".csv":
            # a plain header line (pyarrow would quote the names)
            with tmp.open("wb") as handle:
                handle.write((",".join(arrays) + "\n").encode())
                pacsv.write_csv(
                    table,
                    handle,
                    write_options=pacsv.WriteOptions(include_header=False, quoting_style="none"),
                )
        else:
            pq.write_table(table, tmp)


def write_toml(path: str | os.PathLike[str], document: Mapping[str, Any]) -> None:
    """Write a TOML document atomically."""
    with atomic_output(path) as tmp:
        tmp.write_text(tomli_w.dumps(document))


@dataclass(frozen=True, slots=True, eq=False)
class Log:
    """A log read against a robot file: time, joint angles and motor torques.

    Attributes
    ----------
    t
        Time [s], strictly increasing, shape (n,).
    q
        Joint-side angles [rad], shape (n, n_joints), unwrapped when the file held counts.
    motor_torque
        Motor-side torque [N m], shape (n, n_joints): ``tau_<j>``, or ``i_<j>`` times the
        torque constant.
    joint_names
        Joint names, in the robot file's order.
    path
        The file it came from.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    motor_torque: NDArray[np.float64]
    joint_names: tuple[str, ...]
    path: str


def check_time(t: NDArray[np.float64], path: str | os.PathLike[str]) -> None:
    """InputError unless ``t`` has at least two samples and never decreases.

    A repeated time stamp is allowed here (a host that polled twice before the drive updated);
    the estimators drop such rows with a warning (:func:`torquemap.sanitize.sanitize_log`).
    """
    if t.size < 2:
        raise InputError("log needs at least two samples", path=path)
    step = np.diff(t)
    if not np.all(step >= 0):
        row = int(np.argmax(step < 0)) + 2
        raise InputError(f"time 't' goes backwards (at data row {row})", path=path)
    if not np.any(step > 0):
        raise InputError("time 't' never advances", path=path)


def log_from_columns(columns: Columns, robot: Robot, *, path: str | os.PathLike[str]) -> Log:
    """Build a :class:`Log` from table columns (see :func:`read_log`)."""
    p = os.fspath(path)
    t = numeric_column(columns, "t", p)
    check_time(t, p)
    q = np.empty((t.size, len(robot.joints)))
    tau = np.empty_like(q)
    for k, joint in enumerate(robot.joints):
        raw_q = numeric_column(columns, f"q_{joint.name}", p)
        if joint.position_unit == "counts":
            cpr = float(joint.encoder_counts_per_rev or 0)
            counts = np.unwrap(raw_q, period=cpr)
            q[:, k] = counts * (2.0 * np.pi / cpr) / joint.gear_ratio
        elif joint.position_unit == "turns":
            q[:, k] = raw_q * (2.0 * np.pi) / joint.gear_ratio
        else:
            q[:, k] = raw_q
        if f"tau_{joint.name}" in columns:
            tau[:, k] = numeric_column(columns, f"tau_{joint.name}", p)
        elif f"i_{joint.name}" in columns:
            tau[:, k] = numeric_column(columns, f"i_{joint.name}", p) * joint.torque_constant
        else:
            raise InputError(
                f"missing column 'i_{joint.name}' or 'tau_{joint.name}' for joint {joint.name!r}",
                path=p,
            )
    return Log(t=t, q=q, motor_torque=tau, joint_names=robot.joint_names, path=p)


def read_log(path: str | os.PathLike[str], robot: Robot) -> Log:
    """Read a log file (CSV or Parquet) for ``robot`` (docs/formats.md).

    Parameters
    ----------
    path
        The log: column ``t`` [s], and for each joint ``q_<j>`` and ``i_<j>`` or ``tau_<j>``.
    robot
        The robot whose joints the log must hold.

    Returns
    -------
    Log
        Time, joint angles [rad] and motor-side torques [N m].

    Raises
    ------
    InputError
        On a missing column, NaN or inf, non-increasing time, or an empty or truncated file.
    """
    return log_from_columns(read_table(path), robot, path=path)
