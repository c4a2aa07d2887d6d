"""CLI: ``torquemap estimate`` on the simulated bench, the output format, and one-line errors."""

from __future__ import annotations

import contextlib
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from conftest import WHOLE_MODEL

from torquemap import progress
from torquemap.cli.main import main
from torquemap.io import read_table, write_table
from torquemap.sim.score import common_mask, force_error


@pytest.fixture(scope="module")
def identified(scara_passes: Path) -> Path:
    """The pass-method model of the bench (shared by the session)."""
    return scara_passes


def _run(model: Path, log: Path, out: Path, *extra: str) -> dict[str, np.ndarray]:
    assert main(["estimate", str(model), str(log), "-o", str(out), *extra]) == 0
    return read_table(out)


@dataclass(frozen=True)
class Answered:
    """A run of ``estimate``: the table it wrote and what it printed to stderr."""

    table: dict[str, np.ndarray]
    err: str


@pytest.fixture(scope="module")
def whole_circle(
    scara_bench: Path, scara_model: Path, tmp_path_factory: pytest.TempPathFactory
) -> Answered:
    """``torquemap estimate`` of the whole-fit model on the bench's circle, every option at its
    default, run once for the five tests that read it (each ran it alike before: the same
    command, so the same table and messages). Its tests carry ``WHOLE_MODEL``, so one worker
    runs them and this once."""
    out = tmp_path_factory.mktemp("whole_circle") / "forces.csv"
    err = io.StringIO()
    with pytest.MonkeyPatch.context() as patch, contextlib.redirect_stderr(err):
        patch.setattr(progress, "SHOW_AFTER", math.inf)  # as every test has it (conftest)
        table = _run(scara_model, scara_bench / "circle.csv", out)
    return Answered(table, err.getvalue())


def test_methods_rank_as_the_paper_says(
    scara_bench: Path, identified: Path, tmp_path: Path
) -> None:
    truth = read_table(scara_bench / "truth.csv")
    true_force = np.c_[truth["fx"], truth["fy"]]
    circle = scara_bench / "circle.csv"
    outs = {
        m: _run(identified, circle, tmp_path / f"{m}.csv", "--method", m)
        for m in ("raw", "lowpass", "paper", "model")
    }
    outs["oracle"] = _run(scara_bench / "truth.toml", circle, tmp_path / "oracle.parquet")
    mask = common_mask([o["flag"].astype(np.int64) for o in outs.values()])
    assert mask.mean() > 0.8
    err = {
        m: force_error(np.c_[o["fx"], o["fy"]], true_force, mask=mask).rms for m, o in outs.items()
    }
    # the order the paper's processing stages and our model method promise
    assert err["lowpass"] < err["raw"]
    assert err["paper"] < 0.8 * err["lowpass"]
    assert err["model"] < 0.5 * err["paper"]
    # the oracle knows the simulator's inertia, friction and PDTV: what remains are the noise
    # after a 2 Hz low-pass and the coupling and Coriolis torques the model neglects (the paper
    # neglects them too); they stay under 5 % of the paper's 3.5 N
    assert err["oracle"] < 0.05 * 3.5
    assert err["oracle"] < err["model"]
    # issue 3's targets for the default method: under 3 % of 3.5 N, within 1.3x of the oracle
    assert err["model"] < 0.03 * 3.5
    assert err["model"] < 1.3 * err["oracle"]


def test_output_columns_and_figure(scara_bench: Path, identified: Path, tmp_path: Path) -> None:
    fig = tmp_path / "forces.png"
    out = _run(identified, scara_bench / "circle.csv", tmp_path / "f.parquet", "--figure", str(fig))
    assert list(out) == [
        "t",
        "tau_ext_a",
        "tau_ext_b",
        "fx",
        "fy",
        "tau_ext_a_sigma",
        "tau_ext_b_sigma",
        "fx_sigma",
        "fy_sigma",
        "flag",
    ]
    assert fig.stat().st_size > 10_000
    circle = read_table(scara_bench / "circle.csv")
    np.testing.assert_array_equal(out["t"], circle["t"])
    # the suffixes choose the formats: the same table as JSON (a column per key), an SVG figure
    js, svg = tmp_path / "f.json", tmp_path / "forces.svg"
    circle_log = str(scara_bench / "circle.csv")
    assert main(["estimate", str(identified), circle_log, "-o", str(js), "--figure", str(svg)]) == 0
    doc = json.loads(js.read_text())
    assert list(doc) == list(out)
    for name, values in out.items():
        np.testing.assert_array_equal(np.array(doc[name], dtype=float), values)
    assert svg.read_text().lstrip().startswith("<?xml")


def _bad(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    return err


def test_bad_logs_give_one_line_and_no_output(
    scara_bench: Path, identified: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    circle = read_table(scara_bench / "circle.csv")
    n = 3000
    cols = {k: np.array(v[:n]) for k, v in circle.items()}
    cols["i_b"][100] = np.nan
    write_table(tmp_path / "nan.csv", cols)
    out = tmp_path / "out.csv"
    err = _bad(["estimate", str(identified), str(tmp_path / "nan.csv"), "-o", str(out)], capsys)
    assert "nan.csv" in err and "i_b" in err
    assert not out.exists()
    circle_log = str(scara_bench / "circle.csv")
    err = _bad(["estimate", str(identified), circle_log, "-o", str(tmp_path / "f.xlsx")], capsys)
    assert "f.xlsx: unknown table format ('.xlsx')" in err and ".csv, .parquet or .json" in err
    err = _bad(
        ["estimate", str(identified), circle_log, "-o", str(out), "--figure", "f.gif"], capsys
    )
    assert "unknown figure format ('.gif')" in err and not out.exists()

    del cols["q_a"]
    write_table(tmp_path / "missing.csv", cols)
    err = _bad(["estimate", str(identified), str(tmp_path / "missing.csv"), "-o", str(out)], capsys)
    assert "q_a" in err and "missing.csv" in err
    assert not out.exists()

    still = {k: np.array(v[:n]) for k, v in circle.items()}
    still["q_a"] = np.full(n, 0.1)
    still["q_b"] = np.full(n, 1.0)
    write_table(tmp_path / "still.csv", still)
    err = _bad(
        [
            "estimate",
            str(identified),
            str(tmp_path / "still.csv"),
            "-o",
            str(out),
            "--method",
            "paper",
        ],
        capsys,
    )
    assert "monotonic pass" in err and "still.csv" in err
    assert not out.exists()

    short = {k: np.array(v[:5]) for k, v in circle.items()}
    write_table(tmp_path / "short.csv", short)
    err = _bad(["estimate", str(identified), str(tmp_path / "short.csv"), "-o", str(out)], capsys)
    assert "short.csv" in err
    assert not out.exists()


def test_unknown_method_is_refused(identified: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["estimate", str(identified), "x.csv", "-o", "y.csv", "--method", "kalman"])
    assert exc.value.code == 2
    assert "kalman" in capsys.readouterr().err


@WHOLE_MODEL
def test_reversal_band_option(
    scara_bench: Path,
    identified: Path,
    scara_model: Path,
    whole_circle: Answered,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    circle = scara_bench / "circle.csv"
    default = _run(identified, circle, tmp_path / "d.csv")
    wide = _run(identified, circle, tmp_path / "w.csv", "--reversal-band", "5")
    low = lambda o: (o["flag"].astype(np.int64) & 2) > 0  # noqa: E731
    # pass identification: a wider band only adds undetermined samples (the slowest pass
    # here is 0.5 rad/s)
    assert low(default).mean() < low(wide).mean()
    assert not (low(default) & ~low(wide)).any()
    # a model identified from whole logs knows friction through zero: slow samples keep an
    # answer (never flagged), but a wider band bridges more of them
    whole = whole_circle.table
    whole_wide = _run(scara_model, circle, tmp_path / "ww.csv", "--reversal-band", "5")
    assert not low(whole).any() and not low(whole_wide).any()
    assert np.max(np.abs(whole["fx"] - whole_wide["fx"])) > 1e-3
    out = tmp_path / "bad.csv"
    capsys.readouterr()
    err = _bad(
        ["estimate", str(identified), str(circle), "-o", str(out), "--reversal-band", "-1"], capsys
    )
    assert "reversal band" in err
    assert not out.exists()


@WHOLE_MODEL
def test_every_sample_answered_with_honest_sigmas(
    scara_bench: Path, whole_circle: Answered
) -> None:
    # issue 12: forces wherever the robot moves or rests, flag only what cannot be answered,
    # and one standard deviation per sample: the true error within 2 sigma on 90 to 99 %
    truth = read_table(scara_bench / "truth.csv")
    out = whole_circle.table  # whole-log model
    assert {"tau_ext_a_sigma", "tau_ext_b_sigma", "fx_sigma", "fy_sigma"} <= set(out)
    sound = out["flag"] == 0
    assert sound.mean() > 0.95
    err = np.abs(np.c_[out["fx"] - truth["fx"], out["fy"] - truth["fy"]])[sound]
    sigma = np.c_[out["fx_sigma"], out["fy_sigma"]][sound]
    share = float(np.mean(err <= 2 * sigma))
    assert 0.90 <= share <= 0.99


@WHOLE_MODEL
def test_a_log_polled_slower_than_the_sweeps_widens_its_sigmas(
    scara_bench: Path, scara_model: Path, tmp_path: Path
) -> None:
    # the circle read every 4th sample (500 Hz against the sweeps' 2 kHz): the same current
    # noise per sample in a quarter of the band, four times the PSD in the estimate's band.
    # The model's residual PSD (from the sweeps) alone covered 63 % of the force errors
    # within 2 sigma; with the log's own noise level above 20 Hz 98 % (92 % at 2 kHz)
    import tomllib

    assert all(
        "noise_high_psd" in j["uncertainty"]
        for j in tomllib.loads(scara_model.read_text())["identification"]["joints"].values()
    )
    truth = read_table(scara_bench / "truth.csv")
    circle = read_table(scara_bench / "circle.csv")
    write_table(tmp_path / "slow.csv", {k: v[::4] for k, v in circle.items()})
    out = _run(scara_model, tmp_path / "slow.csv", tmp_path / "s.csv")
    sound = out["flag"] == 0
    err = np.abs(np.c_[out["fx"] - truth["fx"][::4], out["fy"] - truth["fy"][::4]])[sound]
    sigma = np.c_[out["fx_sigma"], out["fy_sigma"]][sound]
    assert 0.90 <= float(np.mean(err <= 2 * sigma)) <= 0.99


@WHOLE_MODEL
def test_a_log_that_folds_the_supply_ripple_onto_zero_says_so(
    scara_bench: Path,
    scara_model: Path,
    whole_circle: Answered,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # the bench's drives carry a 300 Hz ripple (a 50 Hz rectifier's) in their currents; read
    # every 20th sample (100 Hz) the ripple lands on 0 Hz and reads as a constant load: 58 % of
    # the spring force, with 26 % of the errors within 2 sigma before identification recorded
    # the line and estimation folded it into the sigma (98.5 % now)
    import tomllib

    joints = tomllib.loads(scara_model.read_text())["identification"]["joints"]
    # the simulator's ripple, as identified: 300 Hz on both joints, and nothing else
    for j in joints.values():
        assert [round(f) for f, _ in j["uncertainty"]["tones"]] == [300]
    truth = read_table(scara_bench / "truth.csv")
    circle = read_table(scara_bench / "circle.csv")
    write_table(tmp_path / "slow.csv", {k: v[::20] for k, v in circle.items()})
    capsys.readouterr()
    out = _run(scara_model, tmp_path / "slow.csv", tmp_path / "s.csv")
    err_text = capsys.readouterr().err
    assert "300 Hz line" in err_text and "folds it to" in err_text
    sound = out["flag"] == 0
    err = np.abs(np.c_[out["fx"] - truth["fx"][::20], out["fy"] - truth["fy"][::20]])[sound]
    sigma = np.c_[out["fx_sigma"], out["fy_sigma"]][sound]
    assert float(np.mean(err <= 2 * sigma)) >= 0.90
    # how wide the tone makes the sigma, exactly: the same log through the model without its
    # tones, and the joint sigmas' difference in quadrature against the closed form of a line
    # of unknown phase folded onto 0 Hz, amplitude / sqrt 2 (the low-pass's gain 1 there), at
    # the joint (the gear ratio). A folded line is a bounded error (|A cos phase| <= A), so
    # the share within 2 sigma has no upper bound to test: one noise realisation read 98.5 %,
    # another 99.1 %
    doc = tomllib.loads(scara_model.read_text())
    for j in doc["identification"]["joints"].values():
        j["uncertainty"]["tones"] = []
    import tomli_w

    bare = tmp_path / "no_tones.toml"
    bare.write_text(tomli_w.dumps(doc))
    plain = _run(bare, tmp_path / "slow.csv", tmp_path / "p.csv")
    assert np.array_equal(plain["fx"], out["fx"], equal_nan=True)  # the answer is the same
    for name, joint in joints.items():
        gear = doc["joints"][name]["gear_ratio"]
        (amplitude,) = [a for _, a in joint["uncertainty"]["tones"]]
        with_tone, without = out[f"tau_ext_{name}_sigma"], plain[f"tau_ext_{name}_sigma"]
        added = np.sqrt(with_tone**2 - without**2)[np.isfinite(with_tone)]
        np.testing.assert_allclose(added, gear * amplitude / np.sqrt(2.0), rtol=1e-6)
    # at the sweeps' own rate the ripple stays far above the band: no such line
    assert "folds it to" not in whole_circle.err


@WHOLE_MODEL
def test_paper_bench_every_sample_within_3_percent(
    scara_bench: Path, whole_circle: Answered
) -> None:
    # every sample scored, standstill at both ends included: under 3 % of the 3.5 N spring
    # (0.1027 N measured, 2.93 %; 0.1212 N before the table between passes far apart was
    # drawn through the passes' knots too, torquemap.between_passes: a strict xfail then)
    truth = read_table(scara_bench / "truth.csv")
    out = whole_circle.table
    assert force_error(np.c_[out["fx"], out["fy"]], np.c_[truth["fx"], truth["fy"]]).rms < 0.105


@WHOLE_MODEL
def test_logs_of_another_robot_too_slow_or_too_sparse(
    scara_bench: Path,
    identified: Path,
    scara_model: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # issue 12, bad input: one line saying what is missing and what to record instead
    circle = read_table(scara_bench / "circle.csv")
    out = tmp_path / "out.csv"
    other = {("q_x" if k == "q_a" else "i_x" if k == "i_a" else k): v for k, v in circle.items()}
    write_table(tmp_path / "other.csv", other)
    err = _bad(["estimate", str(identified), str(tmp_path / "other.csv"), "-o", str(out)], capsys)
    assert "another robot" in err and "(x)" in err and "(a, b)" in err
    assert not out.exists()
    # the arm holding still: a pass-method model knows friction only above its slowest pass
    n = 4000
    still = {k: np.array(v[:n]) for k, v in circle.items()}
    still["q_a"][:] = still["q_a"][0]
    still["q_b"][:] = still["q_b"][0]
    write_table(tmp_path / "still.csv", still)
    err = _bad(["estimate", str(identified), str(tmp_path / "still.csv"), "-o", str(out)], capsys)
    assert "slower than its reversal band" in err and "--friction whole" in err
    assert not out.exists()
    # a model that knows friction through zero answers it
    held = _run(scara_model, tmp_path / "still.csv", out)
    assert np.all(held["flag"] == 0)
    # 40 Hz: fewer than 5 samples per 0.05 s differentiator window, answered with a warning
    sparse = {k: np.array(v[::50]) for k, v in circle.items()}
    write_table(tmp_path / "sparse.csv", sparse)
    capsys.readouterr()
    assert main(["estimate", str(identified), str(tmp_path / "sparse.csv"), "-o", str(out)]) == 0
    err = capsys.readouterr().err
    assert "median sample interval 0.025 s" in err and "record at 80 Hz or more" in err


@WHOLE_MODEL
def test_a_log_cut_in_motion_says_its_ends_are_unsound(
    scara_bench: Path,
    scara_model: Path,
    whole_circle: Answered,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    # the circle cut to 10-18 s, mid-motion: within 0.1 s of its ends the forces were 1.19 N
    # RMS off against 0.044 N on the same samples of the whole circle, with exit 0 and no word
    circle = read_table(scara_bench / "circle.csv")
    truth = read_table(scara_bench / "truth.csv")
    t = np.asarray(circle["t"])
    cut = (t >= 10.0) & (t < 18.0)
    write_table(tmp_path / "cut.csv", {k: np.asarray(v)[cut] for k, v in circle.items()})
    whole = whole_circle.table
    assert "in motion" not in whole_circle.err  # rest to rest
    capsys.readouterr()
    part = _run(scara_model, tmp_path / "cut.csv", tmp_path / "cut_forces.csv")
    err = capsys.readouterr().err
    assert "the log starts and ends in motion" in err and "record from rest to rest" in err
    # the warning is earned: against the simulator's truth, the cut's ends are far worse than
    # the same samples estimated inside the whole circle
    tc = t[cut]
    ends = np.minimum(tc - tc[0], tc[-1] - tc) < 0.1
    true = np.c_[truth["fx"], truth["fy"]][cut][ends]
    off_cut = force_error(np.c_[part["fx"], part["fy"]][ends], true).rms
    off_whole = force_error(np.c_[whole["fx"], whole["fy"]][cut][ends], true).rms
    assert off_cut > 5 * off_whole
