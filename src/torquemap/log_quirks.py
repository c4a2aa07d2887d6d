"""Quirks of logs as real motor controllers and loggers write them (new-user QA, stop 36).

Each function recognises one quirk that a simulated bench does not produce and that, read as
written, gave a wrong number or a refusal that did not say why (docs/safety.md, "Log quirks
QA"): an encoder count register that overflows (:func:`register_overflow`), a time stamp counter
that wraps or rows out of order (:func:`backwards_time_hint`), time stamps rounded to a few
decimals (:func:`coarse_time_warning`), angles in another unit or on the other side of the gear
(:func:`angle_unit_hint`), and a units row or decimal commas in a CSV (:func:`cell_hint`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: Widths [bits] of the count registers drives and encoder interfaces keep: 16-bit timers in
#: encoder mode, 32-bit shadow counts (ODrive's ``shadow_count``, CiA 402's position actual
#: value).
REGISTER_BITS = (16, 32)


def register_overflow(raw: NDArray[np.float64], cpr: float) -> tuple[int, int] | None:
    """``(bits, row)`` when encoder counts ``raw`` show a count register of ``bits`` bits
    overflowing (first between samples ``row - 1`` and ``row``), else None.

    A register of ``b`` bits that overflows steps by about ``2**b`` counts between two samples
    (from ``2**15 - 1`` to ``-2**15``, or from ``2**16 - 1`` to 0), far more than the motor
    turns in a sample: recognised when some step is within a quarter of ``2**b`` of it, every
    other step is under a quarter of ``2**b``, and the counts stay in the register's signed or
    unsigned range. Such a log holds the count modulo ``2**b``: unwrapped from its first row,
    the joint's angle is off by every overflow before it (a 16-bit register holds 8 motor turns
    of an 8000-count encoder, 0.5 rad of a 100:1 joint). Left to
    :func:`torquemap.io.unwrap_counts`, as before: a 16-bit register whose size is a whole
    number of turns (``2**16`` a multiple of ``cpr``: its overflows unwrap as turns), and a
    register that holds at most two turns (a single-turn encoder's own wrap).

    Before (new-user QA, stop 36), such an overflow was unwrapped by whole turns: each left
    1536 counts (0.19 turn) of an 8000-count encoder behind, an "encoder glitch" that cut the
    log, and every angle was off; the paper bench's forces were 10 to 35 N off (0.10 N clean),
    exit 0.

    Parameters
    ----------
    raw
        Encoder counts as logged, shape (n,).
    cpr
        Encoder counts per motor revolution.

    Examples
    --------
    >>> counts = np.arange(0, 200_000, 1000.0)
    >>> register_overflow((counts + 2**15) % 2**16 - 2**15, 8000.0)
    (16, 33)
    >>> register_overflow((counts + 2**15) % 2**16 - 2**15, 16384.0) is None
    True
    >>> register_overflow((counts - 5000.0) % 2**32, 16384.0)
    (32, 5)
    """
    if raw.size < 2:
        return None
    step = np.abs(np.diff(raw))
    lo, hi = float(np.min(raw)), float(np.max(raw))
    for bits in REGISTER_BITS:
        period = float(2**bits)
        if cpr >= period / 2 or (bits == 16 and cpr > 0 and period % cpr == 0):
            continue
        wraps = np.abs(step - period) < period / 4
        if not wraps.any():
            continue
        others = step[~wraps]
        if others.size and float(np.max(others)) >= period / 4:
            continue
        signed = lo >= -period / 2 and hi < period / 2
        unsigned = lo >= 0 and hi < period
        if signed or unsigned:
            return bits, int(np.argmax(wraps)) + 1
    return None
