"""The ``linearize build/evaluate/figures`` CLI: files, one-line errors, no partial outputs."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from torquemap.cli.main import build_parser, main
from torquemap.errors import InputError
from torquemap.io import read_table, write_table, write_toml
from torquemap.linearize.export import load_tables

N = 48


def write_case(tmp_path: Path, *, torque_scale: tuple[float, float, float] = (1, 1, 1)) -> None:
    """motor.toml and data.csv: tau = g(p) (pw / 255)^2 with phase gains, noise free."""
    write_toml(
        tmp_path / "motor.toml",
        {
            "motor": {
                "name": "synthetic",
                "phases": 3,
                "positions_per_cycle": N,
                "equilibrium_positions": [8, 24, 40],
                "ramping": "wide",
            }
        },
    )
    p, w = np.meshgrid(np.arange(N), np.arange(0, 256, 5), indexing="ij")
    lead = (p * 3) // N  # the phase that owns the position
    g = (2.0 + np.cos(2 * np.pi * 3 * p / N)) * np.asarray(torque_scale)[lead]
    write_table(
        tmp_path / "data.csv",
        {"position": p.ravel(), "pulse_width": w.ravel(), "torque": (g * (w / 255) ** 2).ravel()},
    )


def test_build_evaluate_and_figures(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_case(tmp_path)
    d = str(tmp_path)
    status = main(
        [
            "linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz",
            "--bin", f"{d}/bin", "--hex", f"{d}/hex", "--c-header", f"{d}/t.h",
        ]
    )  # fmt: skip
    assert status == 0
    out = capsys.readouterr().out
    assert "largest position-independent torque 1 N m" in out  # min of g(p) at full scale
    tables = load_tables(tmp_path / "t.npz")
    assert tables.phases.shape == (3, N, 256)
    assert (tmp_path / "bin" / "phase_2.bin").stat().st_size == N * 256
    assert (tmp_path / "hex" / "phase_3.hex").read_text().endswith(":00000001FF\n")
    # a verification run written in the test: the torque the tables ask for, 5 % ripple
    p, c = np.meshgrid(np.arange(N), np.arange(128), indexing="ij")
    ripple = 1 + 0.05 * np.cos(2 * np.pi * p / N)
    write_table(
        tmp_path / "v.csv",
        {"position": p.ravel(), "command": c.ravel(), "torque": (c * 0.01 * ripple).ravel()},
    )
    status = main(
        ["linearize", "evaluate", f"{d}/motor.toml", f"{d}/v.csv", "--tables", f"{d}/t.npz",
         "-o", f"{d}/r.json"]
    )  # fmt: skip
    assert status == 0
    report = json.loads((tmp_path / "r.json").read_text())
    expected = 0.05 * np.mean(np.abs(np.cos(2 * np.pi * np.arange(N) / N)))
    assert report["apmd"] == pytest.approx(expected, rel=1e-9)  # closed form, as in test_metrics
    assert main(["linearize", "evaluate", f"{d}/motor.toml", f"{d}/data.csv"]) == 0
    assert "overall APMD" in capsys.readouterr().out
    status = main(
        ["linearize", "figures", f"{d}/motor.toml", f"{d}/data.csv", "--tables", f"{d}/t.npz",
         "--verification", f"{d}/v.csv", "-o", f"{d}/figs"]
    )  # fmt: skip
    assert status == 0
    assert {f.name for f in (tmp_path / "figs").iterdir()} >= {"pmd.png", "tables.png"}


def test_log_paper_and_wide_options(tmp_path: Path) -> None:
    write_case(tmp_path)
    d = str(tmp_path)
    args = ["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz"]
    assert (
        main([*args, "--command-scaling", "log", "--method", "paper", "--actuation-bits", "12"])
        == 0
    )
    tables = load_tables(tmp_path / "t.npz")
    assert (tables.command_scaling, tables.method, tables.actuation_max) == ("log", "paper", 4095)


def test_collect_is_registered() -> None:
    args = build_parser().parse_args(
        ["linearize", "collect", "m.toml", "-o", "d.csv", "--sim", "vr"]
    )
    assert args.handler.__module__ == "torquemap.cli.cmd_linearize_collect"


def bad(tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    status = main(argv)
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "t.npz").exists() and not (tmp_path / "bin").exists()
    return err


@pytest.mark.parametrize(
    ("column", "values", "message"),
    [
        ("position", lambda p: np.where(p == 3, N, p), "position 48 at data row"),
        ("pulse_width", lambda w: np.where(w == 255, 256, w), "pulse_width 256 at data row"),
        ("pulse_width", lambda w: np.where(w == 5, -5, w), "pulse_width -5 at data row"),
        ("torque", lambda t: np.where(t > 2.5, np.nan, t), "column 'torque' holds NaN"),
        ("torque", None, "missing column 'torque'"),
    ],
)
def test_bad_data(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], column, values, message
) -> None:  # type: ignore[no-untyped-def]
    write_case(tmp_path)
    from torquemap.io import read_table

    cols = read_table(tmp_path / "data.csv")
    if values is None:
        del cols[column]
    else:
        cols[column] = values(cols[column])
    write_table(tmp_path / "data.csv", cols)
    d = str(tmp_path)
    err = bad(
        tmp_path,
        capsys,
        [
            "linearize",
            "build",
            f"{d}/motor.toml",
            f"{d}/data.csv",
            "-o",
            f"{d}/t.npz",
            "--bin",
            f"{d}/bin",
        ],
    )
    assert message in err and "data.csv" in err


def test_dead_phase_and_gaps(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_case(tmp_path, torque_scale=(1.0, 0.0, 1.0))
    d = str(tmp_path)
    argv = ["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz"]
    err = bad(tmp_path, capsys, argv)
    assert "data.csv: phase 2 never produced torque" in err
    write_case(tmp_path)
    from torquemap.io import read_table

    cols = read_table(tmp_path / "data.csv")
    keep = cols["position"] < 30
    write_table(tmp_path / "data.csv", {k: v[keep] for k, v in cols.items()})
    err = bad(tmp_path, capsys, argv)
    assert "data.csv: no data at positions 30 .. 47" in err


def test_corrupt_tables_for_evaluate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_case(tmp_path)
    (tmp_path / "bad.npz").write_bytes(b"PK\x03\x04 truncated")
    d = str(tmp_path)
    err = bad(
        tmp_path,
        capsys,
        ["linearize", "evaluate", f"{d}/motor.toml", f"{d}/data.csv", "--tables", f"{d}/bad.npz"],
    )
    assert "bad.npz: cannot read tables" in err


def test_missing_output_folder_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_case(tmp_path)
    d = str(tmp_path)
    err = bad(
        tmp_path,
        capsys,
        ["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz",
         "--c-header", f"{d}/nowhere/t.h"],
    )  # fmt: skip
    assert "output folder does not exist" in err


def test_two_phases_at_one_equilibrium_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_case(tmp_path)
    motor = tmp_path / "motor.toml"
    # before: accepted, and the tables for negative commands reflected two phases alike
    from torquemap.tomlfile import read_toml

    doc = read_toml(motor)
    doc["motor"]["equilibrium_positions"] = [8, 24, 8]
    write_toml(motor, doc)
    d = str(tmp_path)
    err = bad(
        tmp_path, capsys, ["linearize", "build", str(motor), f"{d}/data.csv", "-o", f"{d}/t.npz"]
    )
    assert err.startswith(f"torquemap: error: {motor}: [motor] equilibrium_positions: phases 1 "
                          "and 3 are both at table position 8")  # fmt: skip


def _noisy_case(tmp_path: Path, *, seed: int) -> list[str]:
    """write_case with 0.01 N m of noise on the torque; the ``linearize build`` arguments."""
    write_case(tmp_path)
    data = tmp_path / "data.csv"
    cols = read_table(data)
    rng = np.random.default_rng(seed)
    cols["torque"] = np.asarray(cols["torque"]) + rng.normal(0.0, 0.01, len(cols["torque"]))
    write_table(data, cols)
    return ["linearize", "build", str(tmp_path / "motor.toml"), str(data)]


def test_denoise_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = _noisy_case(tmp_path, seed=0)
    d = str(tmp_path)
    assert main([*args, "-o", f"{d}/a.npz"]) == 0
    assert "rows denoised: low-rank fit of the collection's blocks, rank" in capsys.readouterr().out
    assert load_tables(tmp_path / "a.npz").denoise_rank >= 1
    assert main([*args, "-o", f"{d}/b.npz", "--no-denoise"]) == 0
    assert "rows denoised" not in capsys.readouterr().out
    assert load_tables(tmp_path / "b.npz").denoise_rank == 0


def test_bias_weight_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = _noisy_case(tmp_path, seed=1)
    d = str(tmp_path)
    assert main([*args, "-o", f"{d}/a.npz"]) == 0
    assert main([*args, "-o", f"{d}/b.npz", "--bias-weight", "10"]) == 0
    assert main([*args, "-o", f"{d}/c.npz", "--bias-weight", "inf"]) == 0
    a, b, c = (load_tables(tmp_path / f"{k}.npz") for k in "abc")
    np.testing.assert_array_equal(a.phases, b.phases)  # 10 is the default
    assert a.denoise_rank >= 1 and c.denoise_rank >= 1
    with pytest.raises(SystemExit) as exit_info:
        main([*args, "-o", f"{d}/e.npz", "--bias-weight", "-1"])
    assert exit_info.value.code == 2
    assert "must be >= 0" in capsys.readouterr().err
    assert not (tmp_path / "e.npz").exists()


def test_tables_for_another_motor_and_saturated_data(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_case(tmp_path)
    d = str(tmp_path)
    assert main(["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz"]) == 0
    # the same tables evaluated against a 4-phase motor file: one line naming the tables file
    write_toml(
        tmp_path / "other.toml",
        {
            "motor": {
                "name": "other",
                "phases": 4,
                "positions_per_cycle": N,
                "equilibrium_positions": [6, 18, 30, 42],
                "ramping": "wide",
            }
        },
    )
    p, c = np.meshgrid(np.arange(N), np.arange(128), indexing="ij")
    write_table(
        tmp_path / "v.csv",
        {"position": p.ravel(), "command": c.ravel(), "torque": c.ravel() / 127.0},
    )
    capsys.readouterr()
    status = main(
        ["linearize", "evaluate", f"{d}/other.toml", f"{d}/v.csv", "--tables", f"{d}/t.npz"]
    )
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1
    assert f"{d}/t.npz: tables are for another motor ('synthetic'" in err
    assert "phases 3 (the motor: 4)" in err and "Traceback" not in err
    # every row at full scale: refused, nothing written
    data = read_table(tmp_path / "data.csv")
    top = np.asarray(data["pulse_width"]) == 255
    write_table(tmp_path / "sat.csv", {k: np.asarray(v)[top] for k, v in data.items()})
    status = main(["linearize", "build", f"{d}/motor.toml", f"{d}/sat.csv", "-o", f"{d}/s.npz"])
    err = capsys.readouterr().err
    assert status == 2 and "sat.csv: every row has pulse width 255" in err
    assert not (tmp_path / "s.npz").exists()


def test_a_verification_of_some_positions_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # between the positions a verification reads the tables interpolate: its APMD does not
    # see them, and evaluate says how many it read (a QA bench: 0.86 % at every 4th position,
    # the characterisation's own, against 1.54 % over every position)
    write_case(tmp_path)
    d = str(tmp_path)
    assert main(["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz"]) == 0
    for step, warned in ((1, False), (4, True)):
        p, c = np.meshgrid(np.arange(0, N, step), np.arange(128), indexing="ij")
        write_table(
            tmp_path / "v.csv",
            {"position": p.ravel(), "command": c.ravel(), "torque": (c * 0.01).ravel()},
        )
        capsys.readouterr()
        args = ["linearize", "evaluate", f"{d}/motor.toml", f"{d}/v.csv", "--tables", f"{d}/t.npz"]
        assert main(args) == 0
        err = capsys.readouterr().err
        assert ("verification read" in err) is warned
        if warned:
            assert f"read {len(range(0, N, 4))} of the {N} positions (one in 4 from 0)" in err
            assert "v.csv" in err


def test_a_verification_is_evaluated_through_its_own_tables(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a verification run measures the tables it ran through; evaluated with other tables (a
    # rebuild by the other method) evaluate printed the first tables' APMD under the second's
    # name with exit 0 (QA on bench 305). Its record holds the digest of the tables it ran
    # through, as the collection writes it: refused in one line naming the data file.
    from torquemap.linearize.collect import read_tables_npz
    from torquemap.linearize.motor import load_motor
    from torquemap.linearize.resume import CollectionRecord, tables_digest, write_record

    write_case(tmp_path)
    d = str(tmp_path)
    assert main(["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz"]) == 0
    build_paper = ["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/p.npz"]
    assert main([*build_paper, "--method", "paper"]) == 0
    p, c = np.meshgrid(np.arange(N), np.arange(128), indexing="ij")
    v = tmp_path / "v.csv"
    write_table(v, {"position": p.ravel(), "command": c.ravel(), "torque": (c * 0.01).ravel()})
    ran = read_tables_npz(tmp_path / "t.npz", load_motor(tmp_path / "motor.toml"))
    stack = np.stack([ran[f"phase_{k + 1}"] for k in range(3)])
    write_record(
        v,
        CollectionRecord(
            kind="verification",
            settings={},
            motor={"tables_sha256": tables_digest(stack)},
            done=((0, N * 128),),
        ),
    )
    evaluate = ["linearize", "evaluate", f"{d}/motor.toml", f"{d}/v.csv", "--tables"]
    capsys.readouterr()
    assert main([*evaluate, f"{d}/t.npz"]) == 0
    assert main([*evaluate, f"{d}/p.npz"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert f"{d}/v.csv: was collected through other tables than {d}/p.npz" in err
    figures = ["linearize", "figures", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/figs"]
    assert main([*figures, "--tables", f"{d}/p.npz", "--verification", f"{d}/v.csv"]) == 2
    assert "other tables than" in capsys.readouterr().err
    # figures: a verification without its tables was dropped without a word
    assert main([*figures, "--verification", f"{d}/v.csv"]) == 2
    assert "v.csv: a verification run is drawn beside the tables" in capsys.readouterr().err
    assert not (tmp_path / "figs").exists()


def test_figures_refuse_tables_of_another_motor(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # tables for another motor were drawn beside this motor's data, exit 0 (QA: bench 328's
    # tables with bench 305's files); evaluate and collect refused them already
    write_case(tmp_path)
    d = str(tmp_path)
    assert main(["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz"]) == 0
    motor = (tmp_path / "motor.toml").read_text().replace("[8, 24, 40]", "[9, 25, 41]")
    motor = motor.replace("8,\n    24,\n    40,", "9,\n    25,\n    41,")
    (tmp_path / "other.toml").write_text(motor)
    assert "9" in motor and "8" not in motor.split("equilibrium_positions")[1]
    capsys.readouterr()
    args = ["linearize", "figures", f"{d}/other.toml", f"{d}/data.csv", "--tables", f"{d}/t.npz"]
    assert main([*args, "-o", f"{d}/figs"]) == 2
    err = capsys.readouterr().err
    assert f"{d}/t.npz: tables are for another motor" in err and err.count("\n") == 1
    assert not (tmp_path / "figs").exists()


def test_a_closed_stdout_pipe_ends_quietly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # `torquemap linearize evaluate ... | head -1` closes the pipe before the report is printed:
    # it said "torquemap: error: Broken pipe" with exit 2, as for bad input; a pipeline expects
    # the silent end of a writer whose reader is gone (exit 128 + SIGPIPE)
    import sys

    write_case(tmp_path)
    d = str(tmp_path)

    class Closed:
        def write(self, text: str) -> int:
            raise BrokenPipeError(32, "Broken pipe")

        def flush(self) -> None:
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sys, "stdout", Closed())
    assert main(["linearize", "evaluate", f"{d}/motor.toml", f"{d}/data.csv"]) == 141
    assert capsys.readouterr().err == ""


def test_a_data_file_cut_inside_its_last_line_is_warned(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A DATA.csv copied while a collection wrote it can end inside its last number (the torque
    "0.1234" read as "0.12"): build and evaluate name the file; a whole file stays silent."""
    write_case(tmp_path)
    d = str(tmp_path)
    assert main(["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz"]) == 0
    assert "no line end" not in capsys.readouterr().err
    text = (tmp_path / "data.csv").read_text()
    (tmp_path / "data.csv").write_text(text.rstrip("\n")[:-3])  # cut inside the last torque
    for argv in (
        ["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/u.npz"],
        ["linearize", "evaluate", f"{d}/motor.toml", f"{d}/data.csv"],
    ):
        assert main(argv) == 0
        err = capsys.readouterr().err
        assert f"{d}/data.csv: the last line has no line end" in err, err


def test_a_phase_table_cut_short_is_named(tmp_path: Path) -> None:
    write_case(tmp_path)
    d = str(tmp_path)
    args = ["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz"]
    assert main(args) == 0
    with np.load(tmp_path / "t.npz") as npz:
        arrays = {name: npz[name] for name in npz.files}
    arrays["phase_2"] = arrays["phase_2"][:, :100]  # a table that lost its top commands
    np.savez(tmp_path / "short.npz", **arrays)
    with pytest.raises(InputError, match=r"table 'phase_2' has shape \(\d+, 100\), 'phase_1'"):
        load_tables(tmp_path / "short.npz")


def test_data_of_the_other_kind_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # before: "missing column 'command' (the file has position, pulse_width, torque)", and
    # the reverse, for a user who swapped the characterisation and the verification file
    write_case(tmp_path)
    d = str(tmp_path)
    assert main(["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz"]) == 0
    p, c = np.meshgrid(np.arange(N), np.arange(0, 128, 8), indexing="ij")
    write_table(
        tmp_path / "v.csv",
        {"position": p.ravel(), "command": c.ravel(), "torque": c.ravel() * 0.01},
    )
    capsys.readouterr()
    assert (
        main(
            ["linearize", "evaluate", f"{d}/motor.toml", f"{d}/data.csv", "--tables", f"{d}/t.npz"]
        )
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"torquemap: error: {d}/data.csv: characterisation data (pulse_width), but --tables "
        "evaluates a verification run (position, command, torque: linearize collect --tables); "
        "drop --tables to evaluate the characterisation"
    ]
    assert main(["linearize", "evaluate", f"{d}/motor.toml", f"{d}/v.csv"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"torquemap: error: {d}/v.csv: verification data (command), evaluated as a "
        "characterisation: give the tables it was collected with, --tables TABLES.npz"
    ]


def test_a_command_step_past_half_way_says_which_step(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # linearize collect --tables --step 64 on 7-bit commands: 0, 64, 127. APMD's tau_ave is
    # the torque at the half-way command 63.5 between the commands from 1: none below it.
    # Before: "no position has data on both sides of the half-way command 63.5", no cause
    write_case(tmp_path)
    d = str(tmp_path)
    assert main(["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o", f"{d}/t.npz"]) == 0
    p, c = np.meshgrid(np.arange(N), [0, 64, 127], indexing="ij")
    write_table(
        tmp_path / "v.csv",
        {"position": p.ravel(), "command": c.ravel(), "torque": c.ravel() * 0.01},
    )
    capsys.readouterr()
    assert (
        main(["linearize", "evaluate", f"{d}/motor.toml", f"{d}/v.csv", "--tables", f"{d}/t.npz"])
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"torquemap: error: {d}/v.csv: no position has")
    assert "(the commands from 1 hold 2 values, 64 to 127, 0 cells below it)" in err[0]
    assert err[0].endswith("(a collection --step or --pulse-step of at most 63)")
    # --step 63 (0, 63, 126, 127) is evaluated
    p, c = np.meshgrid(np.arange(N), [0, 63, 126, 127], indexing="ij")
    write_table(
        tmp_path / "v.csv",
        {"position": p.ravel(), "command": c.ravel(), "torque": c.ravel() * 0.01},
    )
    assert (
        main(["linearize", "evaluate", f"{d}/motor.toml", f"{d}/v.csv", "--tables", f"{d}/t.npz"])
        == 0
    )


def test_a_collection_step_past_half_way_is_warned_when_collecting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # warned before the rig time is spent (the data are collected: build can use them)
    d = tmp_path / "rig"
    argv = ["simulate", "rig", "--motor", "vr", "--out", str(d), "--readings", "1"]
    # (position step 40: gaps build can bridge, 42 at most on 512 positions and 3 phases)
    argv += ["--position-step", "40", "--no-progress", "--pulse-step"]
    assert main([*argv, "200"]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        f"torquemap: warning: {d / 'data.csv'}: a step of 200 leaves no pulse width from 1 below "
        "half way (127.5): linearize evaluate cannot read the APMD's reference torque there; a "
        "step of at most 127 can"
    ]
    assert main(["linearize", "evaluate", f"{d}/motor.toml", f"{d}/data.csv"]) == 2
    assert "at most 127)" in capsys.readouterr().err
    again = ["linearize", "collect", f"{d}/motor.toml", "--sim", "vr", "--readings", "1"]
    again += ["--position-step", "40", "--no-progress", "--step"]
    assert main([*again, "200", "-o", f"{tmp_path}/b.csv"]) == 0
    assert "a step of 200 leaves no pulse width" in capsys.readouterr().err
    assert main([*again, "127", "-o", f"{tmp_path}/c.csv"]) == 0
    assert "warning" not in capsys.readouterr().err


@pytest.mark.parametrize("budget", ["0", "10", "nan"])
def test_a_budget_outside_its_range_names_the_flag(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], budget: str
) -> None:
    # before: "torquemap: error: the budget fraction must be in (0, 1], got 10.0", no flag
    write_case(tmp_path)
    argv = ["linearize", "collect", f"{tmp_path}/motor.toml", "--sim", "vr", "--adaptive"]
    with pytest.raises(SystemExit) as exit_info:
        main([*argv, "--budget", budget, "-o", f"{tmp_path}/a.csv"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].endswith(f"argument --budget: must be a number in (0, 1], got {budget}")
    assert not (tmp_path / "a.csv").exists()


def test_fewer_actuation_bits_than_the_motor_is_warned(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # --actuation-bits 2 on a motor of 8-bit pulse widths: entries 0 .. 3, each step 85 pulse
    # widths; before: written without a word (the option is for 16-bit drives)
    write_case(tmp_path)
    d = str(tmp_path)
    args = ["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv", "-o"]
    assert main([*args, f"{d}/a.npz", "--actuation-bits", "2"]) == 0
    tables = load_tables(tmp_path / "a.npz")
    assert int(tables.phases.max()) == 3  # what the warning says: entries 0 .. 3
    err = capsys.readouterr().err.strip().splitlines()
    # the synthetic surface changes by 8.5 % a position: linearize.count's line comes too (Q40)
    assert [line for line in err if "one table position is 1/48" not in line] == [
        f"torquemap: warning: {d}/motor.toml: --actuation-bits 2 gives entries 0 .. 3, coarser "
        "than the motor's pulse widths 0 .. 255: each entry step is 85 pulse widths (the option "
        "is for drives with more bits than the motor file's)"
    ]
    assert main([*args, f"{d}/b.npz", "--actuation-bits", "12"]) == 0
    assert "actuation-bits" not in capsys.readouterr().err


def test_nyquist_option_reaches_the_tables(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the closed form of test_linearize_hidden_wave: cogging of 16 periods whose zeros sit on
    # the measured positions, read by the rows the rig's compliance moved between them. The
    # sampling check is silent there, so "on" (stop 40's default) and "off" give the same
    # tables; "tested" (the default) keeps the wave and says so once
    from _reuse import reused
    from test_linearize_hidden_wave import _apmd, _collection, _hidden, _spec

    from torquemap.linearize import tables as tables_module
    from torquemap.linearize.motor import motor_to_dict

    # tests/_reuse.py: a build with the same rows and options as an earlier one of this test
    # (the default spelt out; the API's keyword on the rows the CLI read) is computed once;
    # an option the CLI failed to pass would be another key, so a build of its own, and the
    # comparisons below would catch it
    with reused({}):
        build_tables = tables_module.build_tables
        spec = _spec()
        pos, pw, tau = _collection(spec, _hidden, noise=0.02, seed=4)
        write_toml(tmp_path / "motor.toml", motor_to_dict(spec))
        write_table(tmp_path / "data.csv", {"position": pos, "pulse_width": pw, "torque": tau})
        d = str(tmp_path)
        argv = ["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv"]
        hidden = "do not see"
        built = {}
        for choice in ("default", "tested", "on", "off"):
            flag = [] if choice == "default" else ["--nyquist", choice]
            assert main([*argv, "-o", f"{d}/{choice}.npz", *flag]) == 0
            tables = load_tables(tmp_path / f"{choice}.npz")
            built[choice] = tables.phases
            assert capsys.readouterr().err.count(hidden) == (choice in ("default", "tested"))
        # the same tables as the API's keyword from the rows of the file
        data = read_table(tmp_path / "data.csv")
        rows = (data["position"].astype(np.int64), data["pulse_width"], data["torque"])
        for choice, keyword in (("tested", "tested"), ("off", False)):
            assert np.array_equal(built[choice], build_tables(spec, *rows, nyquist=keyword).phases)
        assert np.array_equal(built["default"], built["tested"])
        assert np.array_equal(built["on"], built["off"])
        # against the closed form's torque law the wave helps (measured APMD 1.3 % against 3.6 %)
        cmax = tables.command_max
        assert _apmd(_hidden, built["tested"], cmax) < 0.6 * _apmd(_hidden, built["off"], cmax)


def test_onset_form_option_reaches_the_tables(tmp_path: Path) -> None:
    # the one-phase convex amplifier of test_onset_choose written as MOTOR.toml and DATA.csv:
    # --onset-form choose gives the API's onset_form="choose" tables (there the amplifier's),
    # which differ from the default's (the power law's)
    from test_onset_choose import N, _rows

    from torquemap.linearize.motor import motor_spec, motor_to_dict
    from torquemap.linearize.tables import build_tables

    spec = motor_spec("m1", phases=1, positions_per_cycle=N, equilibrium_positions=(0,))
    _, pos, pw, tau = _rows(1.5, 1.0, 0)
    write_toml(tmp_path / "motor.toml", motor_to_dict(spec))
    write_table(tmp_path / "data.csv", {"position": pos, "pulse_width": pw, "torque": tau})
    d = str(tmp_path)
    argv = ["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv"]
    built = {}
    for choice in ("default", "choose"):
        flag = [] if choice == "default" else ["--onset-form", choice]
        assert main([*argv, "-o", f"{d}/{choice}.npz", *flag]) == 0
        built[choice] = load_tables(tmp_path / f"{choice}.npz").phases
    data = read_table(tmp_path / "data.csv")
    rows = (data["position"].astype(np.int64), data["pulse_width"], data["torque"])
    assert np.array_equal(built["choose"], build_tables(spec, *rows, onset_form="choose").phases)
    assert np.array_equal(built["default"], build_tables(spec, *rows).phases)
    assert not np.array_equal(built["choose"], built["default"])


def test_onset_window_option_reaches_the_tables(tmp_path: Path) -> None:
    # the four-phase closed form of test_onset_window (torque ~ current^2, the amplifier's
    # curve c = 1 past a dead zone of 23, seed 1), where the choice takes the 0.15 window
    # (measured t = -3.2): --onset-window choose gives the API's onset_window="choose" tables,
    # which differ from the default's
    from test_onset_window import _collection, _spec

    from torquemap.linearize.motor import motor_to_dict
    from torquemap.linearize.tables import build_tables

    spec = _spec()
    pos, pw, tau = _collection(spec, (23.0, 1.0, 2.0), seed=1)
    write_toml(tmp_path / "motor.toml", motor_to_dict(spec))
    write_table(tmp_path / "data.csv", {"position": pos, "pulse_width": pw, "torque": tau})
    d = str(tmp_path)
    argv = ["linearize", "build", f"{d}/motor.toml", f"{d}/data.csv"]
    built = {}
    for choice in ("default", "choose"):
        assert main([*argv, "-o", f"{d}/{choice}.npz", "--onset-window", choice]) == 0
        built[choice] = load_tables(tmp_path / f"{choice}.npz").phases
    data = read_table(tmp_path / "data.csv")
    rows = (data["position"].astype(np.int64), data["pulse_width"], data["torque"])
    api = build_tables(spec, *rows, onset_window="choose")
    assert api.onset_window == 0.15
    assert np.array_equal(built["choose"], api.phases)
    assert not np.array_equal(built["choose"], built["default"])
