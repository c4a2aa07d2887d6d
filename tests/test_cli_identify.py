"""CLI: identify, spectrum, pdtv-map end to end, and one-line errors with exit 2."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_identify import ROBOT, simulate

from torquemap.cli.main import main
from torquemap.io import read_table, write_table, write_toml
from torquemap.model import load_model

# one worker runs the module, so its module fixture (a sweep and its identification) is built
# once (stop 43: built on both workers, 0.85 + 0.81 s)
pytestmark = pytest.mark.xdist_group("cli_identify")


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
    "fmt,name",
    [
        ("csv", "map.csv"),
        ("json", "map.json"),
        ("c-header", "map.h"),
        ("c-header", "map.inc"),  # --format where the suffix says nothing
        (None, "cog.csv"),
        (None, "cog.parquet"),
        (None, "cog.json"),
        (None, "cog.h"),
    ],
)
def test_pdtv_map_formats(bench: Path, fmt: str | None, name: str) -> None:
    out = bench / name
    argv = ["pdtv-map", str(bench / "model.toml"), "--joint", "m", "--bins", "64", "-o", str(out)]
    assert main(argv + (["--format", fmt] if fmt else [])) == 0
    kind = fmt or {".json": "json", ".h": "c-header"}.get(out.suffix, "table")
    if kind == "json":
        doc = json.loads(out.read_text())
        assert doc["bins"] == 64 and len(doc["current"]) == 64
    elif kind == "c-header":
        assert "#define PDTV_M_BINS 64" in out.read_text()
    else:
        cols = read_table(out)
        assert list(cols) == ["motor_angle", "torque", "current"] and cols["torque"].size == 64


def test_pdtv_map_of_a_joint_without_lines_warns(
    bench: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a robot file instead of the model: once an all-zero map with nothing said
    out = tmp_path / "zero.csv"
    argv = ["pdtv-map", str(bench / "robot.toml"), "--joint", "m", "--bins", "8", "-o", str(out)]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "robot.toml: joint 'm' has no PDTV lines, the map is all zeros" in err
    assert not read_table(out)["torque"].any()


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
    pdtv_map = ["pdtv-map", str(bench / "model.toml"), "--joint", "m", "--bins", "8", "-o"]
    err = _error(capsys, [*pdtv_map, str(tmp_path / "x.txt")])
    assert "x.txt: unknown map format ('.txt')" in err and ".csv, .parquet, .json or .h" in err
    err = _error(capsys, [*pdtv_map, str(tmp_path / "x.csv"), "--format", "json"])
    assert "--format json contradicts the suffix" in err
    err = _error(capsys, ["identify", robot, str(bench / "sweep.csv"), "-o", "model.json"])
    assert "unknown model format ('.json')" in err and "use .toml" in err
    spectrum = ["spectrum", str(bench / "model.toml"), str(bench / "sweep.csv"), "--joint", "m"]
    err = _error(capsys, [*spectrum, "-o", str(tmp_path / "s.jpeg")])
    assert "unknown figure format ('.jpeg')" in err and ".png, .svg or .pdf" in err
    assert not list(tmp_path.glob("x.*"))
    err = _error(
        capsys, ["identify", robot, str(tmp_path / "missing.csv"), "-o", str(tmp_path / "m.toml")]
    )
    assert "file not found" in err
