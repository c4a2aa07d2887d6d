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
