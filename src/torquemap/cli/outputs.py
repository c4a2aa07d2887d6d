"""Output files of the CLI: the format comes from the suffix, checked before any work is done.

Tables (``.csv``, ``.parquet``, ``.json``), figures (``.png``, ``.svg``, ``.pdf``) and the single
format files (``.toml``, ``.html``, ``.npz``): a command checks its outputs' suffixes while it
parses, so a wrong suffix costs one line and exit status 2, not a computation thrown away.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from torquemap.errors import InputError

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


def write_columns(path: str | os.PathLike[str], columns: Mapping[str, ArrayLike]) -> None:
    """Write a table to ``path`` in the format its suffix names (:data:`TABLE_SUFFIXES`)."""
    from torquemap.io import atomic_output, write_table

    if check_table(path) != ".json":
        write_table(path, columns)
        return
    doc = {}
    for name, values in columns.items():
        arr = np.asarray(values)
        if arr.dtype.kind == "f":
            doc[name] = [float(x) if np.isfinite(x) else None for x in arr.tolist()]
        else:
            doc[name] = arr.tolist()
    with atomic_output(path) as tmp:
        tmp.write_text(json.dumps(doc, allow_nan=False) + "\n")
