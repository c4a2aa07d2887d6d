"""Checks every command makes on its outputs before doing any work (docs/safety.md).

An output may not be one of the command's inputs (the same path, a symbolic or hard link to
it), may not be named twice, must carry the suffix of what is written, must sit in an existing
folder, and may replace an existing file only if that file is writable. The format of an
output comes from its suffix: tables (``.csv``, ``.parquet``, ``.json``), figures (``.png``,
``.svg``, ``.pdf``) and the single-format files (``.toml``, ``.html``, ``.npz``).
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from torquemap.errors import InputError
from torquemap.io import check_output_file, cut_last_line_warnings

PathLike = str | os.PathLike[str]

TABLE = (".csv", ".parquet")
CSV = (".csv",)
FIGURE = (".png", ".pdf", ".svg")
TOML = (".toml",)
JSON = (".json",)
C_HEADER = (".h",)
NPZ = (".npz",)
HTML = (".html", ".htm")


def same_file(a: PathLike, b: PathLike) -> bool:
    """True when ``a`` and ``b`` are one file: the same resolved path, or the same inode.

    Examples
    --------
    >>> same_file("x/../y.csv", "y.csv")
    True
    """
    pa, pb = Path(a), Path(b)
    try:
        if pa.resolve() == pb.resolve():
            return True
    except (OSError, RuntimeError):
        pass
    try:
        sa, sb = pa.stat(), pb.stat()
    except (OSError, ValueError):
        return False
    return (sa.st_dev, sa.st_ino) == (sb.st_dev, sb.st_ino)


def warn_cut_last_lines(logs: Iterable[PathLike]) -> None:
    """Print on stderr a warning for each CSV log whose last line has no line end
    (:func:`torquemap.io.cut_last_line_warning`)."""
    for text in cut_last_line_warnings(logs):
        print(f"torquemap: warning: {text}", file=sys.stderr)


def _suffixes(allowed: Sequence[str]) -> str:
    return " or ".join(allowed)


def check_outputs(
    outputs: Iterable[tuple[PathLike | None, Sequence[str]]],
    inputs: Iterable[PathLike | None] = (),
    *,
    folders: Iterable[tuple[PathLike | None, Sequence[str]]] = (),
) -> None:
    """Refuse, before any work, outputs that would destroy an input or cannot be written.

    Parameters
    ----------
    outputs
        ``(path, suffixes)`` of each output file (None: not requested); ``suffixes`` are the
        allowed ones, lower case (empty: any).
    inputs
        The files the command reads (None entries are skipped).
    folders
        ``(folder, file names)`` of each output folder (created if missing) and the files the
        command writes into it.

    Raises
    ------
    InputError
        Naming the output, on: a suffix that does not match what is written; an output that is
        one of the inputs (same path, or a link to it); the same output named twice; a missing
        output folder; an output that is a folder or a read-only file; an output folder path
        that is a file, or lies below one.
    """
    ins = [Path(p) for p in inputs if p is not None]
    files: list[Path] = []
    for path, allowed in outputs:
        if path is None:
            continue
        target = Path(path)
        if allowed and target.suffix.lower() not in allowed:
            shown = target.suffix or "no suffix"
            raise InputError(
                f"output suffix {shown!r} does not match what is written ({_suffixes(allowed)})",
                path=target,
            )
        files.append(target)
    in_new_folder: set[Path] = set()
    for folder, names in folders:
        if folder is None:
            continue
        base = Path(folder)
        if base.exists() and not base.is_dir():
            raise InputError("output path exists and is not a folder", path=base)
        above = next((a for a in base.parents if a.exists()), None)
        if not base.exists() and above is not None and not above.is_dir():
            raise InputError(
                f"cannot create output folder: {os.fspath(above)} is a file, not a folder",
                path=base,
            )
        for name in names:
            files.append(base / name)
            if not base.exists():
                in_new_folder.add(base / name)
    seen: list[Path] = []
    for target in files:
        for source in ins:
            if same_file(target, source):
                raise InputError(
                    f"output is also an input of this command ({os.fspath(source)}); "
                    "writing it would destroy the input, choose another name",
                    path=target,
                )
        for other in seen:
            if same_file(target, other):
                raise InputError("the same file is named as two outputs", path=target)
        seen.append(target)
        if target not in in_new_folder:
            check_output_file(target)


#: Table outputs: CSV and Parquet as written by :func:`torquemap.io.write_table`; JSON as one
#: object of columns, ``{"name": [values...], ...}`` (NaN and inf as null).
TABLE_SUFFIXES = (".csv", ".parquet", ".json")
#: Figure outputs (matplotlib picks the format from the suffix).
FIGURE_SUFFIXES = (".png", ".svg", ".pdf")


def _listed(allowed: Sequence[str]) -> str:
    return allowed[0] if len(allowed) == 1 else ", ".join(allowed[:-1]) + " or " + allowed[-1]


def output_suffix(path: str | os.PathLike[str], allowed: Sequence[str], what: str) -> str:
    """The lower-case suffix of ``path`` if it is one of ``allowed``; else InputError.

    Examples
    --------
    >>> output_suffix("cog.JSON", TABLE_SUFFIXES, "table")
    '.json'
    """
    suffix = Path(path).suffix.lower()
    if suffix not in allowed:
        given = f"{suffix!r}" if suffix else "no suffix"
        raise InputError(
            f"unknown {what} format ({given}): the suffix chooses it, use {_listed(allowed)}",
            path=path,
        )
    return suffix


def check_table(path: str | os.PathLike[str], allowed: Sequence[str] = TABLE_SUFFIXES) -> str:
    """The suffix of a table output (``.csv``, ``.parquet``, ``.json``)."""
    return output_suffix(path, allowed, "table")


def check_figure(path: str | os.PathLike[str]) -> str:
    """The suffix of a figure output (``.png``, ``.svg``, ``.pdf``)."""
    return output_suffix(path, FIGURE_SUFFIXES, "figure")


def columns_writer(path: str | os.PathLike[str], columns: Mapping[str, ArrayLike]) -> Any:
    """A writer (:func:`torquemap.io.write_all`) of a table in the format its suffix names."""
    from torquemap.io import table_writer

    if check_table(path) != ".json":
        return table_writer(path, columns)
    doc = {}
    for name, values in columns.items():
        arr = np.asarray(values)
        if arr.dtype.kind == "f":
            doc[name] = [float(x) if np.isfinite(x) else None for x in arr.tolist()]
        else:
            doc[name] = arr.tolist()
    text = json.dumps(doc, allow_nan=False) + "\n"
    return lambda tmp: tmp.write_text(text)


def write_columns(path: str | os.PathLike[str], columns: Mapping[str, ArrayLike]) -> None:
    """Write a table to ``path`` in the format its suffix names (:data:`TABLE_SUFFIXES`)."""
    from torquemap.io import write_all

    write_all({Path(path): columns_writer(path, columns)})
