"""Log files (CSV and Parquet), robot-aware log reading, and atomic writes (docs/formats.md).

Every writer goes through :func:`atomic_output`: the file appears whole or not at all.
"""

from __future__ import annotations

import contextlib
import csv
import os
import re
import tempfile
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
import tomli_w
from numpy.typing import ArrayLike, NDArray

from torquemap.errors import InputError
from torquemap.log_quirks import (
    backwards_time_hint,
    cell_hint,
    decimal_comma_rows,
    epoch_time_hint,
    register_overflow,
)
from torquemap.robot import Robot

Columns = dict[str, NDArray[Any]]
#: Writes one output's contents into the (temporary) path it is given.
Writer = Callable[[Path], object]


#: Temporary files of a write in progress: ``.<name>.tqm<pid>-<random>.tmp`` (further suffixes
#: follow when a writer needs the real one, and on the files kept beside such a temporary: a
#: collection's ``.tmp.csv.collect.json`` record and ``.tmp.csv.lock``). A run removes the ones
#: whose process is gone.
TEMPORARY_PATTERN = re.compile(r"^\..*\.tqm(?P<pid>[0-9]+)-[A-Za-z0-9_]+\.tmp(\.[A-Za-z0-9_]+)*$")


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return pid > 0
    return True


def remove_stale_temporaries(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove torquemap's own temporaries in ``folder`` whose writing process is gone.

    A run killed while writing (kill -9, a power cut) leaves ``.<name>.tqm<pid>-<random>.tmp``
    behind; the next write into the same folder calls this. Temporaries of live processes and
    every other file are left alone.

    Returns
    -------
    list of Path
        The files removed.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / ".x.csv.tqm999999999-abc.tmp").write_text("partial")
    >>> [p.name for p in remove_stale_temporaries(d)]
    ['.x.csv.tqm999999999-abc.tmp']
    """
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        match = TEMPORARY_PATTERN.match(entry.name)
        if match is None or _pid_alive(int(match["pid"])):
            continue
        with contextlib.suppress(OSError):
            if entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
    return removed


def current_umask() -> int:
    """The process's file-creation mask (read without changing it where /proc allows)."""
    with contextlib.suppress(OSError, ValueError):
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def check_output_file(path: str | os.PathLike[str]) -> Path:
    """InputError unless ``path`` can be written as a file: folder exists, not a folder, writable.

    An existing file is replaced (fine) unless it is read-only: that is refused, as ``cp`` and
    editors do, since the user marked it as not to be changed.
    """
    target = Path(path)
    parent = target.parent
    if not parent.is_dir():
        if parent.exists():
            raise InputError("output folder is not a folder", path=parent)
        raise InputError("output folder does not exist", path=parent)
    if target.is_dir():
        raise InputError("output is a folder, expected a file name", path=target)
    if target.exists() or target.is_symlink():
        try:
            mode = target.stat().st_mode
        except OSError:
            mode = 0o666
        if not mode & 0o222 or not os.access(target, os.W_OK):
            raise InputError(
                "output exists and is read-only; make it writable or choose another name",
                path=target,
            )
    return target


@contextlib.contextmanager
def atomic_outputs(paths: Sequence[str | os.PathLike[str]]) -> Iterator[list[Path]]:
    """Yield one temporary path per output; rename them all onto the outputs only on success.

    All or none: the temporaries are staged beside their targets (same file system), renamed
    only once every one was written, and removed on any failure (a full disk, an exception,
    Ctrl-C). They are named ``.<name>.tqm<pid>-<random>.tmp``; stale ones of a killed run are
    removed by the next write into the folder (:func:`remove_stale_temporaries`). The outputs
    get the user's umask (``0666 & ~umask``), like any file the user's shell creates.

    Raises
    ------
    InputError
        If an output's folder is missing, an output is a folder or a read-only file, or two
        outputs are the same file.
    """
    targets = [Path(p) for p in paths]
    seen: set[Path] = set()
    for target in targets:
        check_output_file(target)
        key = target.resolve()
        if key in seen:
            raise InputError("the same output is named twice", path=target)
        seen.add(key)
    for folder in {t.parent for t in targets}:
        remove_stale_temporaries(folder)
    mode = 0o666 & ~current_umask()
    tmps: list[Path] = []
    try:
        for target in targets:
            fd, name = tempfile.mkstemp(
                prefix=f".{target.name}.tqm{os.getpid()}-", suffix=".tmp", dir=target.parent
            )
            os.close(fd)
            tmps.append(Path(name))
        yield list(tmps)
        for tmp in tmps:
            os.chmod(tmp, mode)
        for tmp, target in zip(tmps, targets, strict=True):
            os.replace(tmp, target)
    finally:
        for tmp in tmps:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` only on success.

    See :func:`atomic_outputs` (temporary names, umask, read-only outputs).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with atomic_output(d / "x.txt") as tmp:
    ...     _ = tmp.write_text("hello")
    >>> (d / "x.txt").read_text()
    'hello'
    """
    with atomic_outputs([path]) as tmps:
        yield tmps[0]


@contextlib.contextmanager
def output_folder(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Create folder ``path`` (and parents) for the outputs; on failure remove what was created.

    Only folders this call created, and only while empty, are removed: an existing folder is
    never touched.
    """
    folder = Path(path)
    if folder.exists() and not folder.is_dir():
        raise InputError("output path exists and is not a folder", path=folder)
    created: list[Path] = []
    probe = folder
    while not probe.exists():
        created.append(probe)
        if probe.parent == probe:
            break
        probe = probe.parent
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create output folder ({exc.strerror})", path=folder) from None
    try:
        yield folder
    except BaseException:
        for made in created:
            with contextlib.suppress(OSError):
                made.rmdir()
        raise


def _suffix(path: Path) -> str:
    s = path.suffix.lower()
    if s not in (".csv", ".parquet"):
        raise InputError("unknown table format (use .csv or .parquet)", path=path)
    return s


def _parse_hint(path: Path) -> str:
    """What a CSV's first line says about a parse error: ``"; ..."`` naming a comment line or
    a separator other than the comma, else ``""`` (Parquet files, unreadable files)."""
    if path.suffix.lower() != ".csv":
        return ""
    try:
        with path.open("rb") as f:
            head = f.read(4096).split(b"\n", 1)[0].rstrip(b"\r").decode("utf-8", "replace")
    except OSError:
        return ""
    head = head.lstrip("\ufeff")
    shown = head if len(head) <= 40 else head[:37] + "..."
    if head.startswith("#"):
        return f"; the first line {shown!r} is a comment: the first line must be the header"
    try:
        with path.open("rb") as f:
            lines = f.read(4096).splitlines()
        row = lines[1].decode("utf-8", "replace") if len(lines) > 1 else ""
    except OSError:
        row = ""
    for sep, name in ((";", "semicolons"), ("\t", "tabs")):
        if sep in head and "," not in head.replace(sep, ""):
            return f"; the header {shown!r} is separated by {name}: separate columns with commas"
    if decimal_comma_rows(row, head):
        return (
            "; the rows hold more commas than the header: decimal commas? write numbers with a "
            "decimal point"
        )
    cells = row.split(",")
    if row and all(cell_hint(c, 1).startswith(": a units row") for c in cells):
        return "; the first row is" + cell_hint(cells[0], 1)[1:]
    return ""


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
        On a missing, empty, truncated or malformed file, or a folder.
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    p = Path(path)
    kind = _suffix(p)
    if not p.exists():
        raise InputError("file not found", path=p)
    if p.is_dir():  # pyarrow would read a folder as an (empty) Parquet data set
        raise InputError(f"is a folder, expected a {kind.lstrip('.').upper()} file", path=p)
    if p.stat().st_size == 0:
        raise InputError("file is empty", path=p)
    try:
        if kind == ".csv":
            table = pacsv.read_csv(p)
        else:
            # the file's own reader, not ``pq.read_table``: the same table without the
            # dataset layer (its import alone costs a fifth of a second of CPU)
            with pq.ParquetFile(p) as handle:
                table = handle.read()
        names = list(table.column_names)
    except UnicodeDecodeError as exc:
        raise InputError(
            f"not UTF-8 text (byte 0x{exc.object[exc.start]:02x} in the header); save the file "
            "as UTF-8",
            path=p,
        ) from None
    except (pa.ArrowException, OSError, ValueError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(
            f"cannot parse table, truncated or malformed ({first}){_parse_hint(p)}", path=p
        ) from None
    if table.num_rows == 0:
        raise InputError("table has no rows", path=p)
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise InputError(f"column name {name!r} appears more than once", path=p)
        seen.add(name)
    out: Columns = {}
    for name in names:
        column = table.column(name)
        try:
            out[name] = column.to_numpy(zero_copy_only=False)
        except (pa.ArrowException, ValueError):
            out[name] = np.asarray(column.to_pylist(), dtype=object)
    return out


#: Largest magnitude any numeric column may hold: no quantity these files measure reaches
#: 1e15 in SI units, and beyond it squares and sums of a log overflow float64 (a current of
#: 1e308 A is a corrupt file, not a sample).
MAX_MAGNITUDE = 1e15


def _utf8(raw: bytes) -> bool:
    try:
        raw.decode("utf-8")
    except UnicodeDecodeError:
        return False
    return True


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def _is_number_text(value: object) -> bool:
    """Whether ``value`` is text that reads as a number (``'-0.03'``, ``' 12 '``)."""
    if not isinstance(value, str):
        return False
    try:
        float(value)
    except ValueError:
        return False
    return True


#: Units a logger may append to a column name (``q_a_deg``, ``i_a_mA``, ``t_ms``), lower case,
#: and what torquemap reads instead where it is another (SI units: nothing to convert).
NAME_UNITS = {
    "s": "",
    "sec": "",
    "ms": "s",
    "us": "s",
    "ns": "s",
    "rad": "",
    "deg": "rad",
    "degrees": "rad",
    "counts": "rad (or position_unit = 'counts' in the robot file)",
    "cnt": "rad (or position_unit = 'counts' in the robot file)",
    "turns": "rad (or position_unit = 'turns' in the robot file)",
    "rev": "rad (or position_unit = 'turns' in the robot file)",
    "a": "",
    "amps": "",
    "ma": "A",
    "nm": "",
    "n_m": "",
    "nmm": "N m",
}
_NAME_UNIT = re.compile(r"[_ ](" + "|".join(sorted(NAME_UNITS, key=len, reverse=True)) + r")$")
_BRACKETED = re.compile(r"\s*[\[(](.*?)[\])]\s*")


def near_miss(name: str, present: Sequence[str]) -> str | None:
    """The column of ``present`` that is ``name`` but for case, spaces or a unit (in brackets,
    or appended: ``q_a_deg``, ``i_a_mA``), else None."""
    for c in present:
        bare = _BRACKETED.sub("", str(c)).strip().lower()
        if bare == name.lower() or _NAME_UNIT.sub("", bare) == name.lower():
            return str(c)
    return None


def _unit_note(column: str) -> str:
    """``"; its values in deg must be in rad too"`` for a column name carrying a unit that is
    not the one torquemap reads, else "".

    Examples
    --------
    >>> _unit_note("i_a_mA")
    '; its values in mA must be in A too'
    >>> _unit_note("t [ms]")
    '; its values in ms must be in s too'
    >>> _unit_note("q_a [rad]")
    ''
    """
    text = str(column).strip()
    found = _BRACKETED.search(text)
    unit = found.group(1).strip() if found else ""
    if not unit:
        bare = _BRACKETED.sub("", text)
        suffix = _NAME_UNIT.search(bare.lower())
        unit = bare[suffix.start(1) :] if suffix else ""
    target = NAME_UNITS.get(unit.lower().replace(" ", "_"), "")
    return f"; its values in {unit} must be in {target} too" if target else ""


def missing_column_message(name: str, present: Sequence[str]) -> str:
    """``missing column 'name'`` plus what the file holds instead: a header that is one
    column (another separator), a near miss (case, spaces, a unit), or the columns it has.

    Examples
    --------
    >>> missing_column_message("t", ["t;q_a;i_a"])
    "missing column 't' (the header is one column, 't;q_a;i_a': separate columns with commas)"
    >>> missing_column_message("q_a", ["t", " Q_A [rad]", "i_a"])
    "missing column 'q_a' (the file has ' Q_A [rad]': names are exact, lower case, no unit)"
    """
    text = f"missing column {name!r}"
    cols = [str(c) for c in present]
    if len(cols) == 1 and any(sep in cols[0] for sep in ";\t|"):
        return f"{text} (the header is one column, {cols[0][:60]!r}: separate columns with commas)"

    near = near_miss(name, cols)
    if near is not None:
        return (
            f"{text} (the file has {near!r}: names are exact, lower case, no unit"
            f"{_unit_note(near)})"
        )
    shown = ", ".join(cols[:8]) + (f", ... ({len(cols)} in all)" if len(cols) > 8 else "")
    return f"{text} (the file has {shown})"


def missing_channel_message(joint: str, present: Sequence[str]) -> str:
    """``missing column 'i_<j>' or 'tau_<j>'`` plus a near miss the file holds (case, spaces,
    a unit: a header "i_a   " from a writer that pads its columns), as
    :func:`missing_column_message` names one for the other columns.

    Examples
    --------
    >>> missing_channel_message("a", ["t", "q_a", "i_a   "])
    "missing column 'i_a' or 'tau_a' for joint 'a' (the file has 'i_a   ': names are exact, lower case, no unit)"
    """
    text = f"missing column 'i_{joint}' or 'tau_{joint}' for joint {joint!r}"
    cols = [str(c) for c in present]
    near = near_miss(f"i_{joint}", cols) or near_miss(f"tau_{joint}", cols)
    if near is not None:
        return (
            f"{text} (the file has {near!r}: names are exact, lower case, no unit"
            f"{_unit_note(near)})"
        )
    shown = ", ".join(cols[:8]) + (f", ... ({len(cols)} in all)" if len(cols) > 8 else "")
    return f"{text} (the file has {shown})"


def numeric_column(
    columns: Columns,
    name: str,
    path: str | os.PathLike[str],
    *,
    max_abs: float | None = None,
    unit: str = "",
    first_row: int = 0,
    nan_hint: str = "",
) -> NDArray[np.float64]:
    """Column ``name`` as finite float64; InputError naming the column and the first bad row.

    Parameters
    ----------
    columns
        Columns of :func:`read_table`.
    name
        The column.
    path
        The file (for messages).
    max_abs
        Refuse values with a larger magnitude (a corrupt sample, or a number float64 cannot
        resolve at the precision the column needs); default :data:`MAX_MAGNITUDE`.
    unit
        Unit of the column, for the message.
    first_row
        Data row (0-based) of the column's first value in its file, for the messages of a
        file read in chunks.
    nan_hint
        Added to the message on NaN or inf (a log's: what to do with a logger's missed reads).

    Raises
    ------
    InputError
        On a missing column; booleans, text, dates or other non-numbers; NaN or inf; a value
        beyond ``max_abs``.
    """
    if name not in columns:
        raise InputError(missing_column_message(name, list(columns)), path=path)
    raw = np.asarray(columns[name])
    kind = raw.dtype.kind
    if kind == "b":
        raise InputError(f"column {name!r} holds booleans, not numbers", path=path)
    if kind == "O":
        for k, v in enumerate(raw.ravel()):
            if isinstance(v, bytes) and not _utf8(v):
                raise InputError(
                    f"column {name!r} is not UTF-8 text (data row {first_row + k + 1}); save the file as UTF-8",
                    path=path,
                )
        bad_items = [k for k, v in enumerate(raw.ravel()) if not _is_number(v)]
        # a CSV column with one bad cell is read as text throughout: name the first cell that
        # is not a number written as text, not the first cell
        text_bad = [k for k in bad_items if not _is_number_text(raw.ravel()[k])]
        if bad_items:
            row = (text_bad or bad_items)[0]
            cell = raw.ravel()[row]
            # logs joined with `cat a.csv b.csv`: the second header is a data row
            again = (
                ": the header again (files joined with their headers?); keep the first only"
                if isinstance(cell, str) and cell.strip() == name
                else cell_hint(cell, first_row + row + 1)
            )
            raise InputError(
                f"column {name!r} is not numeric (data row {first_row + row + 1}: {cell!r}){again}",
                path=path,
            )
    elif kind in "mM":
        raise InputError(
            f"column {name!r} is not numeric ({raw.dtype} values): write it as seconds, a number",
            path=path,
        )
    elif kind not in "iuf":
        raise InputError(f"column {name!r} is not numeric ({raw.dtype} values)", path=path)
    try:
        values = np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise InputError(f"column {name!r} is not numeric", path=path) from None
    bad = ~np.isfinite(values)
    if bad.any():
        row = int(np.argmax(bad))
        count = int(np.count_nonzero(bad))
        more = f", {count} rows in all" if count > 1 else ""
        raise InputError(
            f"column {name!r} holds NaN or inf (first at data row {first_row + row + 1}{more})"
            f"{nan_hint}",
            path=path,
        )
    limit = MAX_MAGNITUDE if max_abs is None else max_abs
    bad = np.abs(values) > limit
    if bad.any():
        row = int(np.argmax(bad))
        suffix = f" {unit}" if unit else ""
        hint = epoch_time_hint(float(values[row])) if unit == "s" else ""
        raise InputError(
            f"column {name!r} value {values[row]:.6g}{suffix} at data row {first_row + row + 1} is "
            f"beyond +-{limit:g}{suffix}{hint}",
            path=path,
        )
    return values


def render_table(
    target: str | os.PathLike[str], columns: Mapping[str, ArrayLike], *, kind: str
) -> None:
    """Write columns to ``target`` as ``kind`` (``".csv"`` or ``".parquet"``), not atomically.

    The building block of :func:`write_table` and :func:`write_all` (which hand it a temporary).

    Raises
    ------
    InputError
        On a column name a CSV header cannot hold (a comma, quote or line break).
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    arrays = {k: np.asarray(v) for k, v in columns.items()}
    table = pa.table(arrays)
    if kind == ".csv":
        for name in arrays:
            if any(c in name for c in ',"\r\n'):
                raise InputError(f"column name {name!r} cannot be written to a CSV header")
        # a plain header line (pyarrow would quote the names)
        with open(target, "wb") as handle:
            handle.write((",".join(arrays) + "\n").encode())
            pacsv.write_csv(
                table,
                handle,
                write_options=pacsv.WriteOptions(include_header=False, quoting_style="none"),
            )
    else:
        pq.write_table(table, target, use_dictionary=_dictionary_columns(arrays))


def _dictionary_columns(arrays: Mapping[str, NDArray[Any]]) -> list[str]:
    """Columns worth Parquet's dictionary encoding: not floats (measured samples rarely
    repeat; encoding them costs 4x the write time and saves nothing)."""
    return [name for name, values in arrays.items() if values.dtype.kind != "f"]


def write_table(path: str | os.PathLike[str], columns: Mapping[str, ArrayLike]) -> None:
    """Write columns to ``.csv`` or ``.parquet``, atomically.

    Parameters
    ----------
    path
        Output file; the suffix chooses the format.
    columns
        Column name to 1-D values of equal length.
    """
    p = Path(path)
    kind = _suffix(p)
    with atomic_output(p) as tmp:
        render_table(tmp, columns, kind=kind)


def table_writer(path: str | os.PathLike[str], columns: Mapping[str, ArrayLike]) -> Writer:
    """A writer for :func:`write_all` of a table, its format chosen by ``path``'s suffix."""
    kind = _suffix(Path(path))
    return lambda tmp: render_table(tmp, columns, kind=kind)


def toml_writer(document: Mapping[str, Any]) -> Writer:
    """A writer for :func:`write_all` of a TOML document."""
    return lambda tmp: tmp.write_text(tomli_w.dumps(document))


def figure_writer(figure: Any, *, kind: str = "png", dpi: int = 120) -> Writer:
    """A writer for :func:`write_all` of a matplotlib figure in format ``kind``."""
    return lambda tmp: figure.savefig(tmp, format=kind, dpi=dpi)


def write_toml(path: str | os.PathLike[str], document: Mapping[str, Any]) -> None:
    """Write a TOML document atomically."""
    with atomic_output(path) as tmp:
        toml_writer(document)(tmp)


def write_all(writers: Mapping[Path, Writer] | Mapping[str, Writer]) -> list[Path]:
    """Write several files all or none: each writer fills a temporary, then all are renamed.

    Parameters
    ----------
    writers
        Output path to a function writing that file's contents into the path it is given.

    Returns
    -------
    list of Path
        The files written, in order.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> [p.name for p in write_all({d / "a.txt": lambda t: t.write_text("a"),
    ...                             d / "b.txt": lambda t: t.write_text("b")})]
    ['a.txt', 'b.txt']
    """
    paths = [Path(p) for p in writers]
    with atomic_outputs(paths) as tmps:
        for tmp, write in zip(tmps, writers.values(), strict=True):
            write(tmp)
    return paths


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
    path: str = "<memory>"

    def __post_init__(self) -> None:
        """Coerce to float64 arrays and refuse shapes and values the estimators cannot use.

        Raises
        ------
        InputError
            When ``t`` is not 1-D and strictly increasing, ``q`` or ``motor_torque`` is not
            (n, n_joints), ``joint_names`` does not name n_joints joints, or a value is not
            finite.

        Examples
        --------
        >>> Log(t=[0.0, 1.0], q=[0.0, 1.0], motor_torque=[[0.0], [0.0]], joint_names=("a",))
        Traceback (most recent call last):
        ...
        torquemap.errors.InputError: <memory>: q must have shape (n, n_joints) = (2, 1), got (2,)
        """
        t = np.asarray(self.t, dtype=np.float64)
        if t.ndim != 1:
            raise InputError(f"t must be 1-D, got shape {t.shape}", path=self.path)
        names = tuple(str(n) for n in self.joint_names)
        shape = (t.size, len(names))
        arrays = {"t": t}
        for field_name in ("q", "motor_torque"):
            a = np.asarray(getattr(self, field_name), dtype=np.float64)
            if a.shape != shape:
                raise InputError(
                    f"{field_name} must have shape (n, n_joints) = {shape}, got {a.shape}",
                    path=self.path,
                )
            arrays[field_name] = a
        for field_name, a in arrays.items():
            if not np.all(np.isfinite(a)):
                raise InputError(f"{field_name} holds NaN or inf", path=self.path)
        check_time(t, self.path)
        for field_name, a in arrays.items():
            object.__setattr__(self, field_name, a)
        object.__setattr__(self, "joint_names", names)
        object.__setattr__(self, "path", os.fspath(self.path))


#: Largest |t| [s] a log may hold (317 years: Unix time fits, at 2 us resolution).
MAX_TIME = 1e10
#: Largest |q| [rad] a log may hold: beyond it float64 cannot resolve a microradian, and the
#: angle is a corrupt sample, not a position.
MAX_ANGLE = 1e9
#: Largest raw encoder count a log may hold: 2**53, beyond which float64 skips whole counts.
MAX_COUNTS = float(2**53)


def check_time(t: NDArray[np.float64], path: str | os.PathLike[str], *, first_row: int = 0) -> None:
    """InputError unless ``t`` has at least two samples and never decreases.

    A repeated time stamp is allowed here (a host that polled twice before the drive updated);
    the estimators drop such rows with a warning (:func:`torquemap.sanitize.sanitize_log`).
    """
    if t.size < 2:
        raise InputError("log needs at least two samples", path=path)
    step = np.diff(t)
    if not np.all(step >= 0):
        at = int(np.argmax(step < 0))
        hint = backwards_time_hint(t, at, first_row=first_row)
        raise InputError(
            f"time 't' goes backwards (at data row {at + 2 + first_row}){hint}", path=path
        )
    if not np.any(step > 0):
        raise InputError("time 't' never advances" + _float32_time_note(t), path=path)


def _float32_time_note(t: NDArray[np.float64]) -> str:
    """Why ``t`` stands still when it is Unix time stored as float32 (steps of 128 s), else ""."""
    first = float(t[0])
    if abs(first) < 1e5 or float(np.float32(first)) != first:
        return ""
    spacing = float(np.spacing(np.float32(abs(first))))
    return (
        f" (every row holds {first:.10g} s, a float32 value: float32 holds such times only to "
        f"{spacing:g} s; write t as float64, or in seconds from the log's start)"
    )


def _same_length(
    cols: Columns, name: str, path: str, n: int, *, max_abs: float = MAX_MAGNITUDE, unit: str = ""
) -> NDArray[np.float64]:
    values = numeric_column(cols, name, path, max_abs=max_abs, unit=unit)
    if values.shape != (n,):
        raise InputError(f"column {name!r} has shape {values.shape}, 't' has ({n},)", path=path)
    return values


def log_from_columns(
    columns: Mapping[str, ArrayLike], robot: Robot, *, path: str | os.PathLike[str] | None = None
) -> Log:
    """Build a :class:`Log` from columns: a table read from a file, or arrays in memory.

    Parameters
    ----------
    columns
        ``t`` [s] and, per joint ``<j>`` of ``robot``, ``q_<j>`` (joint angle [rad], or motor
        encoder counts for ``position_unit = "counts"``) and ``i_<j>`` [A] or ``tau_<j>``
        [N m, motor side]; each 1-D of the same length (docs/formats.md).
    robot
        The robot whose joints the columns must hold.
    path
        The file the columns came from, for error messages; None for arrays in memory.

    Returns
    -------
    Log
        Time, joint angles [rad] and motor-side torques [N m].

    Raises
    ------
    InputError
        On a missing column, NaN or inf, or non-increasing time.

    Examples
    --------
    >>> from torquemap.robot import robot_from_dict
    >>> rb = robot_from_dict({"robot": {"kinematics": "none"},
    ...                       "joints": {"m": {"gear_ratio": 10, "torque_constant": 0.5}}})
    >>> log = log_from_columns({"t": [0.0, 0.1], "q_m": [0.0, 0.2], "i_m": [1.0, 2.0]}, rb)
    >>> log.motor_torque[:, 0].tolist()
    [0.5, 1.0]
    """
    p = "<memory>" if path is None else os.fspath(path)
    cols: Columns = {k: np.asarray(v) for k, v in columns.items()}
    t, q, tau = _log_arrays(cols, robot, p)
    return Log(t=t, q=q, motor_torque=tau, joint_names=robot.joint_names, path=p)


COUNTS_GAP = 0.125
"""[s] A step in time this long is a gap (the filters' :func:`torquemap.sanitize.max_gap_for`
the default 0.05 s window): a multi-turn counter is not unwrapped across it."""


def unwrap_counts(
    raw: NDArray[np.float64], cpr: float, t: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Encoder counts with their wraps undone: every step between samples longer than half a
    turn (``cpr / 2``) is taken as a wrap (``np.unwrap``), except, for a counter that holds more
    than one turn (some ``|count| > cpr``: a multi-turn counter, not a single-turn encoder),
    across a gap in time longer than :data:`COUNTS_GAP`, where the motor may have turned that
    far (before: a 0.5 s gap in a UR10's log shifted every later angle by whole motor turns)."""
    out: NDArray[np.float64] = np.unwrap(raw, period=cpr)
    if raw.size < 2 or not np.any(np.abs(raw) > cpr):
        return out
    gap = np.diff(t) > COUNTS_GAP
    if not gap.any():
        return out
    step = np.diff(out)
    step[gap] = np.diff(raw)[gap]
    return np.concatenate(([out[0]], out[0] + np.cumsum(step)))


def unwrap_multi_turn_counts(
    raw: NDArray[np.float64], cpr: float, t: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Encoder counts with their wraps undone, a multi-turn counter's by its register's size.

    Counts that never leave one turn (``|count| <= cpr``) wrap each turn: as
    :func:`unwrap_counts`. A counter that holds more than one turn does not wrap each turn, so
    a step of more than half a turn is motion (a fast motor at a low logging rate, or across a
    short gap), not a wrap; only the overflows of a 16-bit register whose size is a whole number
    of turns (``2**16`` a multiple of ``cpr``) are undone (other registers' overflows are
    refused: :func:`torquemap.log_quirks.register_overflow`). Before (new-user QA, stop 36),
    :func:`unwrap_counts` took every such step within 0.125 s as a turn's wrap: random SCARA
    7's circle in counts, 0.66 motor turn of joint b across a 0.1 s gap, read one turn off
    (0.09 rad of the joint) from there on, its forces 1.36 N off against 1.20 N from the same
    log in rad.

    Examples
    --------
    >>> unwrap_multi_turn_counts(np.array([0.0, 9000.0, 20000.0]), 16384.0, np.arange(3.0))
    array([    0.,  9000., 20000.])
    >>> unwrap_multi_turn_counts(np.array([20000.0, 32767.0, -32760.0]), 16384.0, np.arange(3.0))
    array([20000., 32767., 32776.])
    """
    if raw.size < 2 or not np.any(np.abs(raw) > cpr):
        return unwrap_counts(raw, cpr, t)
    period = float(2**16)
    lo, hi = float(np.min(raw)), float(np.max(raw))
    in_register = (lo >= -period / 2 and hi < period / 2) or (lo >= 0 and hi < period)
    if cpr > 0 and period % cpr == 0 and in_register:
        unwrapped: NDArray[np.float64] = np.unwrap(raw, period=period)
        return unwrapped
    return np.array(raw, dtype=np.float64)


def single_turn_wrap(raw: NDArray[np.float64], cpr: float) -> int | None:
    """Index of the sample after the first step of more than half a turn in counts that never
    leave one turn (``|count| <= cpr``: a single-turn register wrapping each motor revolution),
    else None. An arm's log in such counts holds each joint's angle only modulo ``2 pi / N``:
    unwrapped from its first sample, a Talos arm's task log read every pose near zero, all
    10 000 samples singular (new-user QA, docs/arm.md); another pose would be silently wrong.

    Examples
    --------
    >>> single_turn_wrap(np.array([100.0, 4000.0, 8000.0, 12000.0, 16300.0, 40.0]), 16384.0)
    5
    >>> single_turn_wrap(np.array([16300.0, 16500.0, 17000.0]), 16384.0) is None
    True
    """
    if raw.size < 2 or np.any(np.abs(raw) > cpr):
        return None
    jumps = np.flatnonzero(np.abs(np.diff(raw)) > cpr / 2)
    return int(jumps[0]) + 1 if jumps.size else None


#: What a log's NaN refusal adds: a logger's missed reads are rows to delete, and the gap they
#: leave is cut and flagged, not refused (before, stop 39: the refusal named the row alone).
LOG_NAN_HINT = (
    ": empty cells or a logger's missed reads? delete those rows (a gap in time is cut and "
    "flagged, not refused)"
)


def _log_arrays(
    cols: Columns,
    robot: Robot,
    p: str,
    *,
    first_row: int = 0,
    last_counts: NDArray[np.float64] | None = None,
    last_t: float | None = None,
    whole: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``(t, q, motor_torque)`` from a log's columns, each checked (:func:`log_from_columns`).

    ``first_row`` offsets the rows named in messages (a chunk of a file); ``last_counts`` holds,
    per joint in encoder counts, the raw and unwrapped count of the previous chunk's last row
    (shape (2, n_joints)), so that unwrapping continues across chunks exactly as over the
    whole file. ``whole``: the columns are the whole log (its time is checked here; a chunk's
    is checked by its reader, across chunks).
    """
    t = numeric_column(
        cols, "t", p, max_abs=MAX_TIME, unit="s", first_row=first_row, nan_hint=LOG_NAN_HINT
    )
    if whole:
        check_time(t, p)
    missing = [j.name for j in robot.joints if f"q_{j.name}" not in cols]
    for name in missing:
        if near_miss(f"q_{name}", list(cols)) is not None:
            raise InputError(missing_column_message(f"q_{name}", list(cols)), path=p)
    others = sorted(k[2:] for k in cols if k.startswith("q_") and k[2:] not in robot.joint_names)
    if missing and others:  # issue 12: a log from another robot, refused clearly
        raise InputError(
            f"the log's joints ({', '.join(others)}) are not the robot's "
            f"({', '.join(robot.joint_names)}): a log from another robot? Use this robot's "
            "logs, or the model identified from the other robot",
            path=p,
        )
    q = np.empty((t.size, len(robot.joints)))
    tau = np.empty_like(q)

    def column(name: str, *, max_abs: float = MAX_MAGNITUDE, unit: str = "") -> NDArray[np.float64]:
        values = numeric_column(
            cols, name, p, max_abs=max_abs, unit=unit, first_row=first_row, nan_hint=LOG_NAN_HINT
        )
        if values.shape != t.shape:
            raise InputError(
                f"column {name!r} has shape {values.shape}, 't' has ({t.size},)", path=p
            )
        return values

    for k, joint in enumerate(robot.joints):
        name = f"q_{joint.name}"
        if joint.position_unit == "counts":
            raw_q = column(name, max_abs=MAX_COUNTS, unit="counts")
            cpr = float(joint.encoder_counts_per_rev or 0)
            if last_counts is None:
                counts = unwrap_multi_turn_counts(raw_q, cpr, t)
                seen = raw_q
            else:
                before_raw, before = float(last_counts[0, k]), float(last_counts[1, k])
                seen = np.concatenate(([before_raw], raw_q))
                joined = unwrap_multi_turn_counts(
                    seen,
                    cpr,
                    np.concatenate(([t[0] if last_t is None else last_t], t)),
                )
                counts = joined[1:] + (before - before_raw)
            overflow = register_overflow(seen, cpr)
            if overflow is not None:
                bits, at = overflow
                raise InputError(
                    f"joint {joint.name}: {name} steps by {seen[at] - seen[at - 1]:+.0f} counts "
                    f"at data row {first_row + at + (1 if last_counts is None else 0)}: a "
                    f"{bits}-bit count register overflowed (or a signed count was written "
                    f"unsigned), so the log holds the count only modulo 2**{bits} and the joint's "
                    "angle is lost; log the count as a signed 64-bit number from the homed zero, "
                    "or the joint angle in rad (position_unit)",
                    path=p,
                )
            if robot.kinematics == "urdf" and joint.gear_ratio != 1.0:
                wrap = single_turn_wrap(seen, cpr)
                if wrap is not None:
                    raise InputError(
                        f"joint {joint.name}: {name} wraps by a motor turn at data row "
                        f"{first_row + wrap + (1 if last_counts is None else 0)} (a single-turn "
                        "encoder register): an arm's pose needs each joint's absolute angle, "
                        f"which motor counts modulo a turn through a {joint.gear_ratio:g}:1 gear "
                        "do not hold; log multi-turn counts from the homed zero, or the joint "
                        "angles in rad (position_unit)",
                        path=p,
                    )
            q[:, k] = counts * (2.0 * np.pi / cpr) / joint.gear_ratio
            far = np.abs(q[:, k]) > MAX_ANGLE
            if far.any():
                row = int(np.argmax(far))
                raise InputError(
                    f"column {name!r} unwraps to {q[row, k]:.6g} rad at data row "
                    f"{first_row + row + 1}, beyond +-{MAX_ANGLE:g} rad",
                    path=p,
                )
        elif joint.position_unit == "turns":
            q[:, k] = (
                column(name, max_abs=MAX_ANGLE, unit="turns") * (2.0 * np.pi) / joint.gear_ratio
            )
        else:
            q[:, k] = column(name, max_abs=MAX_ANGLE, unit="rad")
        if f"tau_{joint.name}" in cols:
            tau[:, k] = column(f"tau_{joint.name}", unit="N m")
        elif f"i_{joint.name}" in cols:
            tau[:, k] = column(f"i_{joint.name}", unit="A") * joint.torque_constant
        else:
            raise InputError(missing_channel_message(joint.name, list(cols)), path=p)
    return t, q, tau


def cut_last_line_warning(path: str | os.PathLike[str]) -> str | None:
    """A warning naming ``path`` when it is a CSV file whose last line has no line end, else None.

    A file copied while another program was writing it ends inside a line, and its last
    number may be cut (``-0.0123`` read as ``-0.01``) with nothing else wrong to see. A line
    end (``\\n``, ``\\r\\n`` or ``\\r``) as the last byte, an empty, unreadable or Parquet file:
    None (tests/test_cli_bad_logs.py).
    """
    p = Path(path)
    if p.suffix.lower() != ".csv":
        return None
    try:
        with open(p, "rb") as handle:
            if handle.seek(0, os.SEEK_END) == 0:
                return None
            handle.seek(-1, os.SEEK_END)
            last = handle.read(1)
    except OSError:
        return None
    if last in (b"\n", b"\r"):
        return None
    return (
        f"{p}: the last line has no line end: if the file was copied while being written its "
        "last row may be cut; check it"
    )


def cut_last_line_warnings(paths: Iterable[str | os.PathLike[str]]) -> list[str]:
    """:func:`cut_last_line_warning` of each path, the Nones left out."""
    return [w for w in (cut_last_line_warning(p) for p in paths) if w is not None]


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


@dataclass(frozen=True, slots=True, eq=False)
class LogChunk:
    """Consecutive rows of a log file read in chunks (:func:`iter_log_chunks`).

    Attributes
    ----------
    t
        Time [s], non-decreasing (also across chunks), shape (m,).
    q
        Joint-side angles [rad], shape (m, n_joints) (counts unwrapped across chunks).
    motor_torque
        Motor-side torque [N m], shape (m, n_joints).
    first_row
        Data row (0-based) of the chunk's first row in the file.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    motor_torque: NDArray[np.float64]
    first_row: int


def _log_column_names(robot: Robot, present: Sequence[str]) -> list[str]:
    """The columns a log of ``robot`` is read from, among ``present`` (missing ones too, so
    that the reader names them)."""
    names = ["t"]
    for joint in robot.joints:
        names.append(f"q_{joint.name}")
        tau, current = f"tau_{joint.name}", f"i_{joint.name}"
        names.append(tau if tau in present else current)
    return names


def _csv_header(p: Path) -> list[str]:
    with open(p, "rb") as handle:
        raw = handle.readline()
    try:
        line = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError("not UTF-8 text in the header; save the file as UTF-8", path=p) from None
    line = line.removeprefix("\ufeff")  # a byte-order mark, as spreadsheets write
    # names as pyarrow reads them (quotes removed, spaces kept), so that a name with spaces
    # gets the same missing-column hint as from read_table, not a parse error later
    return next(csv.reader([line.rstrip("\r\n")]), [])


def _check_log_header(names: Sequence[str], present: Sequence[str], p: Path) -> None:
    """InputError, as :func:`read_log` words it, for the first of ``names`` not ``present``."""
    for name in names:
        if name not in present:
            if name.startswith("i_"):
                j = name[2:]
                raise InputError(missing_channel_message(j, present), path=os.fspath(p))
            raise InputError(missing_column_message(name, present), path=os.fspath(p))


def _record_batches(p: Path, names: list[str], rows: int) -> Iterator[Any]:
    """Record batches of the columns ``names`` that exist in file ``p``."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    if p.suffix.lower() == ".parquet":
        # pre_buffer (the default) keeps every row group's bytes read so far until the file
        # is closed: memory grew with the log (13 bytes per row measured); without it, flat
        handle = pq.ParquetFile(p, pre_buffer=False)
        present = set(handle.schema_arrow.names)
        yield from handle.iter_batches(batch_size=rows, columns=[n for n in names if n in present])
        return
    header = _csv_header(p)
    wanted = [n for n in names if n in header]
    reader = pacsv.open_csv(
        p,
        read_options=pacsv.ReadOptions(block_size=max(1 << 16, 48 * rows)),
        convert_options=pacsv.ConvertOptions(
            include_columns=wanted, column_types={n: pa.float64() for n in wanted}
        ),
    )
    yield from reader


def iter_log_chunks(
    path: str | os.PathLike[str], robot: Robot, *, rows: int = 1 << 18
) -> Iterator[LogChunk]:
    """Read a log file (CSV or Parquet) for ``robot`` in chunks of about ``rows`` rows.

    Memory is bounded by the chunk, not by the file: Parquet is read by record batches of its
    row groups, CSV by blocks of pyarrow's streaming reader. Every chunk is checked as
    :func:`read_log` checks a whole log (columns, NaN, magnitudes, time never going back, also
    across chunks, with the file's own row numbers in messages), and encoder counts are
    unwrapped across chunks exactly as over the whole file.

    Parameters
    ----------
    path
        The log (docs/formats.md).
    robot
        The robot whose joints the log must hold.
    rows
        Rows per chunk (Parquet: exactly, but the last; CSV: about, by bytes).

    Yields
    ------
    LogChunk

    Raises
    ------
    InputError
        As :func:`read_log`, when the chunk holding the fault is reached.
    """
    import pyarrow as pa

    p = Path(path)
    kind = _suffix(p)
    if not p.exists():
        raise InputError("file not found", path=p)
    if p.stat().st_size == 0:
        raise InputError("file is empty", path=p)
    try:
        if kind == ".parquet":
            import pyarrow.parquet as pq

            present: Sequence[str] = pq.ParquetFile(p).schema_arrow.names
        else:
            present = _csv_header(p)
    except (pa.ArrowException, OSError, ValueError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(
            f"cannot parse table, truncated or malformed ({first}){_parse_hint(p)}", path=p
        ) from None
    names = _log_column_names(robot, present)
    _check_log_header(names, present, p)
    chain = _ChunkChain(robot, os.fspath(p))
    batches = _record_batches(p, names, rows)
    while True:
        try:
            batch = next(batches, None)
        except (pa.ArrowException, OSError, ValueError) as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise InputError(
                f"cannot parse table, truncated or malformed ({first}){_parse_hint(p)}", path=p
            ) from None
        if batch is None:
            break
        if batch.num_rows:
            yield chain.chunk({n: batch.column(n).to_numpy(zero_copy_only=False) for n in names})
    chain.close()


def _check_still_growing(path: Path, handle: BinaryIO, *, refuse: bool) -> bool:
    """Whether the followed file is now shorter than what was read; InputError when it was
    replaced or removed, or is shorter and ``refuse``: the rows written after that would be
    silently missed (the reader waits at its old position in the old file)."""
    try:
        now = os.stat(path)
    except OSError:
        raise InputError("the log was removed while it was followed", path=path) from None
    read = handle.tell()
    replaced = now.st_ino != os.fstat(handle.fileno()).st_ino
    shorter = now.st_size < read
    if replaced or (shorter and refuse):
        raise InputError(
            f"the log was truncated or replaced while it was followed ({now.st_size} bytes "
            f"now, {read} read): follow a file that only grows, one run per file",
            path=path,
        )
    return shorter


class _ChunkChain:
    """Checks and state carried from one chunk of a log to the next (time, counts, rows)."""

    def __init__(self, robot: Robot, path: str) -> None:
        self.robot = robot
        self.path = path
        self.rows = 0
        self.last_t: float | None = None
        self.last_counts: NDArray[np.float64] | None = None
        self.advanced = False

    def chunk(self, cols: Columns) -> LogChunk:
        """The next chunk from its columns (checked, counts unwrapped)."""
        robot, first_row = self.robot, self.rows
        t, q, tau = _log_arrays(
            cols,
            robot,
            self.path,
            first_row=first_row,
            last_counts=self.last_counts,
            last_t=self.last_t,
            whole=False,
        )
        joined = t if self.last_t is None else np.concatenate(([self.last_t], t))
        step = np.diff(joined)
        if step.size and not np.all(step >= 0):
            at = int(np.argmax(step < 0))
            offset = first_row - (0 if self.last_t is None else 1)
            hint = backwards_time_hint(joined, at, first_row=offset)
            raise InputError(
                f"time 't' goes backwards (at data row {at + 2 + offset}){hint}", path=self.path
            )
        self.advanced = self.advanced or bool(np.any(step > 0))
        for k, joint in enumerate(robot.joints):
            if joint.position_unit != "counts":
                continue
            if self.last_counts is None:
                self.last_counts = np.zeros((2, len(robot.joints)))
            raw = float(np.asarray(cols[f"q_{joint.name}"], dtype=np.float64)[-1])
            cpr = float(joint.encoder_counts_per_rev or 0)
            # unwrapping adds whole periods: recover their number exactly
            turns = round((q[-1, k] * joint.gear_ratio * cpr / (2.0 * np.pi) - raw) / cpr)
            self.last_counts[:, k] = raw, raw + turns * cpr
        self.last_t = float(t[-1])
        self.rows += t.size
        return LogChunk(t=t, q=q, motor_torque=tau, first_row=first_row)

    def close(self) -> None:
        """InputError unless the whole log had rows, two samples and advancing time."""
        if self.rows == 0:
            raise InputError("table has no rows", path=self.path)
        if self.rows < 2:
            raise InputError("log needs at least two samples", path=self.path)
        if not self.advanced:
            raise InputError(
                "time 't' never advances" + _float32_time_note(np.array([self.last_t])),
                path=self.path,
            )


def follow_log_chunks(
    path: str | os.PathLike[str],
    robot: Robot,
    *,
    poll: float = 0.2,
    timeout: float = 10.0,
    sleep: Callable[[float], object] | None = None,
) -> Iterator[LogChunk]:
    """Read a CSV log that another program is still writing, as it grows (``tail -f``).

    The file is polled every ``poll`` seconds; each poll yields the complete lines written
    since the last (a line still being written waits for its newline). Reading stops when the
    file has not grown for ``timeout`` seconds, or on Ctrl-C (KeyboardInterrupt while waiting);
    then a last line without its newline is read too. Checked as :func:`iter_log_chunks`.

    Parameters
    ----------
    path
        A ``.csv`` log with its header line written.
    robot
        The robot whose joints the log must hold.
    poll
        Seconds between polls.
    timeout
        Seconds without growth after which reading stops.
    sleep
        The waiting function (``time.sleep``; tests pass their own).

    Yields
    ------
    LogChunk
    """
    import io as _io
    import time

    import pyarrow as pa
    import pyarrow.csv as pacsv

    p = Path(path)
    if p.suffix.lower() != ".csv":
        raise InputError("--follow reads a growing CSV log (.csv)", path=p)
    if not p.exists():
        raise InputError("file not found", path=p)
    wait = time.sleep if sleep is None else sleep
    header = _csv_header(p)
    names = _log_column_names(robot, header)
    _check_log_header(names, header, p)
    chain = _ChunkChain(robot, os.fspath(p))
    with open(p, "rb") as handle:
        head = handle.readline()
        pending = b""
        quiet = 0.0
        stop = False
        shrunk = False
        while True:
            data = handle.read()
            if data:
                quiet = 0.0
                pending += data
            cut = pending.rfind(b"\n") + 1
            if stop and pending.strip():
                cut = len(pending)
            if cut:
                lines, pending = pending[:cut], pending[cut:]
                if lines.strip():
                    try:
                        table = pacsv.read_csv(
                            _io.BytesIO(head + lines),
                            convert_options=pacsv.ConvertOptions(
                                include_columns=names,
                                column_types={n: pa.float64() for n in names},
                            ),
                        )
                    except (pa.ArrowException, ValueError) as exc:
                        first = str(exc).strip().splitlines()[0]
                        raise InputError(f"cannot parse rows ({first})", path=p) from None
                    yield chain.chunk({n: table.column(n).to_numpy() for n in names})
            if stop:
                break
            if not data:
                # two polls in a row: a writer that rewrites the file in place passes through
                # a shorter file for a moment
                shrunk = _check_still_growing(p, handle, refuse=shrunk)
                if quiet >= timeout:
                    stop = True
                    continue
                try:
                    wait(poll)
                except KeyboardInterrupt:
                    stop = True
                    continue
                quiet += poll
    chain.close()


@contextlib.contextmanager
def table_stream(
    path: str | os.PathLike[str], *, flush: bool = False
) -> Iterator[Callable[[Mapping[str, ArrayLike]], None]]:
    """Write a table in parts as they are computed, atomically (:func:`atomic_output`).

    Yields a function that appends rows (a mapping of column name to equal-length arrays, the
    same columns each time); the file appears under ``path`` only when the block ends without
    an error, whole. CSV as :func:`render_table` writes it (the header, then rows), Parquet
    one row group per part, uncompressed. Memory holds one part, not the table. ``flush``: CSV
    rows reach the (temporary) file at each part, for a reader following it.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> with table_stream(d / "x.csv") as append:
    ...     append({"a": [1.0, 2.0]})
    ...     append({"a": [3.0]})
    >>> (d / "x.csv").read_text().split()
    ['a', '1', '2', '3']
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    p = Path(path)
    kind = _suffix(p)
    with atomic_output(p) as tmp, contextlib.ExitStack() as stack:
        state: dict[str, Any] = {}

        def append(columns: Mapping[str, ArrayLike]) -> None:
            arrays = {k: np.asarray(v) for k, v in columns.items()}
            table = pa.table(arrays)
            if kind == ".csv":
                if "handle" not in state:
                    for name in arrays:
                        if any(c in name for c in ',"\r\n'):
                            raise InputError(
                                f"column name {name!r} cannot be written to a CSV header"
                            )
                    state["handle"] = stack.enter_context(open(tmp, "wb"))
                    state["handle"].write((",".join(arrays) + "\n").encode())
                if table.num_rows:
                    pacsv.write_csv(
                        table,
                        state["handle"],
                        write_options=pacsv.WriteOptions(
                            include_header=False, quoting_style="none"
                        ),
                    )
            else:
                if "writer" not in state:
                    # no compression: snappy saves 3-4 % of an estimate's float columns
                    # and costs a quarter of the write time
                    state["writer"] = stack.enter_context(
                        pq.ParquetWriter(
                            tmp,
                            table.schema,
                            use_dictionary=_dictionary_columns(arrays),
                            compression="none",
                        )
                    )
                if table.num_rows:
                    state["writer"].write_table(table)
            if flush and "handle" in state:
                state["handle"].flush()

        yield append
