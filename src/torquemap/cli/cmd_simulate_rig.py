"""CLI: placeholder for the `simulate_rig` sub-commands; filled in by its issue."""

from __future__ import annotations

import argparse
from typing import Any


def register(subparsers: argparse._SubParsersAction[Any]) -> None:
    """Add this module's sub-commands to subparsers (a command group's sub-parsers)."""
