"""docs/api-example.md runs: its python blocks in order, each printing what the page shows."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

PAGE = Path(__file__).resolve().parents[1] / "docs" / "api-example.md"


def _cells(text: str) -> list[tuple[str, str | None]]:
    """(python code, the text block right after it or None)."""
    blocks = re.findall(r"```(python|text)\n(.*?)```", text, re.S)
    out: list[tuple[str, str | None]] = []
    for kind, body in blocks:
        if kind == "python":
            out.append((body, None))
        elif out and out[-1][1] is None:
            out[-1] = (out[-1][0], body)
    return out


@pytest.mark.filterwarnings("error")
def test_every_cell_prints_what_the_page_shows() -> None:
    cells = _cells(PAGE.read_text(encoding="utf-8"))
    assert len(cells) >= 6
    scope: dict[str, object] = {"__name__": "api_example"}
    for code, shown in cells:
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            exec(compile(code, str(PAGE), "exec"), scope)
        if shown is not None:
            assert buf.getvalue() == shown, code
