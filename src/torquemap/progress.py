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
never one per item; with ``--quiet``, nothing. Steps quicker than :data:`SHOW_AFTER` (2 s) leave
no line. Progress always goes to stderr: stdout carries the
command's results.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
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


#: Steps shorter than this [s] leave no line (a spinner shows meanwhile on a terminal).
SHOW_AFTER = 2.0


def _seconds(start: float) -> str:
    return f"{time.perf_counter() - start:.1f} s"


@dataclass(slots=True)
class _Line:
    label: str
    start: float
    shown: bool = False
    ended: bool = False


class PlainProgress(Progress):
    """One plain line per step that lasts, on a stream (for logs and pipes): no counts, no colour.

    A step's line is written once it has run ``after`` seconds (default :data:`SHOW_AFTER`;
    quicker steps leave none) and completed with ``done (<elapsed>)`` when it ends. A step shown
    inside another closes the outer line first; the outer step then ends with a line of its own.
    """

    def __init__(
        self, stream: TextIO, *, after: float | None = None, prefix: str = "torquemap: "
    ) -> None:
        self.stream = stream
        self.after = after
        self.prefix = prefix
        self._open: _Line | None = None  # the step whose line awaits its "done"
        self._lock = threading.Lock()

    def _write(self, text: str) -> None:
        self.stream.write(text)
        self.stream.flush()

    def _show(self, line: _Line) -> None:
        with self._lock:
            if line.ended:
                return
            if self._open is not None:
                self._write("\n")
            self._write(f"{self.prefix}{line.label} ...")
            self._open = line
            line.shown = True

    @contextmanager
    def step(self, label: str, *, total: float | None = None) -> Iterator[Step]:
        """One step: a line when it ends (plain lines for a pipe)."""
        line = _Line(label, time.perf_counter())
        delay = SHOW_AFTER if self.after is None else self.after
        timer = None
        if delay <= 0:
            self._show(line)
        elif math.isfinite(delay):
            timer = threading.Timer(delay, self._show, args=(line,))
            timer.daemon = True
            timer.start()
        ok = False
        try:
            yield Step()
            ok = True
        finally:
            if timer is not None:
                timer.cancel()
            with self._lock:
                line.ended = True
                if line.shown:
                    end = "done" if ok else "stopped"
                    end += f" ({_seconds(line.start)})"
                    if self._open is line:
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


def _count_column() -> Any:
    from rich.progress import ProgressColumn
    from rich.text import Text

    class CountColumn(ProgressColumn):
        """``done/total`` where the step knows its total, nothing where it does not."""

        def render(self, task: Any) -> Text:
            if task.total is None:
                return Text("")
            return Text(f"{int(task.completed)}/{int(task.total)}", style="progress.download")

    return CountColumn()


class RichProgress(Progress):
    """A rich spinner (or bar, where the total is known) per running step on a terminal.

    Steps that lasted ``after`` seconds (default :data:`SHOW_AFTER`) leave one line,
    ``done <label> (<elapsed>)``; nested steps show together.
    """

    def __init__(self, stream: TextIO, *, after: float | None = None) -> None:
        from rich.console import Console

        self.console = Console(file=stream)
        self.after = after
        self._bar: Any = None
        self._depth = 0

    def _live(self) -> Any:
        if self._bar is None:
            from rich.progress import (
                BarColumn,
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
                _count_column(),
                TimeElapsedColumn(),
                console=self.console,
                transient=True,
            )
            self._bar.start()
        return self._bar

    @contextmanager
    def step(self, label: str, *, total: float | None = None) -> Iterator[Step]:
        """One step: a spinner or bar on the terminal, then a line when it ends."""
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
            bar.refresh()
            after = SHOW_AFTER if self.after is None else self.after
            if not ok or time.perf_counter() - start >= after:
                mark = "[green]done[/green]" if ok else "[red]stopped[/red]"
                self.console.print(f"{mark} {label} ({_seconds(start)})", highlight=False)
            self._depth -= 1
            if self._depth == 0:
                bar.stop()
                self._bar = None


def reporter(
    *, quiet: bool = False, stream: TextIO | None = None, after: float | None = None
) -> Progress:
    """The reporter for a command: :data:`NULL` if ``quiet``, rich on a terminal, else plain lines.

    Parameters
    ----------
    quiet
        Report nothing.
    stream
        Where progress goes (default: ``sys.stderr``, looked up at call time).
    after
        Steps quicker than this [s] leave no line (default :data:`SHOW_AFTER`, 2 s).

    Examples
    --------
    >>> import io
    >>> out = io.StringIO()
    >>> with reporter(stream=out, after=0).step("simulate"):
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
        return RichProgress(target, after=after)
    return PlainProgress(target, after=after)
