"""Logs as real controllers and loggers write them: quirks that gave wrong numbers silently or
refusals that did not say why (new-user QA, stop 36; docs/safety.md, "Log quirks QA").

Each test builds its log here, small and seeded, and asserts one independent fact: the exact
refusal or warning, or the same numbers as the clean log.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from torquemap.errors import InputError
from torquemap.io import iter_log_chunks, log_from_columns, read_log, write_table
from torquemap.robot import Joint, Robot

#: The paper bench's joint a: 100:1, 8000 counts per motor turn, logged as raw counts.
COUNTS = Robot(
    name="m", kinematics="none", link_lengths=(), joints=(Joint("m", 100.0, 0.11, 8000, "counts"),)
)


def _counts(n: int = 4000) -> dict[str, np.ndarray]:
    """A joint sweeping 1 rad and back at 1 kHz: 16 motor turns, 127 324 counts."""
    t = np.arange(n) * 1e-3
    joint = np.sin(math.pi * t / t[-1])
    counts = np.floor(joint * 100.0 * 8000 / (2 * math.pi))
    return {"t": t, "q_m": counts, "i_m": np.cos(t)}


@pytest.mark.parametrize(
    ("bits", "register"),
    [
        (16, lambda c: (c + 2**15) % 2**16 - 2**15),  # int16 timer in encoder mode
        (16, lambda c: c % 2**16),  # the same, written unsigned
        (32, lambda c: (c - 5000.0) % 2**32),  # a signed count near zero written as uint32
    ],
)
def test_an_overflowing_count_register_is_refused(
    tmp_path: Path, bits: int, register: object
) -> None:
    # Before: each overflow was unwrapped as whole turns, leaving 1536 counts (0.19 turn) of
    # an 8000-count encoder behind; the paper bench's forces were 10 to 35 N off, exit 0.
    cols = _counts()
    clean = log_from_columns(cols, COUNTS)
    assert clean.q[:, 0].max() == pytest.approx(1.0, abs=1e-4)  # the clean log reads right
    cols["q_m"] = register(cols["q_m"])  # type: ignore[operator]
    rows = np.flatnonzero(np.abs(np.abs(np.diff(cols["q_m"])) - 2.0**bits) < 2.0**bits / 4)
    message = (
        rf"joint m: q_m steps by [+-]\d+ counts at data row {rows[0] + 2}: a {bits}-bit count "
        rf"register overflowed \(or a signed count was written unsigned\), so the log holds the "
        rf"count only modulo 2\*\*{bits}"
    )
    with pytest.raises(InputError, match=message):
        log_from_columns(cols, COUNTS)
    p = tmp_path / "log.parquet"  # read in chunks (estimate's large logs): the same row
    write_table(p, cols)
    with pytest.raises(InputError, match=message):
        list(iter_log_chunks(p, COUNTS, rows=700))
    with pytest.raises(InputError, match=message):
        read_log(p, COUNTS)
