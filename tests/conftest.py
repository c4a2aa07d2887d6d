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


@pytest.fixture(scope="session")
def scara_model(scara_bench: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The model ``torquemap identify`` (defaults: whole-log friction) writes from the bench's
    sweeps; returns the model file's path. Shared: identification is the expensive step."""
    from torquemap.cli.main import main

    out = tmp_path_factory.mktemp("scara_model") / "model.toml"
    argv = ["identify", str(scara_bench / "robot.toml"), str(scara_bench / "sweep.csv")]
    assert main([*argv, "-o", str(out)]) == 0
    return out
