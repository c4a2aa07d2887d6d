"""Help of the CLI: descriptions wrapped by paragraph, examples in the epilog, as typed."""

from __future__ import annotations

import argparse
import textwrap
from collections.abc import Sequence
from typing import Any

WIDTH = 78


def described(description: str, examples: Sequence[str]) -> dict[str, Any]:
    """Keyword arguments of ``add_parser``: the description and an ``examples:`` epilog.

    The description's paragraphs (blank-line separated) are wrapped here, because the raw
    formatter that keeps the examples' lines as written keeps the description's lines too.

    Examples
    --------
    >>> kw = described("Say hello.", ["torquemap hello"])
    >>> print(kw["epilog"])
    example:
      torquemap hello
    """
    paragraphs = [textwrap.fill(" ".join(p.split()), WIDTH) for p in description.split("\n\n")]
    head = "example:" if len(examples) == 1 else "examples:"
    return {
        "description": "\n\n".join(paragraphs),
        "epilog": "\n".join([head, *(f"  {e}" for e in examples)]),
        "formatter_class": argparse.RawDescriptionHelpFormatter,
    }
