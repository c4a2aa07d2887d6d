"""Table files (torquemap.linearize.export): npz round trip, EPROM images, Intel HEX, C header."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from torquemap.errors import InputError
from torquemap.linearize.export import (
    c_header,
    eprom_image,
    intel_hex,
    load_tables,
    save_tables,
    write_outputs,
)
from torquemap.linearize.motor import motor_spec
from torquemap.linearize.tables import TableSet, build_tables

# one worker runs the module (pytest -n 2 --dist loadgroup), so its module fixture `tables`
# is built once, not once per worker
pytestmark = pytest.mark.xdist_group("export")


def make_tables(n: int = 512, actuation_bits: int | None = None) -> TableSet:
    spec = motor_spec(
        "J 2/x",
        phases=3,
        positions_per_cycle=n,
        equilibrium_positions=(10 * n // 512, 180 * n // 512, 350 * n // 512),
    )
    p, w = np.meshgrid(np.arange(0, n, max(1, n // 64)), np.arange(0, 256, 8), indexing="ij")
    t = (2 + np.cos(6 * np.pi * p / n)) * (w / 255.0) ** 2
    return build_tables(spec, p.ravel(), w.ravel(), t.ravel(), actuation_bits=actuation_bits)


@pytest.fixture(scope="module")
def tables() -> TableSet:
    return make_tables()


def parse_hex(text: str) -> bytes:
    """A tiny independent Intel HEX reader: checks every checksum, honours type 04 records."""
    memory: dict[int, int] = {}
    upper = 0
    lines = text.strip().splitlines()
    assert lines[-1] == ":00000001FF"
    for line in lines:
        assert line[0] == ":"
        raw = bytes.fromhex(line[1:])
        assert sum(raw) & 0xFF == 0, line  # the checksum makes the byte sum 0 mod 256
        count, addr, kind, payload = raw[0], int.from_bytes(raw[1:3], "big"), raw[3], raw[4:-1]
        assert len(payload) == count
        if kind == 0:
            for i, b in enumerate(payload):
                memory[(upper << 16) + addr + i] = b
        elif kind == 4:
            upper = int.from_bytes(payload, "big")
        elif kind == 1:
            break
    return bytes(memory[i] for i in range(len(memory)))


def test_npz_round_trip(tables: TableSet, tmp_path: Path) -> None:
    f = tmp_path / "t.npz"
    save_tables(f, tables)
    back = load_tables(f)
    assert_array_equal(back.phases, tables.phases)
    assert back.torque_per_count == tables.torque_per_count
    assert back.equilibrium_positions == tables.equilibrium_positions
    assert back.motor_name == "J 2/x" and back.command_scaling == "linear"
    with np.load(f) as npz:  # the contract: phase_k of shape (P, 2**bits), 0-d metadata
        assert npz["phase_1"].shape == (512, 256) and npz["phase_1"].dtype == np.uint8
        assert npz["torque_per_count"].ndim == 0 and str(npz["ramping"]) == "wide"


def test_eprom_addressing(tables: TableSet) -> None:
    image = eprom_image(tables, 2)
    assert len(image) == 128 * 1024  # the paper's 128K x 8 EPROM
    table = tables.phases[1]
    for p, c in [(0, 0), (3, 5), (300, -1), (511, 127), (17, -128), (200, -37)]:
        assert image[(p << 8) | (c & 255)] == table[p, c % 256]


def test_wide_entries_little_endian() -> None:
    t = make_tables(64, actuation_bits=16)
    image = eprom_image(t, 1)
    assert len(image) == 64 * 256 * 2
    p, c = 10, 100  # phase 1 at full ramp
    word = (p << 8) | c
    assert int.from_bytes(image[2 * word : 2 * word + 2], "little") == t.phases[0, p, c]
    assert t.phases[0, p, c] > 255


def test_intel_hex_round_trip(tables: TableSet) -> None:
    image = eprom_image(tables, 1)
    text = intel_hex(image)
    assert text.count(":02000004") == 1  # one extended linear address record (128 KiB)
    assert parse_hex(text) == image
    small = bytes(range(40))
    assert parse_hex(intel_hex(small)) == small


def test_c_header(tables: TableSet) -> None:
    text = c_header(tables)
    assert "static const uint8_t j_2_x_phase_3[512][256]" in text
    assert f"J_2_X_TORQUE_PER_COUNT {tables.torque_per_count!r}" in text
    assert "(p << 8) | (c & 255)" in text
    row = "    {" + ",".join(map(str, tables.phases[0, 7])) + "},"
    assert row in text


def test_write_outputs_all_or_nothing(tables: TableSet, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="output folder does not exist"):
        write_outputs(
            tables,
            npz=tmp_path / "t.npz",
            bin_dir=tmp_path / "bin",
            c_header_path=tmp_path / "no" / "t.h",
        )
    assert list(tmp_path.iterdir()) == []
    written = write_outputs(
        tables, npz=tmp_path / "t.npz", bin_dir=tmp_path / "b", hex_dir=tmp_path / "h"
    )
    assert len(written) == 7
    assert (tmp_path / "b" / "phase_3.bin").read_bytes() == eprom_image(tables, 3)
    assert parse_hex((tmp_path / "h" / "phase_1.hex").read_text()) == eprom_image(tables, 1)


def test_load_errors(tables: TableSet, tmp_path: Path) -> None:
    f = tmp_path / "t.npz"
    save_tables(f, tables)
    cut = tmp_path / "cut.npz"
    cut.write_bytes(f.read_bytes()[: f.stat().st_size // 2])
    with pytest.raises(InputError, match="corrupt or truncated"):
        load_tables(cut)
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not a zip at all")
    with pytest.raises(InputError, match=r"junk\.npz: cannot read tables"):
        load_tables(junk)
    # a CSV saved as .npz: np.load called it pickled data and suggested allow_pickle
    text = tmp_path / "text.npz"
    text.write_text("position,pulse_width,torque\n0,0,0.1\n")
    with pytest.raises(InputError, match=r"text\.npz: .*\(not a zip archive, as \.npz files are\)"):
        load_tables(text)
    with pytest.raises(InputError, match="file not found"):
        load_tables(tmp_path / "missing.npz")
    partial = tmp_path / "partial.npz"
    np.savez(partial, phase_1=np.zeros((4, 4), dtype=np.uint8))
    with pytest.raises(InputError, match="lacks 'torque_per_count'"):
        load_tables(partial)
    assert zipfile.is_zipfile(f)


def _member_data_offset(path: Path, member: str) -> tuple[int, int]:
    """Where a zip member's compressed bytes start, and how many (the local header's layout,
    APPNOTE 4.3.7: 30 fixed bytes, then the name and the extra field)."""
    with zipfile.ZipFile(path) as z:
        info = z.getinfo(member)
    raw = path.read_bytes()
    start = info.header_offset
    name_len = int.from_bytes(raw[start + 26 : start + 28], "little")
    extra_len = int.from_bytes(raw[start + 28 : start + 30], "little")
    return start + 30 + name_len + extra_len, info.compress_size


def test_load_refuses_corrupt_contents(tables: TableSet, tmp_path: Path) -> None:
    f = tmp_path / "t.npz"
    save_tables(f, tables)
    # one byte flipped inside a compressed table: at the start of the deflate stream zlib
    # refuses it (zlib.error, a traceback before), further in the member's CRC-32 does
    start, size = _member_data_offset(f, "phase_1.npy")
    for offset in (0, size // 2):
        raw = bytearray(f.read_bytes())
        raw[start + offset] ^= 0xFF
        flipped = tmp_path / "flipped.npz"
        flipped.write_bytes(bytes(raw))
        with pytest.raises(InputError, match=r"flipped\.npz: cannot read tables, corrupt or"):
            load_tables(flipped)
    arrays = dict(np.load(f))
    # an entry beyond the full-scale pulse width (the builder writes 0 .. actuation_max only)
    wide = arrays["phase_2"].astype(np.uint16)
    wide[7, 9] = tables.actuation_max + 1
    np.savez_compressed(tmp_path / "big.npz", **{**arrays, "phase_2": wide})
    with pytest.raises(InputError, match=r"'phase_2' holds 256 at position 7, command 9"):
        load_tables(tmp_path / "big.npz")
    np.savez_compressed(tmp_path / "float.npz", **{**arrays, "phase_3": arrays["phase_3"] * 0.5})
    with pytest.raises(InputError, match="'phase_3' must hold integers, got float64"):
        load_tables(tmp_path / "float.npz")
    for value in (np.nan, -1.0, 0.0):
        np.savez_compressed(tmp_path / "scale.npz", **{**arrays, "torque_per_count": value})
        with pytest.raises(InputError, match=r"torque_per_count is .*not a positive number"):
            load_tables(tmp_path / "scale.npz")


def test_load_names_a_missing_phase_table_or_equilibrium(tables: TableSet, tmp_path: Path) -> None:
    # both were reported as "tables have shape (1, 512, 256), the metadata says (1, 512, 256)":
    # a shape beside the same shape, naming neither the table nor the equilibria
    f = tmp_path / "t.npz"
    save_tables(f, tables)
    arrays = dict(np.load(f))
    gap = {k: v for k, v in arrays.items() if k != "phase_2"}
    np.savez_compressed(tmp_path / "gap.npz", **gap)
    with pytest.raises(
        InputError, match=r"gap\.npz: tables file lacks 'phase_2' but holds phase_3"
    ):
        load_tables(tmp_path / "gap.npz")
    two = {**arrays, "equilibrium_positions": arrays["equilibrium_positions"][:2]}
    np.savez_compressed(tmp_path / "two.npz", **two)
    with pytest.raises(InputError, match=r"two\.npz: tables hold 3 phase tables and 2 equilibrium"):
        load_tables(tmp_path / "two.npz")
