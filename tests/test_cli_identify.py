"""CLI: identify, spectrum, pdtv-map end to end, and one-line errors with exit 2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_identify import ROBOT, simulate

from torquemap.cli.main import main
from torquemap.io import write_table, write_toml
from torquemap.model import load_model


@pytest.fixture(scope="module")
def bench(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("cli")
    t, q, tau = simulate(np.random.default_rng(10), speeds=(1.0, 4.0))
    write_toml(d / "robot.toml", ROBOT)
    write_table(d / "sweep.csv", {"t": t, "q_m": q, "tau_m": tau})
    assert (
        main(
            [
                "identify",
                str(d / "robot.toml"),
                str(d / "sweep.csv"),
                "-o",
                str(d / "model.toml"),
                "--max-order",
                "100",
            ]
        )
        == 0
    )
    return d


def test_identify_writes_a_model_with_notes(bench: Path) -> None:
    model = load_model(bench / "model.toml")
    assert {round(ln.order) for ln in model.joints["m"].pdtv} == {2, 7, 36}
    assert model.notes["logs"] == [str(bench / "sweep.csv")]
    assert model.notes["joints"]["m"]["bins_per_rev"] == 256


def test_spectrum_text_and_figure(bench: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert (
        main(["spectrum", str(bench / "model.toml"), str(bench / "sweep.csv"), "--joint", "m"]) == 0
    )
    out = capsys.readouterr().out
    assert out.splitlines()[2].startswith("2,")  # the strongest line, 2 CPR, first
    fig = bench / "spectrum.png"
    assert (
        main(
            [
                "spectrum",
                str(bench / "model.toml"),
                str(bench / "sweep.csv"),
                "--joint",
                "m",
                "-o",
                str(fig),
            ]
        )
        == 0
    )
    assert fig.read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    "fmt,name", [("csv", "map.csv"), ("json", "map.json"), ("c-header", "map.h")]
)
def test_pdtv_map_formats(bench: Path, fmt: str, name: str) -> None:
    out = bench / name
    assert (
        main(
            [
                "pdtv-map",
                str(bench / "model.toml"),
                "--joint",
                "m",
                "--bins",
                "1024",
                "-o",
                str(out),
                "--format",
                fmt,
            ]
        )
        == 0
    )
    assert out.stat().st_size > 0


def _error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    return err


def test_errors_are_one_line(
    bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    robot = str(bench / "robot.toml")
    t = np.arange(0.0, 2.0, 1e-3)
    write_table(
        tmp_path / "still.csv", {"t": t, "q_m": np.zeros_like(t), "tau_m": np.zeros_like(t)}
    )
    err = _error(
        capsys, ["identify", robot, str(tmp_path / "still.csv"), "-o", str(tmp_path / "m.toml")]
    )
    assert "no joint moves" in err and not (tmp_path / "m.toml").exists()
    write_table(tmp_path / "short.csv", {"t": t[:10], "q_m": t[:10], "tau_m": t[:10]})
    err = _error(
        capsys, ["identify", robot, str(tmp_path / "short.csv"), "-o", str(tmp_path / "m.toml")]
    )
    assert "short.csv" in err and "differentiation window" in err
    err = _error(
        capsys,
        [
            "identify",
            robot,
            str(bench / "sweep.csv"),
            "-o",
            str(tmp_path / "m.toml"),
            "--max-order",
            "5000",
        ],
    )
    assert "needs a slower sweep" in err
    err = _error(
        capsys,
        [
            "pdtv-map",
            str(bench / "model.toml"),
            "--joint",
            "x",
            "--bins",
            "8",
            "-o",
            str(tmp_path / "x.csv"),
        ],
    )
    assert "unknown joint" in err and not (tmp_path / "x.csv").exists()
    err = _error(
        capsys, ["identify", robot, str(tmp_path / "missing.csv"), "-o", str(tmp_path / "m.toml")]
    )
    assert "file not found" in err
