"""Logs read in chunks (iter_log_chunks), followed as they grow, and tables written in parts."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from torquemap.errors import InputError
from torquemap.io import (
    follow_log_chunks,
    iter_log_chunks,
    read_log,
    read_table,
    table_stream,
    write_table,
)
from torquemap.robot import Joint, Robot

COUNTS = Robot(
    name="m", kinematics="none", link_lengths=(), joints=(Joint("m", 50.0, 0.5, 8192, "counts"),)
)


def _counts_log(n: int = 5000) -> dict[str, np.ndarray]:
    t = np.arange(n) * 1e-3
    motor_angle = 0.3 + 20.0 * np.sin(0.8 * t) + 9.0 * t  # several revolutions, both ways
    counts = np.floor(motor_angle / (2 * math.pi / 8192))
    return {"t": t, "q_m": np.mod(counts, 8192), "i_m": np.cos(t)}


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_chunks_join_to_the_whole_log(tmp_path: Path, suffix: str) -> None:
    p = tmp_path / f"log{suffix}"
    write_table(p, _counts_log())
    whole = read_log(p, COUNTS)
    chunks = list(iter_log_chunks(p, COUNTS, rows=700))
    assert len(chunks) >= 3  # the wrapped register crosses chunk boundaries
    assert [c.first_row for c in chunks] == list(np.cumsum([0] + [c.t.size for c in chunks])[:-1])
    # the same parse, and unwrapping carried across chunks: equal to the bit
    assert_array_equal(np.concatenate([c.t for c in chunks]), whole.t)
    assert_array_equal(np.concatenate([c.q for c in chunks]), whole.q)
    assert_array_equal(np.concatenate([c.motor_torque for c in chunks]), whole.motor_torque)


def test_a_fault_in_a_later_chunk_names_its_row_in_the_file(tmp_path: Path) -> None:
    cols = _counts_log(3000)
    cols["t"][2500] = cols["t"][2498]  # time goes back at data row 2501
    p = tmp_path / "log.parquet"
    write_table(p, cols)
    with pytest.raises(InputError, match="goes backwards \\(at data row 2501\\)"):
        list(iter_log_chunks(p, COUNTS, rows=1000))
    with pytest.raises(InputError, match="goes backwards \\(at data row 2501\\)"):
        read_log(p, COUNTS)
    cols = _counts_log(3000)
    cols["i_m"][2100] = np.nan
    write_table(p, cols)
    with pytest.raises(InputError, match="first at data row 2101"):
        list(iter_log_chunks(p, COUNTS, rows=1000))
    write_table(p, {"t": cols["t"], "q_m": cols["q_m"]})
    with pytest.raises(InputError, match="missing column 'i_m' or 'tau_m'"):
        list(iter_log_chunks(p, COUNTS))


def test_a_followed_log_is_read_as_it_grows(tmp_path: Path) -> None:
    cols = _counts_log(3000)
    p = tmp_path / "full.csv"
    write_table(p, cols)
    text = p.read_bytes()
    header_end = text.index(b"\n") + 1
    # another program writes the log in uneven pieces, cutting lines in the middle
    cuts = [header_end, 500, 20000, 20001, 45000, len(text)]
    growing = tmp_path / "growing.csv"
    growing.write_bytes(text[: cuts[0]])
    pieces = iter(cuts[1:])
    waits = []

    def sleep(seconds: float) -> None:
        waits.append(seconds)
        end = next(pieces, None)
        if end is not None:
            growing.write_bytes(text[:end])

    got = list(follow_log_chunks(growing, COUNTS, poll=0.5, timeout=2.0, sleep=sleep))
    whole = read_log(p, COUNTS)
    assert_array_equal(np.concatenate([c.t for c in got]), whole.t)
    assert_array_equal(np.concatenate([c.q for c in got]), whole.q)
    # it stops after the timeout without growth: 4 polls of 0.5 s after the last piece
    assert sum(waits[-4:]) == pytest.approx(2.0)
    with pytest.raises(InputError, match="growing CSV"):
        list(follow_log_chunks(tmp_path / "x.parquet", COUNTS))


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_table_written_in_parts_equals_one_written_whole(tmp_path: Path, suffix: str) -> None:
    cols = {"t": np.arange(10) * 0.1, "x": np.sin(np.arange(10)), "flag": np.arange(10)}
    write_table(tmp_path / f"whole{suffix}", cols)
    with table_stream(tmp_path / f"parts{suffix}") as append:
        for a, b in ((0, 3), (3, 3), (3, 10)):
            append({k: v[a:b] for k, v in cols.items()})
    if suffix == ".csv":
        assert (tmp_path / "parts.csv").read_bytes() == (tmp_path / "whole.csv").read_bytes()
    got = read_table(tmp_path / f"parts{suffix}")
    for k, v in cols.items():
        assert_array_equal(got[k], v)


def test_a_failed_stream_leaves_no_file(tmp_path: Path) -> None:
    out = tmp_path / "out.csv"
    with pytest.raises(RuntimeError), table_stream(out) as append:
        append({"a": np.arange(3.0)})
        raise RuntimeError("disk full")
    assert list(tmp_path.iterdir()) == []


def test_a_header_with_spaces_gets_the_same_hint_read_whole_or_in_chunks(tmp_path: Path) -> None:
    cols = _counts_log(50)
    p = tmp_path / "spaced.csv"
    rows = "".join(f"{a:.17g},{b:.17g},{c:.17g}\n" for a, b, c in zip(*cols.values(), strict=True))
    p.write_text("t , q_m,i_m\n" + rows)
    with pytest.raises(InputError) as whole:
        read_log(p, COUNTS)
    with pytest.raises(InputError) as chunked:
        list(iter_log_chunks(p, COUNTS, rows=10))
    with pytest.raises(InputError) as followed:
        list(follow_log_chunks(p, COUNTS, timeout=0.0, sleep=lambda s: None))
    hint = f"{p}: missing column 't' (the file has 't ': names are exact, lower case, no unit)"
    assert str(whole.value) == str(chunked.value) == str(followed.value) == hint
    p.write_text('"t","q_m","i_m"\n' + rows)  # quoted names are the names
    assert_array_equal(np.concatenate([c.t for c in iter_log_chunks(p, COUNTS)]), cols["t"])


@pytest.mark.parametrize("rows", [700, 1000, 10_000])
def test_a_multi_turn_counter_is_not_unwrapped_across_a_gap(tmp_path: Path, rows: int) -> None:
    """A counter holding many turns (the arm benches' absolute counts) across a 0.5 s gap in
    which the motor turned 3.6 revolutions: read as logged, whole or in chunks (the gap inside
    a chunk, or at a boundary), not shifted by whole turns (found on a UR10 log with a gap:
    every angle after it was off by up to 0.63 rad and identification failed)."""
    t = np.arange(3000) * 1e-3
    t[1000:] += 0.5  # the gap, after row 1000 (a chunk boundary with rows=1000)
    motor_angle = 400.0 + 45.0 * t
    counts = np.floor(motor_angle / (2 * math.pi / 8192))
    p = tmp_path / "log.csv"
    write_table(p, {"t": t, "q_m": counts, "i_m": np.zeros_like(t)})
    whole = read_log(p, COUNTS).q[:, 0]
    assert_allclose(whole, motor_angle / 50.0, atol=2 * math.pi / 8192 / 50.0)
    chunks = np.concatenate([c.q[:, 0] for c in iter_log_chunks(p, COUNTS, rows=rows)])
    assert_array_equal(chunks, whole)


@pytest.mark.parametrize("how", ["truncated", "replaced", "removed"])
def test_a_followed_log_that_is_truncated_or_replaced_is_refused(tmp_path: Path, how: str) -> None:
    # the logger restarts and writes a new log under the same name; before: the follower
    # waited at its old position (or on the old file), missed every new row and ended after
    # the timeout with exit 0
    cols = _counts_log(3000)
    p = tmp_path / "full.csv"
    write_table(p, cols)
    text = p.read_bytes()
    growing = tmp_path / "growing.csv"
    growing.write_bytes(text[:40000])
    calls = []

    def sleep(seconds: float) -> None:
        calls.append(seconds)
        if len(calls) == 1:
            if how == "truncated":
                growing.write_bytes(text[:2000])  # same file, shorter, then growing again
            elif how == "replaced":
                other = tmp_path / "new.csv"
                other.write_bytes(text[:45000])
                other.replace(growing)
            else:
                growing.unlink()

    message = {"truncated": "truncated or replaced", "replaced": "truncated or replaced"}
    with pytest.raises(InputError, match=message.get(how, "removed while it was followed")):
        list(follow_log_chunks(growing, COUNTS, poll=0.5, timeout=5.0, sleep=sleep))


def test_a_log_rewritten_in_place_for_a_moment_is_followed(tmp_path: Path) -> None:
    # a writer that rewrites the whole file passes through a shorter file: one poll of it is
    # not a truncation
    cols = _counts_log(3000)
    p = tmp_path / "full.csv"
    write_table(p, cols)
    text = p.read_bytes()
    growing = tmp_path / "growing.csv"
    growing.write_bytes(text[:40000])
    states = iter([text[:100], text])

    def sleep(seconds: float) -> None:
        nxt = next(states, None)
        if nxt is not None:
            growing.write_bytes(nxt)

    got = list(follow_log_chunks(growing, COUNTS, poll=0.5, timeout=1.0, sleep=sleep))
    assert_array_equal(np.concatenate([c.t for c in got]), read_log(p, COUNTS).t)
