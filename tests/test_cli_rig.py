"""CLI: ``simulate rig`` and ``linearize collect``."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from torquemap.cli import cmd_linearize_collect
from torquemap.cli.main import build_parser, main
from torquemap.errors import InputError
from torquemap.io import read_table, write_toml
from torquemap.linearize.motor import load_motor, motor_to_dict
from torquemap.sim.rig import brushless_dc_rig

FAST = ["--readings", "2", "--position-step", "32", "--no-progress"]


def _collect(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """Run ``linearize collect`` through main() once cmd_linearize registers it, else alone."""
    try:
        build_parser().parse_args(["linearize", "collect", "--help"])
    except SystemExit as stop:
        capsys.readouterr()
        if stop.code == 0:
            status = main(["linearize", "collect", *argv])
            return status, capsys.readouterr().err
    parser = argparse.ArgumentParser(prog="torquemap linearize")
    cmd_linearize_collect.register(parser.add_subparsers())
    args = parser.parse_args(["collect", *argv])
    try:
        status = args.handler(args)
    except InputError as exc:  # what main() does with it
        return 2, f"torquemap: error: {exc}\n"
    return status, capsys.readouterr().err


def test_simulate_rig_writes_motor_and_data(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "bench"
    status = main(
        ["simulate", "rig", "--motor", "bldc", "--out", str(out), "--pulse-step", "32", *FAST]
    )
    assert status == 0
    assert "data.csv" in capsys.readouterr().out
    spec = load_motor(out / "motor.toml")
    rig = brushless_dc_rig(rng=0)
    assert spec.positions_per_cycle == 256 and spec.ramping == "wide"
    assert spec.equilibrium_positions == rig.equilibrium_positions()
    data = read_table(out / "data.csv")
    assert list(data) == ["position", "pulse_width", "torque", "bias"]
    assert_array_equal(np.unique(data["pulse_width"]), [*range(0, 255, 32), 255])
    assert sorted({int(p) // 32 for p in data["position"]}) == list(range(8))
    # same seed, same file; the output is a function of the arguments
    again = tmp_path / "again"
    main(["simulate", "rig", "--motor", "bldc", "--out", str(again), "--pulse-step", "32", *FAST])
    assert (again / "data.csv").read_bytes() == (out / "data.csv").read_bytes()
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no temporary files left


def test_simulate_rig_keeps_the_collection_record(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The record stays beside data.csv, as a real collection's: ``linearize build`` weighs the
    bias by the bias readings per reading it names (before: the default 10, whatever
    ``--bias-readings`` said), and ``linearize collect`` on the same file has nothing left."""
    from torquemap.cli.cmd_linearize import _bias_weight
    from torquemap.linearize.resume import read_record

    out = tmp_path / "bench"
    argv = ["--pulse-step", "32", "--readings", "4", "--bias-readings", "6"]
    status = main(["simulate", "rig", "--motor", "bldc", "--out", str(out), *argv, *FAST[2:]])
    assert status == 0
    record = read_record(out / "data.csv")
    assert record is not None and record.kind == "characterisation"
    assert sum(rows for _, rows in record.done) == len(read_table(out / "data.csv")["position"])
    assert _bias_weight(None, str(out / "data.csv")) == pytest.approx(6 / 4)
    before = (out / "data.csv").read_bytes()
    capsys.readouterr()
    again = [str(out / "motor.toml"), "-o", str(out / "data.csv"), "--sim", "bldc", "--step"]
    status, _ = _collect([*again, "32", *argv[2:], *FAST[2:]], capsys)
    assert status == 0 and (out / "data.csv").read_bytes() == before


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--seed", "-1"], "seed must be a non-negative integer"),
        (["--pulse-step", "0"], "level step must be a positive integer"),
        (["--position-step", "0"], "position step must be a positive integer"),
        (["--readings", "0"], "readings must be a positive integer"),
        (["--bias-readings", "0"], "bias readings must be a positive integer"),
    ],
)
def test_simulate_rig_bad_options(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: list[str], message: str
) -> None:
    status = main(
        ["simulate", "rig", "--motor", "vr", "--out", str(tmp_path / "o"), "--no-progress", *extra]
    )
    err = capsys.readouterr().err
    assert status == 2 and message in err and err.count("\n") == 1


def test_simulate_rig_out_is_a_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "f").write_text("x")
    status = main(["simulate", "rig", "--motor", "vr", "--out", str(tmp_path / "f"), *FAST])
    err = capsys.readouterr().err
    assert status == 2 and "not a folder" in err and err.count("\n") == 1


def _motor_file(tmp_path: Path) -> Path:
    path = tmp_path / "motor.toml"
    write_toml(path, motor_to_dict(brushless_dc_rig(rng=0).motor_spec()))
    return path


def test_linearize_collect_resumes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    motor = _motor_file(tmp_path)
    data = tmp_path / "data.csv"
    argv = [str(motor), "-o", str(data), "--sim", "bldc", "--step", "64", *FAST]
    status, _ = _collect(argv, capsys)
    assert status == 0
    first = data.read_bytes()
    rows = read_table(data)
    assert rows["torque"].size == 8 * 5  # 8 positions x pulse widths 0, 64, 128, 192, 255
    status, _ = _collect(argv, capsys)  # resume a complete file: nothing to measure
    assert status == 0 and data.read_bytes() == first
    # other settings than the file's: refused, naming them, the file untouched
    status, err = _collect([*argv, "--position-step", "16", "--readings", "3"], capsys)
    assert status == 2 and err.count("\n") == 1 and str(data) in err
    assert "position_step (this run 16, the file's 32)" in err and "readings (this run 3" in err
    assert data.read_bytes() == first


def test_linearize_collect_verification(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    motor = _motor_file(tmp_path)
    spec = load_motor(motor)
    c = np.arange(256)
    inverse = np.where(c < 128, 2 * c, 0)
    np.savez(
        tmp_path / "tables.npz",
        **{
            f"phase_{k + 1}": np.rint(inverse * spec.ramp[:, k : k + 1]).astype(np.int64)
            for k in range(3)
        },
    )
    after = tmp_path / "after.csv"
    argv = [
        str(motor),
        "-o",
        str(after),
        "--sim",
        "bldc",
        "--tables",
        str(tmp_path / "tables.npz"),
        "--step",
        "32",
        *FAST,
    ]
    status, _ = _collect(argv, capsys)
    assert status == 0
    rows = read_table(after)
    assert list(rows) == ["position", "command", "torque", "bias"]
    assert_array_equal(np.unique(rows["command"]), [0, 32, 64, 96, 127])


def test_linearize_collect_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    motor = _motor_file(tmp_path)
    status, err = _collect(
        [str(motor), "-o", str(tmp_path / "d.csv"), "--sim", "vr", *FAST], capsys
    )
    assert status == 2 and "simulated vr motor has 3 and 512" in err and str(motor) in err
    status, err = _collect([str(tmp_path / "none.toml"), "-o", "d.csv", "--sim", "vr"], capsys)
    assert status == 2 and "file not found" in err
    np.savez(tmp_path / "t.npz", phase_1=np.zeros((256, 256), dtype=np.int64))
    argv = [
        str(motor),
        "-o",
        str(tmp_path / "a.csv"),
        "--sim",
        "bldc",
        "--tables",
        str(tmp_path / "t.npz"),
        *FAST,
    ]
    status, err = _collect(argv, capsys)
    assert status == 2 and "t.npz: tables lack 'phase_2'" in err
    assert not (tmp_path / "a.csv").exists()


def test_bias_open_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # with the bias read on an open contact the level-0 rows hold the torque at rest (the BLDC's
    # cogging beyond friction: 0 .. 0.06 N m); read at rest (the default) they average zero
    level0 = {}
    for flag in ([], ["--bias-open"]):
        out = tmp_path / f"rig{len(flag)}"
        argv = ["simulate", "rig", "--motor", "bldc", "--out", str(out), "--pulse-step", "255"]
        assert (
            main([*argv, "--readings", "20", "--position-step", "4", "--no-progress", *flag]) == 0
        )
        data = read_table(out / "data.csv")
        level0[bool(flag)] = np.asarray(data["torque"])[np.asarray(data["pulse_width"]) == 0]
        assert _collect(
            [str(out / "motor.toml"), "--sim", "bldc", "-o", str(out / "c.csv"), "--step", "255",
             *FAST, *flag],
            capsys,
        )[0] == 0  # fmt: skip
    assert abs(level0[False].mean()) < 0.002
    assert level0[True].mean() > 0.005 and level0[True].max() > 0.04
    capsys.readouterr()


def test_transitions_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from torquemap.linearize.collect import collection_targets

    out = tmp_path / "rig"
    argv = ["simulate", "rig", "--motor", "bldc", "--out", str(out), "--pulse-step", "255"]
    assert main([*argv, *FAST, "--transitions"]) == 0
    spec = load_motor(out / "motor.toml")
    data = read_table(out / "data.csv")
    blocks = int(np.sum(np.asarray(data["pulse_width"]) == 0))
    wanted = collection_targets(spec, positions=8, transitions=True)
    assert blocks == wanted.size > 8
    status, _ = _collect(
        [str(out / "motor.toml"), "--sim", "bldc", "-o", str(out / "c.csv"), "--step", "255",
         *FAST, "--transitions"],
        capsys,
    )  # fmt: skip
    assert status == 0
    again = read_table(out / "c.csv")
    assert int(np.sum(np.asarray(again["pulse_width"]) == 0)) == wanted.size


def test_verification_refuses_tables_in_other_units(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # tables built with --actuation-bits 6 hold entries 0 .. 63 for a 0 .. 255 amplifier: the
    # verification applied them as pulse widths (QA bench 305: APMD 1475 %, exit 0), and 10-bit
    # ones were refused as "values outside 0 .. 255"
    from torquemap.linearize.export import save_tables
    from torquemap.linearize.tables import build_tables

    motor = _motor_file(tmp_path)
    spec = load_motor(motor)
    n = spec.positions_per_cycle
    p, w = np.meshgrid(np.arange(0, n, 8), np.arange(0, 256, 16), indexing="ij")
    tau = (2.0 + np.cos(2 * np.pi * 3 * p / n)) * (w / 255.0) ** 2
    for bits in (6, 10):
        tables = build_tables(spec, p.ravel(), w.ravel(), tau.ravel(), actuation_bits=bits)
        save_tables(tmp_path / f"t{bits}.npz", tables)
        out = tmp_path / f"after{bits}.csv"
        argv = [
            str(motor),
            "-o",
            str(out),
            "--sim",
            "bldc",
            "--tables",
            str(tmp_path / f"t{bits}.npz"),
        ]
        status, err = _collect([*argv, *FAST], capsys)
        top = (1 << bits) - 1
        assert status == 2 and err.count("\n") == 1
        assert f"t{bits}.npz: table entries run 0 .. {top} (built with --actuation-bits)" in err
        assert not out.exists()


def test_data_is_read_with_the_motor_file_it_was_collected_with(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # DATA.csv's pulse widths were ramped through the motor file's ramp: built with the file
    # edited from wide to narrow after the collection, the tables were 52 % APMD against 2 %
    # with exit 0 (QA bench 316). The collection's record holds the ramp's digest.
    motor = _motor_file(tmp_path)
    data = tmp_path / "data.csv"
    status, _ = _collect(
        [str(motor), "-o", str(data), "--sim", "bldc", "--step", "64", *FAST], capsys
    )
    assert status == 0
    text = motor.read_text()
    assert 'ramping = "wide"' in text
    narrow = tmp_path / "narrow.toml"
    narrow.write_text(text.replace('ramping = "wide"', 'ramping = "narrow"'))
    capsys.readouterr()
    assert main(["linearize", "build", str(narrow), str(data), "-o", str(tmp_path / "t.npz")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"{data}: was collected with another motor file than {narrow} (another ramp" in err
    assert not (tmp_path / "t.npz").exists()
    # the same rows without their record (data from elsewhere): nothing to compare, read
    from torquemap.linearize.resume import record_path
    from torquemap.linearize.tables import read_data

    record_path(data).unlink()
    assert read_data(data, load_motor(narrow), kind="characterisation").position.size > 0
