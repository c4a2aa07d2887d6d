"""Table files: TABLES.npz, raw EPROM images, Intel HEX and a C header (docs/linearize.md).

Addressing (the paper's joint interface board, §4.2): the table position ``p`` and the signed
torque command ``c`` (two's complement, ``mask = 2**bits - 1``) are concatenated into the word
address ``(p << bits) | (c & mask)``; with 9 position bits and 8 command bits that is the
128K x 8 EPROM of one phase. Entries wider than 8 bits are stored as little-endian words of
``w = ceil(entry_bits / 8)`` bytes at byte address ``w * word_address``.

Every writer renders its bytes in memory first; :func:`write_outputs` renders all requested
outputs before writing any, then writes each through a temporary file and a rename.
"""

from __future__ import annotations

import contextlib
import math
import os
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from torquemap.ctext import c_comment, c_float, c_identifier, check_c_identifier
from torquemap.errors import InputError
from torquemap.io import atomic_output, atomic_outputs, check_output_file, output_folder
from torquemap.linearize.tables import TableSet

_META = (
    "torque_per_count",
    "torque_max",
    "command_scaling",
    "log_curvature",
    "motor_name",
    "ramping",
    "method",
    "command_bits",
    "actuation_max",
    "motor_actuation_max",
    "positions_per_cycle",
    "equilibrium_positions",
    "monotonic",
    "voids_filled",
    "median_cells",
    "monotonic_fixes",
)


def entry_bytes(tables: TableSet) -> int:
    """Bytes per table entry: ``ceil(bits(actuation_max) / 8)``.

    Examples
    --------
    >>> import types
    >>> entry_bytes(types.SimpleNamespace(actuation_max=255)), entry_bytes(
    ...     types.SimpleNamespace(actuation_max=65535))
    (1, 2)
    """
    return max(1, (int(tables.actuation_max).bit_length() + 7) // 8)


def _dtype(tables: TableSet) -> np.dtype[Any]:
    return np.dtype({1: "<u1", 2: "<u2"}.get(entry_bytes(tables), "<u4"))


def npz_arrays(tables: TableSet) -> dict[str, NDArray[Any]]:
    """The arrays of TABLES.npz: ``phase_1 .. phase_m``, ``base``, ``ramp`` and 0-d metadata."""
    out: dict[str, NDArray[Any]] = {
        f"phase_{k + 1}": tables.phases[k].astype(_dtype(tables))
        for k in range(tables.phases.shape[0])
    }
    out["base"] = tables.base
    out["ramp"] = tables.ramp
    for name in _META:
        value = getattr(tables, name)
        out[name] = np.asarray(list(value) if isinstance(value, tuple) else value)
    out["denoise_rank"] = np.asarray(tables.denoise_rank)  # optional on reading (added later)
    out["handover_cells"] = np.asarray(tables.handover_cells)  # optional on reading (added later)
    out["detent_harmonics"] = np.asarray(tables.detent_harmonics, dtype=np.int64)  # optional too
    out["surface"] = np.asarray(tables.surface)  # optional on reading (added later)
    return out


def _npz_bytes(tables: TableSet, tmp: Path) -> None:
    with tmp.open("wb") as handle:
        np.savez_compressed(handle, **npz_arrays(tables))  # type: ignore[arg-type]


def save_tables(path: str | os.PathLike[str], tables: TableSet) -> None:
    """Write TABLES.npz atomically."""
    with atomic_output(path) as tmp:
        _npz_bytes(tables, tmp)


def read_npz_arrays(path: str | os.PathLike[str]) -> dict[str, NDArray[Any]]:
    """Every array of an ``.npz`` file, read whole.

    Raises
    ------
    InputError
        On a missing file, or one that is not a readable ``.npz`` (not a zip archive,
        truncated, a member whose compressed bytes or checksum are corrupt, pickled objects).
    """
    p = os.fspath(path)
    if not Path(p).exists():
        raise InputError("file not found", path=p)
    if not zipfile.is_zipfile(p):  # np.load would call it "pickled data" and suggest unpickling
        raise InputError(
            "cannot read tables, corrupt or truncated (not a zip archive, as .npz files are)",
            path=p,
        )
    try:
        with open(p, "rb") as handle, np.load(handle, allow_pickle=False) as npz:
            return {name: np.asarray(npz[name]) for name in npz.files}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as exc:
        # zlib.error: a corrupt byte inside a compressed member (np.savez_compressed)
        raise InputError(f"cannot read tables, corrupt or truncated ({exc})", path=p) from None


def _check_entries(data: dict[str, NDArray[Any]], phases: int, top: int, path: str) -> None:
    """Every phase table integer-valued and within ``0 .. top`` (the builder writes no other)."""
    for k in range(phases):
        name = f"phase_{k + 1}"
        table = data[name]
        if not np.issubdtype(table.dtype, np.integer):
            raise InputError(f"table {name!r} must hold integers, got {table.dtype}", path=path)
        if table.size and (table.min() < 0 or table.max() > top):
            bad = np.argwhere((table < 0) | (table > top))[0]
            raise InputError(
                f"table {name!r} holds {table[tuple(bad)]} at position {bad[0]}, command "
                f"{bad[1]}, outside 0 .. {top} (actuation_max): corrupt tables?",
                path=path,
            )


def load_tables(path: str | os.PathLike[str]) -> TableSet:
    """Read TABLES.npz.

    Raises
    ------
    InputError
        On a missing, corrupt or truncated file, a missing array, inconsistent shapes, table
        entries that are not integers in ``0 .. actuation_max``, a torque scale that is not
        a positive number, or a NaN or infinity in ``base`` or ``ramp``.
    """
    p = os.fspath(path)
    data = read_npz_arrays(p)
    for name in (*_META, "base", "ramp", "phase_1"):
        if name not in data:
            raise InputError(f"tables file lacks {name!r}", path=p)
    m = 0
    while f"phase_{m + 1}" in data:
        m += 1
    names = sorted(k for k in data if k.startswith("phase_") and k[6:].isdigit())
    stray = [k for k in names if int(k[6:]) > m]
    if stray:
        raise InputError(
            f"tables file lacks 'phase_{m + 1}' but holds {', '.join(stray)}: corrupt tables?",
            path=p,
        )
    try:
        top = int(data["actuation_max"])
    except (TypeError, ValueError) as exc:
        raise InputError(f"tables file has malformed contents ({exc})", path=p) from None
    _check_entries(data, m, top, p)
    shapes = {data[f"phase_{k + 1}"].shape for k in range(m)}
    if len(shapes) > 1:
        first = data["phase_1"].shape
        odd = next(k + 1 for k in range(m) if data[f"phase_{k + 1}"].shape != first)
        raise InputError(
            f"table 'phase_{odd}' has shape {data[f'phase_{odd}'].shape}, 'phase_1' {first}: "
            "truncated or corrupt tables?",
            path=p,
        )
    try:
        phases = np.stack([data[f"phase_{k + 1}"].astype(np.int64) for k in range(m)])
        meta = {name: data[name].item() if data[name].ndim == 0 else data[name] for name in _META}
        tables = TableSet(
            phases=phases,
            torque_per_count=float(meta["torque_per_count"]),
            torque_max=float(meta["torque_max"]),
            command_scaling=str(meta["command_scaling"]),  # type: ignore[arg-type]
            log_curvature=float(meta["log_curvature"]),
            base=np.asarray(data["base"], dtype=np.float64),
            ramp=np.asarray(data["ramp"], dtype=np.float64),
            motor_name=str(meta["motor_name"]),
            ramping=str(meta["ramping"]),
            method=str(meta["method"]),
            command_bits=int(meta["command_bits"]),
            actuation_max=int(meta["actuation_max"]),
            motor_actuation_max=int(meta["motor_actuation_max"]),
            positions_per_cycle=int(meta["positions_per_cycle"]),
            equilibrium_positions=tuple(
                int(e) for e in np.atleast_1d(meta["equilibrium_positions"])
            ),
            monotonic=bool(meta["monotonic"]),
            voids_filled=int(meta["voids_filled"]),
            median_cells=int(meta["median_cells"]),
            monotonic_fixes=int(meta["monotonic_fixes"]),
            denoise_rank=int(data["denoise_rank"].item()) if "denoise_rank" in data else 0,
            handover_cells=(int(data["handover_cells"].item()) if "handover_cells" in data else 0),
            surface=bool(data["surface"].item()) if "surface" in data else False,
        )
    except (TypeError, ValueError) as exc:
        raise InputError(f"tables file has malformed contents ({exc})", path=p) from None
    shape = (m, tables.positions_per_cycle, 1 << tables.command_bits)
    if len(tables.equilibrium_positions) != m:
        raise InputError(
            f"tables hold {m} phase tables and {len(tables.equilibrium_positions)} equilibrium "
            "positions, one a phase: corrupt tables?",
            path=p,
        )
    if tables.phases.shape != shape:
        raise InputError(
            f"tables have shape {tables.phases.shape}, the metadata says {shape}", path=p
        )
    if tables.command_scaling not in ("linear", "log"):
        raise InputError(f"unknown command_scaling {tables.command_scaling!r}", path=p)
    scales = ("torque_per_count", "torque_max")
    for name in (*scales, "log_curvature") if tables.command_scaling == "log" else scales:
        value = getattr(tables, name)
        if not (math.isfinite(value) and value > 0):
            raise InputError(f"{name} is {value}, not a positive number: corrupt tables?", path=p)
    for name in ("base", "ramp"):  # the builder writes finite values only (clipped, rounded)
        values = getattr(tables, name)
        if not np.all(np.isfinite(values)):
            at = tuple(int(i) for i in np.argwhere(~np.isfinite(values))[0])
            raise InputError(
                f"array {name!r} holds {values[at]} at {list(at)}, not a number: corrupt tables?",
                path=p,
            )
    return tables


def eprom_image(tables: TableSet, phase: int) -> bytes:
    """The raw image of one phase (1-based): entry ``[p, c]`` at word ``(p << bits) | c``.

    Examples
    --------
    >>> import types
    >>> t = types.SimpleNamespace(phases=np.arange(8).reshape(1, 2, 4), actuation_max=255)
    >>> eprom_image(t, 1).hex()
    '0001020304050607'
    """
    table = np.asarray(tables.phases[phase - 1])
    return table.astype(_dtype(tables)).tobytes(order="C")


def _record(kind: int, address: int, payload: bytes) -> str:
    body = bytes([len(payload), (address >> 8) & 0xFF, address & 0xFF, kind]) + payload
    checksum = (-sum(body)) & 0xFF
    return ":" + (body + bytes([checksum])).hex().upper()


def intel_hex(image: bytes, *, record_size: int = 16) -> str:
    """Intel HEX text of an image starting at address 0.

    Data records (type 00) of ``record_size`` bytes, an extended linear address record (type 04)
    before the first record of every 64 KiB segment above the first, and the EOF record (01).

    Examples
    --------
    >>> print(intel_hex(bytes([1, 2, 3])))
    :03000000010203F7
    :00000001FF
    """
    lines: list[str] = []
    segment = 0
    for start in range(0, len(image), record_size):
        upper = start >> 16
        if upper != segment:
            lines.append(_record(4, 0, upper.to_bytes(2, "big")))
            segment = upper
        chunk = image[start : min(start + record_size, (upper + 1) << 16, len(image))]
        lines.append(_record(0, start & 0xFFFF, chunk))
    lines.append(_record(1, 0, b""))
    return "\n".join(lines) + "\n"


def c_header(tables: TableSet, *, prefix: str | None = None) -> str:
    """A C header with the phase tables as const arrays and the torque scale.

    Parameters
    ----------
    tables
        The tables.
    prefix
        C identifier prefixing every name (``[A-Za-z_][A-Za-z0-9_]*``); default: made from the
        motor name by :func:`torquemap.ctext.c_identifier`. The motor name itself appears only
        in a comment, escaped by :func:`torquemap.ctext.c_comment`.

    Raises
    ------
    InputError
        On a prefix that is not a C identifier, or a non-finite torque scale.
    """
    name = (
        check_c_identifier(prefix) if prefix else c_identifier(tables.motor_name, fallback="motor")
    )
    upper = name.upper()
    m, n, width = tables.phases.shape
    ctype = {1: "uint8_t", 2: "uint16_t"}.get(entry_bytes(tables), "uint32_t")
    guard = f"TORQUEMAP_{upper}_TABLES_H"
    suffix = "u" if entry_bytes(tables) > 2 else ""
    lines = [
        f"/* Torque-linearisation tables for motor '{c_comment(tables.motor_name)}', written by "
        "torquemap.",
        f" * {m} phases x {n} positions x {width} commands ({tables.command_bits}-bit signed).",
        f" * Lookup: {name}_phase_k[p][c & {width - 1}] for table position p (0..{n - 1}) and",
        " * torque command c (two's complement, so c = -1 is the last column); as one flat",
        f" * EPROM image the entry sits at word address (p << {tables.command_bits}) | (c & "
        f"{width - 1}).",
        f" * Command scaling: {tables.command_scaling}"
        + (
            f", torque = sign(c) * TORQUE_MAX * expm1({c_comment(f'{tables.log_curvature:g}')} * |c| / "
            f"{tables.command_max}) / expm1({c_comment(f'{tables.log_curvature:g}')})."
            if tables.command_scaling == "log"
            else ", torque = c * TORQUE_PER_COUNT."
        ),
        " */",
        f"#ifndef {guard}",
        f"#define {guard}",
        "",
        "#include <stdint.h>",
        "",
        f"#define {upper}_PHASES {m}",
        f"#define {upper}_POSITIONS {n}",
        f"#define {upper}_COMMAND_BITS {tables.command_bits}",
        f"#define {upper}_ACTUATION_MAX {int(tables.actuation_max)}{suffix}",
        f"#define {upper}_TORQUE_PER_COUNT {c_float(tables.torque_per_count)} "
        "/* N m per command unit */",
        f"#define {upper}_TORQUE_MAX {c_float(tables.torque_max)} /* N m at the largest command */",
        "",
    ]
    for k in range(m):
        lines.append(f"static const {ctype} {name}_phase_{k + 1}[{n}][{width}] = {{")
        for row in tables.phases[k]:
            lines.append("    {" + ",".join(f"{int(v)}{suffix}" for v in row.tolist()) + "},")
        lines.append("};")
        lines.append("")
    lines.append(f"#endif /* {guard} */")
    return "\n".join(lines) + "\n"


def write_outputs(
    tables: TableSet,
    *,
    npz: str | os.PathLike[str] | None = None,
    bin_dir: str | os.PathLike[str] | None = None,
    hex_dir: str | os.PathLike[str] | None = None,
    c_header_path: str | os.PathLike[str] | None = None,
) -> list[str]:
    """Write every requested output; nothing is written unless all could be rendered.

    Parameters
    ----------
    tables
        The tables.
    npz
        TABLES.npz.
    bin_dir
        Folder (created) for ``phase_1.bin`` .. ``phase_m.bin``.
    hex_dir
        Folder (created) for ``phase_1.hex`` .. ``phase_m.hex``.
    c_header_path
        The C header.

    Returns
    -------
    list of str
        The files written.

    Raises
    ------
    InputError
        If an output folder (of npz or the header) does not exist, or a folder path is a file,
        or an output is read-only. All files are staged as temporaries and renamed together: on
        any failure (a full disk) none is written and folders created here are removed.
    """
    m = tables.phases.shape[0]
    for target in (npz, c_header_path):
        if target is not None:
            check_output_file(target)
    for folder in (bin_dir, hex_dir):
        if folder is not None and Path(folder).exists() and not Path(folder).is_dir():
            raise InputError("output folder is a file", path=folder)
    rendered: dict[Path, bytes | str | None] = {}
    if npz is not None:
        rendered[Path(npz)] = None
    images = [eprom_image(tables, k + 1) for k in range(m)] if (bin_dir or hex_dir) else []
    if bin_dir is not None:
        for k, image in enumerate(images):
            rendered[Path(bin_dir) / f"phase_{k + 1}.bin"] = image
    if hex_dir is not None:
        for k, image in enumerate(images):
            rendered[Path(hex_dir) / f"phase_{k + 1}.hex"] = intel_hex(image)
    if c_header_path is not None:
        rendered[Path(c_header_path)] = c_header(tables)
    with contextlib.ExitStack() as stack:
        for folder in (bin_dir, hex_dir):
            if folder is not None:
                stack.enter_context(output_folder(folder))
        paths = list(rendered)
        with atomic_outputs(paths) as tmps:
            for tmp, content in zip(tmps, rendered.values(), strict=True):
                if content is None:
                    _npz_bytes(tables, tmp)
                elif isinstance(content, bytes):
                    tmp.write_bytes(content)
                else:
                    tmp.write_text(content)
    return [os.fspath(path) for path in paths]
