"""argparse types for numeric options: a bad value is one usage line, never a traceback."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def int_in(low: int, high: int) -> Callable[[str], int]:
    """An argparse type: an integer in ``low .. high``.

    Examples
    --------
    >>> int_in(1, 32)("8")
    8
    """

    def parse(text: str) -> int:
        try:
            value = int(text, 10)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be in {low} .. {high}, got {value}")
        return value

    parse.__name__ = "integer"
    return parse


def float_in(
    low: float, high: float = math.inf, *, low_open: bool = False
) -> Callable[[str], float]:
    """An argparse type: a finite number in ``[low, high]`` (``(low, high]`` when ``low_open``).

    Examples
    --------
    >>> float_in(0.0, low_open=True)("2.5")
    2.5
    """

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
        ok = math.isfinite(value) and value <= high and (value > low if low_open else value >= low)
        if not ok:
            left = "(" if low_open else "["
            right = f"{high:g}]" if math.isfinite(high) else "inf)"
            raise argparse.ArgumentTypeError(
                f"must be a number in {left}{low:g}, {right}, got {text}"
            )
        return value

    parse.__name__ = "number"
    return parse


def add_window_argument(parser: argparse.ArgumentParser, *, default: float | None = None) -> None:
    """Add ``--window S``, the differentiator window [s], to a command that differentiates.

    ``default=None``: the window the model was identified with (else 0.05 s).
    """
    where = (
        "the window the model was identified with, else 0.05"
        if default is None
        else f"{default:g}; stored in the model for later commands"
    )
    parser.add_argument(
        "--window",
        type=float_in(0.0, 10.0, low_open=True),
        default=default,
        metavar="S",
        help=f"differentiator window [s] for velocity and acceleration (default: {where})",
    )
