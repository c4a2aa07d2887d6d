"""The one exception type for bad user input."""

from __future__ import annotations

import os


class InputError(ValueError):
    """Bad input from a user: a file, a column, a key or an option.

    The CLI prints it as one line, ``torquemap: error: <path>: <message>``, and exits with
    status 2. Library callers can catch it as a :class:`ValueError`.

    Parameters
    ----------
    message
        What is wrong, in one line.
    path
        The file the problem is in, when there is one.

    Examples
    --------
    >>> str(InputError("missing column 'q_a'", path="log.csv"))
    "log.csv: missing column 'q_a'"
    """

    def __init__(self, message: str, *, path: str | os.PathLike[str] | None = None) -> None:
        super().__init__(message)
        self.message = message
        self.path = None if path is None else os.fspath(path)

    def __str__(self) -> str:
        return self.message if self.path is None else f"{self.path}: {self.message}"


def one_line(text: str) -> str:
    r"""``text`` on one line: line breaks and other unprintable characters as escapes.

    User text (a joint name, a key) can hold any character; a message naming it must still be
    one line on a terminal and in a log, so a line feed, ``\x1e``, ``\u2028`` and the like are
    written as their escapes.

    Examples
    --------
    >>> print(one_line("[joints.a\nb] must be a table"))
    [joints.a\nb] must be a table
    """
    return "".join(
        ch if ch.isprintable() or ch == " " else ch.encode("unicode_escape").decode("ascii")
        for ch in text
    )
