"""Blocks estimated in threads (``--threads``): the same answers, bytes and messages as one."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from conftest import Ran

import torquemap.stream as stream
from torquemap.cli import cmd_estimate
from torquemap.cli.main import main
from torquemap.errors import InputError
from torquemap.estimate import ForceEstimate, ForceEstimator
from torquemap.io import Log, LogChunk, iter_log_chunks, read_log
from torquemap.model import Model, load_model, model_from_dict
from torquemap.stream import (
    MAX_DEFAULT_THREADS,
    _concatenate,
    default_threads,
    estimate_in_chunks,
    estimate_to_file,
)


@pytest.fixture(scope="module")
def model(scara_identified: Ran) -> Model:
    return load_model(scara_identified.folder / "bench" / "model.toml")


@pytest.fixture(scope="module")
def circle(scara_bench: Path) -> Path:
    return scara_bench / "circle.csv"


def _pieces(log: Log, rows: int) -> list[LogChunk]:
    out = []
    for a in range(0, log.t.size, rows):
        b = a + rows
        out.append(
            LogChunk(t=log.t[a:b], q=log.q[a:b], motor_torque=log.motor_torque[a:b], first_row=a)
        )
    return out


def _irregular(model: Model, circle: Path) -> Log:
    """The circle with jittered stamps (up to 3 % of a step), a 10 s gap (longer than a
    block's margin) and a 0.3 s one (shorter)."""
    log = read_log(circle, model.robot)
    h = float(np.median(np.diff(log.t)))
    rng = np.random.default_rng(7)
    t = log.t + rng.uniform(-0.03, 0.03, log.t.size) * h
    t[20_000:] += 10.0
    t[45_000:] += 0.3
    return Log(t=t, q=log.q, motor_torque=log.motor_torque, joint_names=log.joint_names)


def _same_files(a: Path, b: Path) -> None:
    assert a.read_bytes() == b.read_bytes()


# Each case runs the 31 s circle three times (1, 2 and 3 threads), each block with 8.2 s of
# margin on either side, so the small blocks cost most. The block layouts (chunks of the log
# against rows per block) are each written to Parquet, whose row groups are the appends, so its
# bytes depend on how the answers are grouped as well as on their values: rows not a multiple
# of the chunk (8 blocks), 16 blocks of a power of two (the most in flight) and 3 blocks
# barely fed by their chunks. A CSV's bytes are its rows alone, which the equal Parquet files
# already hold equal, so one layout covers its writer: the 8 blocks (the CSV cases of the two
# other layouts, dropped, repeated it at 6 runs of the circle).
@pytest.mark.parametrize(
    ("suffix", "chunk", "rows"),
    [
        (".parquet", 5000, 8000),
        (".parquet", 3000, 4096),
        (".parquet", 20_000, 30_000),
        (".csv", 5000, 8000),
    ],
)
def test_threads_write_the_same_table_as_one(
    model: Model, circle: Path, tmp_path: Path, chunk: int, rows: int, suffix: str
) -> None:
    summaries = {}
    for threads in (1, 2, 3):
        out = tmp_path / f"t{threads}{suffix}"
        chunks = iter_log_chunks(circle, model.robot, rows=chunk)
        summaries[threads] = estimate_to_file(
            model, chunks, out, rows=rows, threads=threads, path=str(circle)
        )
    for threads in (2, 3):
        _same_files(tmp_path / f"t1{suffix}", tmp_path / f"t{threads}{suffix}")
        a, b = summaries[1], summaries[threads]
        assert (a.samples, a.sound, a.blocks, a.warnings, a.stride, a.stopped) == (
            b.samples,
            b.sound,
            b.blocks,
            b.warnings,
            b.stride,
            b.stopped,
        )
        np.testing.assert_array_equal(a.tau_ext_mean, b.tau_ext_mean)
        assert a.force_median == b.force_median
    assert summaries[1].blocks >= 62_000 // rows  # several blocks, so several in flight


def test_an_irregular_log_with_gaps_is_answered_alike(
    model: Model, circle: Path, tmp_path: Path
) -> None:
    log = _irregular(model, circle)
    summaries = {}
    for threads in (1, 2):
        out = tmp_path / f"t{threads}.parquet"
        summaries[threads] = estimate_to_file(
            model, _pieces(log, 4000), out, rows=6000, threads=threads
        )
    _same_files(tmp_path / "t1.parquet", tmp_path / "t2.parquet")
    assert summaries[1].warnings == summaries[2].warnings
    assert any("gaps in time" in w for w in summaries[1].warnings)
    # and through estimate_in_chunks: the same rows, whatever the parts they come in
    got = {
        threads: _concatenate(
            list(estimate_in_chunks(model, _pieces(log, 4000), rows=6000, threads=threads))
        )
        for threads in (1, 2)
    }
    for name in ("t", "tau_ext", "tau_ext_sigma", "force", "force_sigma", "flag", "velocity"):
        np.testing.assert_array_equal(getattr(got[1], name), getattr(got[2], name))
    assert got[1].warnings == got[2].warnings


def _one_motor() -> Model:
    return model_from_dict(
        {
            "robot": {"kinematics": "none"},
            "joints": {"m": {"gear_ratio": 10, "torque_constant": 0.5}},
        }
    )


def test_a_block_with_nothing_to_estimate_is_flagged_in_its_place(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # 5 samples of log alone between two 10 s gaps: its block holds no stretch long enough, so
    # it is answered NaN and flagged (a refusal in a thread, judged in the blocks' order)
    m = _one_motor()
    t = np.r_[np.arange(0.0, 6.0, 1e-3), np.arange(16.0, 16.004, 1e-3), np.arange(26.0, 32.0, 1e-3)]
    rng = np.random.default_rng(1)
    q = np.sin(t)[:, None]
    i = (0.2 + 0.01 * np.sin(3 * t) + rng.normal(0.0, 1e-3, t.size))[:, None]
    calls = []
    real = stream._gap_estimate

    def counted(*args: object) -> ForceEstimate:
        calls.append(1)
        return real(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(stream, "_gap_estimate", counted)
    got: dict[int, ForceEstimate] = {}
    warnings = {}
    for threads in (1, 2):
        est = ForceEstimator(m, hop=0.0, threads=threads)
        # the first side answered when the fragment arrives; the fragment alone when the
        # far side's first 0.7 s do
        cuts = np.r_[0, 3000, 6000, 6005, np.arange(6705, t.size, 700), t.size]
        parts = [est.update(t[a:b], q[a:b], i[a:b]) for a, b in itertools.pairwise(cuts)]
        parts.append(est.finish())
        got[threads] = _concatenate([p for p in parts if p.t.size])
        warnings[threads] = est.warnings
    assert len(calls) == 2  # once per run
    np.testing.assert_array_equal(got[1].t, t)
    for name in ("t", "tau_ext", "tau_ext_sigma", "flag", "velocity"):
        np.testing.assert_array_equal(getattr(got[1], name), getattr(got[2], name))
    assert warnings[1] == warnings[2]
    lone = (t >= 16.0) & (t < 17.0)
    assert np.all(got[2].flag[lone] & 8) and np.all(np.isnan(got[2].tau_ext[lone]))


def test_a_log_too_short_is_refused_as_by_one_thread() -> None:
    m = _one_motor()
    t = np.arange(0.0, 0.01, 1e-3)
    messages = []
    for threads in (1, 2):
        est = ForceEstimator(m, threads=threads)
        est.update(t, np.sin(t)[:, None], np.full((t.size, 1), 0.2))
        with pytest.raises(InputError) as caught:
            est.finish()
        messages.append(str(caught.value))
    assert messages[0] == messages[1]


@pytest.mark.parametrize("threads", [0, -1, 1.5, True])
def test_threads_must_be_a_whole_number_from_one(threads: object) -> None:
    with pytest.raises(InputError, match="threads must be a whole number >= 1"):
        ForceEstimator(_one_motor(), threads=threads)  # type: ignore[arg-type]


def test_the_default_is_the_cores_at_most_two() -> None:
    import os

    n = default_threads()
    assert 1 <= n <= MAX_DEFAULT_THREADS == 2
    assert n == min(len(os.sched_getaffinity(0)), 2)


def test_the_option_through_the_command_line(
    scara_identified: Ran,
    circle: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from torquemap import io as tio

    monkeypatch.setattr(cmd_estimate, "STREAM_BYTES", 0)  # every CSV log counts as large
    real = tio.iter_log_chunks
    monkeypatch.setattr(tio, "iter_log_chunks", lambda p, r: real(p, r, rows=5000))
    seen: list[int] = []
    real_to_file = stream.estimate_to_file

    def to_file(*a: object, **k: object) -> object:
        seen.append(int(k["threads"]))  # type: ignore[call-overload]
        return real_to_file(*a, **{**k, "rows": 9000})  # type: ignore[arg-type]

    monkeypatch.setattr(stream, "estimate_to_file", to_file)
    model = scara_identified.folder / "bench" / "model.toml"
    printed = {}
    for threads in ("1", "2", None):
        out = tmp_path / f"t{threads}.parquet"
        extra = [] if threads is None else ["--threads", threads]
        capsys.readouterr()
        assert main(["estimate", str(model), str(circle), "-o", str(out), *extra]) == 0
        got = capsys.readouterr()
        printed[threads] = (got.out.replace(str(out), "OUT"), got.err)
    assert seen == [1, 2, default_threads()]
    _same_files(tmp_path / "t1.parquet", tmp_path / "t2.parquet")
    _same_files(tmp_path / "t1.parquet", tmp_path / "tNone.parquet")
    assert printed["1"] == printed["2"] == printed[None]
    with pytest.raises(SystemExit) as stop:
        main(["estimate", str(model), str(circle), "-o", str(tmp_path / "x.csv"), "--threads", "0"])
    assert stop.value.code == 2
    assert "--threads: must be in 1 .. 64, got 0" in capsys.readouterr().err
