"""Run the tutorial's commands and write what they print into docs/tutorial.md (and the others).

The tutorial pairs each ```` ```sh ```` block of commands with the ```` ```text ```` block right
after it: what those commands print (stdout and stderr, in order; progress lines, which only
steps over 2 s leave, are not shown). This script runs every command in a fresh folder and
rewrites the text blocks; ``tests/test_tutorial.py`` runs the same commands and fails when a
block differs from what the tool prints, so the tutorial cannot drift from the tool::

    PYTHONPATH=src python docs/gen_tutorial.py          # rewrite docs/tutorial.md
    PYTHONPATH=src python docs/gen_tutorial.py --check  # exit 1 if it would change

Only torquemap commands run, and ``head -n N FILE`` (to show a file written); ``make demo`` runs
``torquemap demo --out demo-out``, what the Makefile does; ``git``, ``make test`` and ``export``
lines are the reader's. The numbers that
vary from run to run (:data:`MASKS`: the demo's elapsed seconds) are compared masked.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import shlex
import sys
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

TUTORIAL = Path(__file__).with_name("tutorial.md")
#: The pages whose outputs are generated and checked, each run in a fresh folder of its own.
PAGES = (TUTORIAL, Path(__file__).with_name("estimation.md"))
#: Lines of a sh block that stand for a torquemap command (the Makefile's recipe).
ALIASES = {"make demo": "torquemap demo --out demo-out"}
#: Numbers that vary from run to run: (pattern, replacement) applied before comparing.
MASKS = ((re.compile(r"^(report: \S+ +\()\d+( s\))$", re.M), r"\1<seconds>\2"),)


@dataclass(frozen=True, slots=True)
class Block:
    """One sh block: its commands, and the text block after it (``None`` if there is none)."""

    commands: tuple[str, ...]
    output: str | None
    span: tuple[int, int] | None  # line range of the text block's body in the file


def _fence(lines: list[str], start: int) -> int:
    """Index of the closing fence of the block opened at ``start``."""
    for k in range(start + 1, len(lines)):
        if lines[k].strip() == "```":
            return k
    raise ValueError(f"unclosed code block at line {start + 1}")


def parse(text: str) -> list[Block]:
    """The sh blocks of a tutorial, each with the text block that follows it."""
    lines = text.split("\n")
    blocks = []
    k = 0
    while k < len(lines):
        if lines[k].strip() != "```sh":
            k += 1
            continue
        end = _fence(lines, k)
        commands = []
        for raw in lines[k + 1 : end]:
            line = " ".join(shlex.split(raw, comments=True))
            line = ALIASES.get(line, line)
            if line.startswith(("torquemap ", "head ")):
                commands.append(line)
        k = end + 1
        output, span = None, None
        if k < len(lines) and lines[k].strip() == "```text":
            close = _fence(lines, k)
            output = "\n".join(lines[k + 1 : close]) + "\n"
            span = (k + 1, close)
            k = close + 1
        blocks.append(Block(tuple(commands), output, span))
    return blocks


def masked(text: str) -> str:
    """``text`` with the numbers of :data:`MASKS` replaced."""
    for pattern, replacement in MASKS:
        text = pattern.sub(replacement, text)
    return text


#: A decimal number as the commands print it (sign, digits, optional fraction and exponent).
NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def mismatches(got: str, shown: str, *, rtol: float) -> list[str]:
    """Where ``got`` differs from ``shown`` beyond floating-point noise, one line each.

    The words must be identical and the numbers equal within ``rtol`` of the larger (or within
    one unit of the last digit printed). Another CPU or BLAS build rounds differently, and a
    discrete choice near a tie (a sample flagged or not) moves a count by one or two: those are
    not drift of the docs, which is what this catches (a changed word, format or result).
    """
    got_m, shown_m = masked(got), masked(shown)
    if NUMBER.sub("#", got_m) != NUMBER.sub("#", shown_m):
        import difflib

        diff = difflib.unified_diff(
            shown_m.splitlines(), got_m.splitlines(), "shown", "printed", lineterm="", n=0
        )
        return ["the words differ:", *diff]
    out: list[str] = []
    for a, b in zip(NUMBER.findall(got_m), NUMBER.findall(shown_m), strict=True):
        x, y = float(a), float(b)
        digits = b.split(".")[1] if "." in b and "e" not in b.lower() else ""
        ulp = 10.0 ** -len(digits) if "e" not in b.lower() else 0.0
        if abs(x - y) > max(rtol * max(abs(x), abs(y)), ulp * 1.0001):
            out.append(f"printed {a}, shown {b}")
    return out


@contextlib.contextmanager
def working_directory(path: Path) -> Iterator[None]:
    """Run the block inside ``path`` (the commands use relative paths, as a reader types them)."""
    before = Path.cwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(before)


def run(command: str) -> str:
    """Run one torquemap command in-process in the current folder; what it prints, in order.

    Raises
    ------
    RuntimeError
        If the command exits with a status other than 0.
    """
    import math

    from torquemap import progress
    from torquemap.cli.main import main

    words = shlex.split(command)
    if words[0] == "head":
        if len(words) != 4 or words[1] != "-n":
            raise ValueError(f"only 'head -n N FILE' is understood, not {command!r}")
        with open(words[3], encoding="utf-8") as handle:
            return "".join(handle.readline() for _ in range(int(words[2])))
    buffer = io.StringIO()
    shown_after = progress.SHOW_AFTER
    progress.SHOW_AFTER = math.inf  # progress lines are not part of the shown output
    try:
        with contextlib.redirect_stdout(buffer), contextlib.redirect_stderr(buffer):
            status = main(words[1:])
    finally:
        progress.SHOW_AFTER = shown_after
    if status != 0:
        raise RuntimeError(f"{command!r} exited with {status}:\n{buffer.getvalue()}")
    return buffer.getvalue()


def run_all(blocks: list[Block], runner: Callable[[str], str] = run) -> list[str]:
    """What each block's commands print, concatenated per block."""
    return ["".join(runner(c) for c in block.commands) for block in blocks]


def rewrite(text: str, blocks: list[Block], printed: list[str]) -> str:
    """``text`` with each text block replaced by what its commands printed."""
    lines = text.split("\n")
    for block, out in sorted(
        zip(blocks, printed, strict=True), key=lambda p: -(p[0].span or (0, 0))[0]
    ):
        if block.span is not None:
            a, b = block.span
            lines[a:b] = out.rstrip("\n").split("\n")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Rewrite the pages' outputs (or, with --check, report whether they are up to date)."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if a page would change")
    args = parser.parse_args(argv)
    status = 0
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        blocks = parse(text)
        with tempfile.TemporaryDirectory(prefix="docs-") as tmp, working_directory(Path(tmp)):
            printed = run_all(blocks)
        new = rewrite(text, blocks, printed)
        if args.check:
            same = masked(new) == masked(text)
            print(f"{page.name} is up to date" if same else f"{page.name} differs")
            status = max(status, 0 if same else 1)
        else:
            page.write_text(new, encoding="utf-8")
            print(f"wrote {page}")
    return status


if __name__ == "__main__":
    sys.exit(main())
