"""Ctrl-C: one line and exit 130 at any point, the imports of the commands included."""

from __future__ import annotations

import importlib
import subprocess
import sys
from types import ModuleType

import pytest

import torquemap.cli.main as cli


def test_ctrl_c_while_the_commands_import(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: the commands (and numpy, ~0.5 s) were imported with torquemap.cli.main, before
    # main() and its handler: Ctrl-C in the first half second printed a traceback
    real = importlib.import_module

    def interrupted(name: str, package: str | None = None) -> ModuleType:
        if name == "torquemap.cli.cmd_estimate":
            raise KeyboardInterrupt
        return real(name, package)

    monkeypatch.setattr(importlib, "import_module", interrupted)
    assert cli.main(["--version"]) == 130
    assert capsys.readouterr().err == "torquemap: interrupted\n"


def test_the_entry_module_imports_no_command() -> None:
    # what runs before main()'s handler: the entry module and what it imports
    code = (
        "import sys, torquemap.cli.main; "
        "print(sorted(m for m in sys.modules if m.startswith(('numpy', 'torquemap.cli.cmd_'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
