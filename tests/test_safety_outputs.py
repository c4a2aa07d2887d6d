"""Issue 15 items 1 and 6: outputs never destroy inputs, are written all or none, get the umask.

Every refusal is checked through the CLI (one line on stderr, exit 2, nothing written) or the
library call that writes; inputs that are refused before any work need not be valid files.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import main
from torquemap.errors import InputError
from torquemap.io import (
    TEMPORARY_PATTERN,
    atomic_output,
    remove_stale_temporaries,
    write_all,
    write_table,
    write_toml,
)
from torquemap.linearize.export import write_outputs
from torquemap.linearize.motor import motor_spec
from torquemap.linearize.tables import build_tables


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """Exit status and stderr of the CLI (argparse's SystemExit included)."""
    try:
        status = main(argv)
    except SystemExit as exc:
        status = int(exc.code or 0)
    err = capsys.readouterr().err
    return status, err


def one_line_error(status: int, err: str, match: str) -> None:
    assert status == 2
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert match in err, err


@pytest.fixture
def files(tmp_path: Path) -> dict[str, Path]:
    """Placeholder inputs (their contents are never read: refusals come first)."""
    out = {}
    for name in ("robot.toml", "model.toml", "motor.toml", "log.csv", "data.csv", "t.npz"):
        out[name] = tmp_path / name
        out[name].write_text(f"original {name}\n")
    return out


def _same_file_cases(f: dict[str, Path]) -> list[list[str]]:
    d = f["log.csv"].parent
    return [
        ["identify", str(f["robot.toml"]), str(f["log.csv"]), "-o", str(f["robot.toml"])],
        ["estimate", str(f["model.toml"]), str(f["log.csv"]), "-o", str(f["log.csv"])],
        ["estimate", str(f["model.toml"]), str(f["log.csv"]), "-o", str(d / "x" / ".." / "log.csv")],
        ["linearize", "build", str(f["motor.toml"]), str(f["data.csv"]), "-o", str(d / "o.npz"),
         "--c-header", str(d / "o.h"), "--bin", str(d)],  # phase_k.bin in d: not an input: ok
        ["linearize", "evaluate", str(f["motor.toml"]), str(f["data.csv"]), "-o", str(f["t.npz"])],
        ["report", str(f["model.toml"]), str(f["log.csv"]), "-o", str(f["log.csv"])],
        ["import", "rosbag", str(f["log.csv"]), "--robot", str(f["robot.toml"]), "-o",
         str(f["log.csv"])],
        ["pdtv-map", str(f["model.toml"]), "--joint", "a", "--bins", "8", "-o",
         str(f["model.toml"]), "--format", "csv"],
        ["linearize", "collect", str(f["motor.toml"]), "-o", str(f["motor.toml"]), "--sim", "vr"],
    ]  # fmt: skip


@pytest.mark.parametrize("case", range(9))
def test_output_that_is_an_input_or_misnamed_is_refused(
    case: int, files: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    argv = _same_file_cases(files)[case]
    before = {name: p.read_text() for name, p in files.items()}
    status, err = run(argv, capsys)
    assert status == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    if case == 3:  # build's outputs are not inputs: refused later, for the placeholder motor
        assert "not valid TOML" in err
    else:
        assert (
            "is also an input" in err
            or "does not match what is written" in err
            or "the suffix chooses it" in err
        ), err
    assert {name: p.read_text() for name, p in files.items()} == before


@pytest.mark.parametrize("kind", ["symlink", "hardlink"])
def test_links_to_an_input_are_refused(
    kind: str, files: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    link = files["log.csv"].parent / "forces.csv"
    if kind == "symlink":
        link.symlink_to(files["log.csv"])
    else:
        os.link(files["log.csv"], link)
    status, err = run(
        ["estimate", str(files["model.toml"]), str(files["log.csv"]), "-o", str(link)], capsys
    )
    one_line_error(status, err, "is also an input")
    assert files["log.csv"].read_text() == "original log.csv\n"


@pytest.mark.parametrize(
    ("argv_tail", "suffix"),
    [
        (["identify", "R", "L", "-o", "model.csv"], ".toml"),
        (["estimate", "M", "L", "-o", "forces.toml"], ".csv or .parquet"),
        (["estimate", "M", "L", "-o", "f.csv", "--figure", "fig.csv"], ".png"),
        (["pdtv-map", "M", "--joint", "a", "--bins", "8", "-o", "m.csv", "--format", "c-header"],
         ".h"),
        (["pdtv-map", "M", "--joint", "a", "--bins", "8", "-o", "m.h", "--format", "json"],
         ".json"),
        (["linearize", "build", "MO", "D", "-o", "t.h"], ".npz"),
        (["linearize", "build", "MO", "D", "-o", "t.npz", "--c-header", "t.npz2"], ".h"),
        (["linearize", "evaluate", "MO", "D", "-o", "r.csv"], ".json"),
        (["report", "M", "L", "-o", "r.pdf"], ".html"),
        (["spectrum", "M", "L", "--joint", "a", "-o", "s.txt"], ".png"),
    ],
)  # fmt: skip
def test_suffix_must_match_what_is_written(
    argv_tail: list[str],
    suffix: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    status, err = run(argv_tail, capsys)
    if "--format" in argv_tail:  # the suffix names one format, --format another
        one_line_error(status, err, "contradicts the suffix")
    elif "the suffix chooses it" in err:  # the command's own suffix check ran first
        one_line_error(status, err, "the suffix chooses it")
    else:
        one_line_error(status, err, f"does not match what is written ({suffix}")
    assert list(tmp_path.iterdir()) == []


def test_read_only_output_is_refused(
    files: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    out = files["log.csv"].parent / "forces.csv"
    out.write_text("keep me\n")
    out.chmod(0o444)
    status, err = run(
        ["estimate", str(files["model.toml"]), str(files["log.csv"]), "-o", str(out)], capsys
    )
    one_line_error(status, err, "read-only")
    assert out.read_text() == "keep me\n"
    with pytest.raises(InputError, match="read-only"):  # the library refuses it too
        write_table(out, {"a": [1.0]})
    out.chmod(0o644)
    write_table(out, {"a": [1.0]})  # a writable existing output is simply replaced
    assert out.read_text() == "a\n1\n"


def test_figure_into_a_missing_folder_fails_before_anything_is_written(
    files: dict[str, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    d = files["log.csv"].parent
    argv = ["estimate", str(files["model.toml"]), str(files["log.csv"]), "-o", str(d / "f.csv")]
    status, err = run([*argv, "--figure", str(d / "missing" / "fig.png")], capsys)
    one_line_error(status, err, "output folder does not exist")
    assert not (d / "f.csv").exists()


@pytest.mark.parametrize("mask", [0o022, 0o077, 0o002])
def test_outputs_get_the_umask(mask: int, tmp_path: Path) -> None:
    old = os.umask(mask)
    try:
        write_table(tmp_path / "a.csv", {"x": [1.0]})
        write_toml(tmp_path / "b.toml", {"k": 1})
    finally:
        os.umask(old)
    for name in ("a.csv", "b.toml"):
        assert (tmp_path / name).stat().st_mode & 0o777 == 0o666 & ~mask


def test_multi_file_write_is_all_or_none(tmp_path: Path) -> None:
    (tmp_path / "a.txt").write_text("old a")

    def disk_full(tmp: Path) -> None:
        tmp.write_bytes(b"partial")
        raise OSError(28, "No space left on device")

    with pytest.raises(OSError, match="No space"):
        write_all(
            {
                tmp_path / "a.txt": lambda t: t.write_text("new a"),
                tmp_path / "b.txt": disk_full,
            }
        )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]  # no temporaries left
    assert (tmp_path / "a.txt").read_text() == "old a"


def test_build_outputs_all_or_none_on_a_full_disk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    spec = motor_spec("m", phases=3, positions_per_cycle=48, equilibrium_positions=(8, 24, 40))
    p, w = np.meshgrid(np.arange(48), np.arange(0, 256, 8), indexing="ij")
    tables = build_tables(spec, p.ravel(), w.ravel(), ((w / 255.0) ** 2).ravel())
    import torquemap.linearize.export as export

    def full(image: bytes, *, record_size: int = 16) -> str:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(export, "intel_hex", full)
    with pytest.raises(OSError):
        write_outputs(
            tables,
            npz=tmp_path / "t.npz",
            bin_dir=tmp_path / "new" / "bin",
            hex_dir=tmp_path / "new" / "hex",
            c_header_path=tmp_path / "t.h",
        )
    assert list(tmp_path.iterdir()) == []  # no file, no temporary, no folder made for it


def test_stale_temporaries_of_a_killed_run_are_removed(tmp_path: Path) -> None:
    # a real kill -9 in the middle of a write leaves its temporary behind ...
    code = (
        "import os, signal, sys\n"
        "from torquemap.io import atomic_output\n"
        "with atomic_output(sys.argv[1]) as tmp:\n"
        "    tmp.write_bytes(b'x' * 100000)\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "big.csv")], env=env)
    assert done.returncode == -9
    left = [p.name for p in tmp_path.iterdir()]
    assert len(left) == 1 and TEMPORARY_PATTERN.match(left[0]) and left[0].startswith(".big.csv")
    # ... a live process's temporary and unrelated files are kept
    (tmp_path / f".other.csv.tqm{os.getpid()}-abc.tmp").write_text("in progress")
    (tmp_path / ".mine.tmp").write_text("not ours")
    # ... and the next write into the folder removes the stale one
    write_table(tmp_path / "next.csv", {"x": [1.0]})
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [".mine.tmp", f".other.csv.tqm{os.getpid()}-abc.tmp", "next.csv"]
    )
    assert remove_stale_temporaries(tmp_path) == []


def test_a_killed_rig_simulations_collection_files_are_stale_temporaries(tmp_path: Path) -> None:
    # `simulate rig` collects into .data.csv.tqm<pid>-<random>.tmp.csv, beside which the
    # collection keeps its record and lock; killed (kill -9), all three stay behind, and the
    # next write into the folder removed the partial data but not the record and lock before
    from torquemap.linearize.resume import lock_path, record_path

    proc = subprocess.Popen(["true"])
    proc.wait()
    partial = tmp_path / f".data.csv.tqm{proc.pid}-k9x_1.tmp.csv"
    partial.write_text("position,pulse_width,torque\n0,0,0.1\n")
    record_path(partial).write_text("{}")
    lock_path(partial).write_text(f"{proc.pid}\n")
    removed = remove_stale_temporaries(tmp_path)
    assert sorted(p.name for p in removed) == sorted(
        [partial.name, record_path(partial).name, lock_path(partial).name]
    )
    assert list(tmp_path.iterdir()) == []


def test_temporaries_are_removed_on_failure(tmp_path: Path) -> None:
    with pytest.raises(RuntimeError), atomic_output(tmp_path / "x.csv") as tmp:
        tmp.write_text("partial")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
