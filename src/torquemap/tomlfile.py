"""Reading TOML input files (robot, model, motor) with every failure as one InputError line."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

from torquemap.errors import InputError

#: Largest TOML input file read [bytes]; robot, model and motor files are a few kB.
MAX_TOML_BYTES = 16 * 1024 * 1024


def read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Parse a TOML file; InputError naming the file on any failure.

    Parameters
    ----------
    path
        The file.

    Returns
    -------
    dict
        The document.

    Raises
    ------
    InputError
        On a missing, unreadable, empty, oversized, non-UTF-8 or malformed file, and on one
        nested too deeply for the parser (an array or table nested thousands deep).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "deep.toml"
    >>> _ = f.write_text("a = " + "[" * 100000 + "]" * 100000)
    >>> try:
    ...     read_toml(f)
    ... except InputError as exc:
    ...     print(exc.message)
    not valid TOML (nested too deeply)
    """
    p = Path(path)
    try:
        if p.is_dir():
            raise InputError("is a folder, expected a TOML file", path=p)
        size = p.stat().st_size
        if size > MAX_TOML_BYTES:
            raise InputError(
                f"file is {size} bytes, more than a TOML input may be "
                f"({MAX_TOML_BYTES // (1024 * 1024)} MiB)",
                path=p,
            )
        text = p.read_bytes()
    except FileNotFoundError:
        raise InputError("file not found", path=p) from None
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror}", path=p) from None
    if not text.strip():
        raise InputError("file is empty", path=p)
    try:
        # "utf-8-sig": a byte-order mark, as Windows editors write one, is skipped
        decoded = text.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(
            f"not UTF-8 text (byte 0x{text[exc.start]:02x} at offset {exc.start})", path=p
        ) from None
    try:
        return tomllib.loads(decoded)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"not valid TOML ({exc})", path=p) from None
    except RecursionError:
        raise InputError("not valid TOML (nested too deeply)", path=p) from None
