"""CLI: ``torquemap estimate`` of large logs in blocks, and of growing logs (``--follow``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torquemap.cli import cmd_estimate
from torquemap.cli.main import main
from torquemap.io import read_table


@pytest.fixture(scope="module")
def identified(scara_passes: Path) -> Path:
    """The pass-method model of the bench (shared by the session)."""
    return scara_passes


@pytest.fixture(scope="module")
def whole(scara_bench: Path, identified: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("whole") / "forces.csv"
    assert main(["estimate", str(identified), str(scara_bench / "circle.csv"), "-o", str(out)]) == 0
    return out


def test_a_large_log_is_estimated_in_blocks_with_the_same_numbers(
    scara_bench: Path,
    identified: Path,
    whole: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from torquemap import io as tio

    monkeypatch.setattr(cmd_estimate, "STREAM_BYTES", 0)  # every CSV log counts as large
    real = tio.iter_log_chunks
    monkeypatch.setattr(tio, "iter_log_chunks", lambda p, r: real(p, r, rows=5000))
    import torquemap.stream as stream

    real_to_file = stream.estimate_to_file
    monkeypatch.setattr(
        stream, "estimate_to_file", lambda *a, **k: real_to_file(*a, **{**k, "rows": 9000})
    )
    capsys.readouterr()
    out = tmp_path / "blocks.csv"
    assert main(["estimate", str(identified), str(scara_bench / "circle.csv"), "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    a, b = read_table(whole), read_table(out)
    assert list(a) == list(b)
    np.testing.assert_array_equal(a["flag"], b["flag"])
    for name in a:
        # an all-NaN column (no sigma without the identification's covariance) reads as nulls
        x, y = np.array(a[name], dtype=float), np.array(b[name], dtype=float)
        f = np.isfinite(x)
        np.testing.assert_array_equal(f, np.isfinite(y))
        # rounding only (tests/test_stream.py)
        np.testing.assert_allclose(y[f], x[f], rtol=0, atol=1e-7)
    assert printed.startswith(f"model: {int((a['flag'] == 0).sum())}/{a['t'].size} samples sound")


def test_follow_writes_every_row_of_a_log_that_stopped_growing(
    scara_bench: Path, identified: Path, whole: Path, tmp_path: Path
) -> None:
    out = tmp_path / "followed.csv"
    argv = ["estimate", str(identified), str(scara_bench / "circle.csv"), "-o", str(out)]
    assert main([*argv, "--follow", "--follow-timeout", "0.1"]) == 0
    a, b = read_table(whole), read_table(out)
    np.testing.assert_array_equal(a["t"], b["t"])
    np.testing.assert_array_equal(a["flag"], b["flag"])
    f = np.isfinite(a["fx"])
    # streamed: the low-pass's tail cut at 1e-6 of its input (the force error is ~0.05 N)
    np.testing.assert_allclose(b["fx"][f], a["fx"][f], rtol=0, atol=1e-5)


def test_follow_refuses_what_needs_the_whole_log(
    scara_bench: Path, identified: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["estimate", str(identified), str(scara_bench / "circle.csv"), "--follow"]
    assert main([*argv, "-o", str(tmp_path / "f.csv"), "--method", "paper"]) == 2
    assert "--follow estimates with the model, lowpass or raw method" in capsys.readouterr().err
    assert main([*argv, "-o", str(tmp_path / "f.json")]) == 2
    assert not list(tmp_path.iterdir())


def test_a_large_log_with_spaces_in_its_header_gets_the_small_logs_hint(
    scara_bench: Path,
    identified: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    text = (scara_bench / "circle.csv").read_text()
    head, rest = text.split("\n", 1)
    log = tmp_path / "spaced.csv"
    log.write_text(head.replace(",", " , ") + "\n" + rest)  # 't , q_1 , ...'
    out = tmp_path / "f.csv"
    argv = ["estimate", str(identified), str(log), "-o", str(out)]
    capsys.readouterr()
    assert main(argv) == 2
    small = capsys.readouterr().err
    monkeypatch.setattr(cmd_estimate, "STREAM_BYTES", 0)  # every CSV log counts as large
    assert main(argv) == 2
    large = capsys.readouterr().err
    # before: the chunked reader stripped the spaces, then failed with "cannot parse table"
    assert large == small
    assert len(large.splitlines()) == 1 and str(log) in large
    assert "missing column 't' (the file has 't ': names are exact" in large
    assert not out.exists()
