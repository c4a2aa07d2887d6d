"""Progress of long steps: a hook library functions call, reporters the CLI installs.

Library code takes ``progress: Progress | None = None`` and reports through it without knowing
who listens (the default, :data:`NULL`, does nothing)::

    def build_everything(data, *, progress: Progress | None = None) -> Result:
        with steps(progress).step("fit the tables", total=len(data)) as step:
            for block in data:
                ...
                step.advance()

The CLI passes the reporter :func:`reporter` picks: on a terminal a rich spinner (a bar where the
step knows its total) with the elapsed time, then one line per finished step; when stderr is piped
or redirected, plain lines, one per step (``torquemap: fit the tables ... done (3.2 s)``) and
never one per item; with ``--quiet``, nothing. Progress always goes to stderr: stdout carries the
command's results.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any, TextIO, TypeVar

T = TypeVar("T")

__all__ = ["NULL", "PlainProgress", "Progress", "RichProgress", "Step", "reporter", "steps"]


class Step:
    """The handle of one running step: count done items, change the detail shown."""

    def advance(self, amount: float = 1.0) -> None:
        """``amount`` more items of the step's total are done."""

    def describe(self, detail: str) -> None:
        """Show ``detail`` (for example ``"joint b"``) beside the step's label."""


class Progress:
    """The library-side hook. This base class does nothing; reporters override :meth:`step`."""

    @contextmanager
    def step(self, label: str, *, total: float | None = None) -> Iterator[Step]:
        """A step named ``label`` (``total`` items if known); ends when the block exits."""
        yield Step()

    def run(self, label: str, fn: Callable[[], T], *, total: float | None = None) -> T:
        """``fn()`` inside a step named ``label``; returns what ``fn`` returns."""
        with self.step(label, total=total):
            return fn()


#: The hook that reports nothing (the default of every library function).
NULL = Progress()


def steps(progress: Progress | None) -> Progress:
    """``progress``, or :data:`NULL` for ``None``: what a library function reports through.

    Examples
    --------
    >>> with steps(None).step("nothing shown", total=3) as s:
    ...     s.advance()
    """
    return NULL if progress is None else progress


def _seconds(start: float) -> str:
    return f"{time.perf_counter() - start:.1f} s"


class PlainProgress(Progress):
    """One plain line per step on a stream (for logs and pipes): no item counts, no colours.

    A step's line is written when it starts and completed with ``done (<elapsed>)`` when it ends;
    a step that starts inside another closes the outer line first, and the outer step then ends
    with a line of its own.
    """

    def __init__(self, stream: TextIO, *, prefix: str = "torquemap: ") -> None:
        self.stream = stream
        self.prefix = prefix
        self._open: str | None = None  # the label whose line awaits its "done"

    def _write(self, text: str) -> None:
        self.stream.write(text)
        self.stream.flush()

    @contextmanager
    def step(self, label: str, *, total: float | None = None) -> Iterator[Step]:
        if self._open is not None:
            self._write("\n")
        self._write(f"{self.prefix}{label} ...")
        self._open = label
        start = time.perf_counter()
        ok = False
        try:
            yield Step()
            ok = True
        finally:
            end = f"done ({_seconds(start)})" if ok else f"stopped ({_seconds(start)})"
            if self._open == label:
                self._write(f" {end}\n")
            else:
                self._write(f"{self.prefix}{label}: {end}\n")
            self._open = None


class _RichStep(Step):
    def __init__(self, bar: Any, task: Any, label: str) -> None:
        self._bar = bar
        self._task = task
        self._label = label

    def advance(self, amount: float = 1.0) -> None:
        self._bar.update(self._task, advance=amount)

    def describe(self, detail: str) -> None:
        self._bar.update(self._task, description=f"{self._label}: {detail}")


class RichProgress(Progress):
    """A rich spinner (or bar, where the total is known) per running step on a terminal.

    Finished steps leave one line, ``done <label> (<elapsed>)``; nested steps show together.
    """

    def __init__(self, stream: TextIO) -> None:
        from rich.console import Console

        self.console = Console(file=stream)
        self._bar: Any = None
        self._depth = 0

    def _live(self) -> Any:
        if self._bar is None:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                SpinnerColumn,
                TextColumn,
                TimeElapsedColumn,
            )
            from rich.progress import (
                Progress as RichBar,
            )

            self._bar = RichBar(
                SpinnerColumn(),
                TextColumn("{task.description}"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeElapsedColumn(),
                console=self.console,
                transient=True,
            )
            self._bar.start()
        return self._bar

    @contextmanager
    def step(self, label: str, *, total: float | None = None) -> Iterator[Step]:
        bar = self._live()
        task = bar.add_task(label, total=total)
        self._depth += 1
        start = time.perf_counter()
        ok = False
        try:
            yield _RichStep(bar, task, label)
            ok = True
        finally:
            bar.remove_task(task)
            mark = "[green]done[/green]" if ok else "[red]stopped[/red]"
            self.console.print(f"{mark} {label} ({_seconds(start)})", highlight=False)
            self._depth -= 1
            if self._depth == 0:
                bar.stop()
                self._bar = None


def reporter(*, quiet: bool = False, stream: TextIO | None = None) -> Progress:
    """The reporter for a command: :data:`NULL` if ``quiet``, rich on a terminal, else plain lines.

    Parameters
    ----------
    quiet
        Report nothing.
    stream
        Where progress goes (default: ``sys.stderr``, looked up at call time).

    Examples
    --------
    >>> import io
    >>> out = io.StringIO()
    >>> with reporter(stream=out).step("simulate"):
    ...     pass
    >>> out.getvalue().startswith("torquemap: simulate ... done (")
    True
    >>> reporter(quiet=True) is NULL
    True
    """
    if quiet:
        return NULL
    target = sys.stderr if stream is None else stream
    isatty = getattr(target, "isatty", None)
    if callable(isatty) and isatty():
        return RichProgress(target)
    return PlainProgress(target)
