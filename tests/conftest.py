"""Shared fixtures: the simulated SCARA bench, run once per test session."""

from __future__ import annotations

from pathlib import Path

import pytest

from torquemap.sim.bench import write_scara_bench


@pytest.fixture(scope="session")
def scara_bench(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The simulated SCARA bench written with seed 0; returns its folder.

    The folder holds robot.toml, sweep.csv, circle.csv, truth.csv and truth.toml
    (docs/formats.md). Treat it as read-only: every test of the session shares it.
    """
    out = tmp_path_factory.mktemp("scara_bench")
    write_scara_bench(out, seed=0)
    return out
