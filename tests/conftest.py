"""Shared fixtures: the simulated SCARA bench, run once per test session."""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import pytest

from torquemap import progress
from torquemap.sim.bench import write_scara_bench


@pytest.fixture(autouse=True)
def _no_progress_lines(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """No step lasts long enough to be reported: stderr holds only what a test checks.

    The CLI reports steps over 2 s (torquemap.progress.SHOW_AFTER); on a loaded machine any step
    may take that long, which would make stderr depend on the load. tests/test_progress.py sets
    the threshold it tests.
    """
    monkeypatch.setattr(progress, "SHOW_AFTER", math.inf)
    yield


@pytest.fixture(scope="session")
def scara_bench(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The simulated SCARA bench written with seed 0; returns its folder.

    The folder holds robot.toml, sweep.csv, circle.csv, truth.csv and truth.toml
    (docs/formats.md). Treat it as read-only: every test of the session shares it.
    """
    out = tmp_path_factory.mktemp("scara_bench")
    write_scara_bench(out, seed=0)
    return out
