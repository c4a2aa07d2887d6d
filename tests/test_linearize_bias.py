"""The bias column of DATA.csv and what the table builder makes of it (torquemap.linearize.bias).

Checked against (1) a bias known in closed form, simulated inside the test: a sensor drift of
one period per cycle plus the load at rest ``max(cogging - friction, 0)`` of a 12-period
cogging, with seeded noise; (2) the simulated rig, where a collection with the bias read on an
open contact, with the same sensor-noise seed, measures the same readings with the load kept in
the rows: a second method for what the correction must restore.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from torquemap.cli.main import main
from torquemap.errors import InputError
from torquemap.io import read_table, write_table, write_toml
from torquemap.linearize.bias import check_bias
from torquemap.linearize.collect import (
    CollectionSettings,
    collect_characterisation,
    collect_verification,
)
from torquemap.linearize.export import save_tables
from torquemap.linearize.metrics import apmd_report, evaluate_linearity
from torquemap.linearize.motor import MotorSpec, load_motor, motor_to_dict
from torquemap.linearize.tables import LinearizeData, TableSet, build_tables, read_data
from torquemap.sim.motors import BrushlessDcMotor
from torquemap.sim.rig import SimRig, brushless_dc_rig

#: conftest.py's ``_reused_builds`` (tests/_reuse.py): each distinct table build of this
#: module runs once; the CLI builds the rows ``restored_tables`` and
#: ``plain`` read (the bias column dropped)
REUSE_BUILDS = True

N = 128
PERIODS = 12


def _closed_form(
    cogging: float, *, seed: int = 0
) -> tuple[dict[str, np.ndarray], np.ndarray, float]:
    """Rows of a collection with the bias read at rest, every 2nd position and 4 levels.

    The sensor's own bias drifts over the cycle, ``1 + 0.4 cos(2 pi p / N + 0.3)``; the contact
    is loaded at rest by ``max(cogging sin(2 pi 12 p / N) - 0.05, 0)``, which the bias swallows.
    Each block's bias averages 100 readings of noise 0.05 N m, each row 10 (the collection's
    defaults). Returns the columns, the true load per block and the bias's standard error.
    """
    g = np.random.default_rng(seed)
    targets = np.arange(0, N, 2)
    levels = np.array([0, 85, 170, 255])
    load = np.maximum(cogging * np.sin(2 * np.pi * PERIODS * targets / N) - 0.05, 0.0)
    drift = 1.0 + 0.4 * np.cos(2 * np.pi * targets / N + 0.3)
    sigma = 0.05
    bias = drift + load + g.normal(0.0, sigma / np.sqrt(100), targets.size)
    p = np.repeat(targets, levels.size)
    w = np.tile(levels, targets.size)
    reading = np.repeat(drift + load, levels.size) + w / 100.0
    reading = reading + g.normal(0.0, sigma / np.sqrt(10), p.size)
    cols = {
        "position": p,
        "pulse_width": w,
        "torque": reading - np.repeat(bias, levels.size),
        "bias": np.repeat(bias, levels.size),
    }
    return cols, load, sigma / np.sqrt(100)


def test_a_load_in_the_bias_is_found_and_restored() -> None:
    cols, load, se = _closed_form(0.3)
    check = check_bias(
        cols["position"], cols["pulse_width"], cols["torque"], cols["bias"], positions_per_cycle=N
    )
    assert check.varies and check.separated and check.harmonics == 1  # the drift's one period
    # the standard error from the rows at level 0: within 15 % of the truth (64 rows)
    assert abs(check.standard_error / se - 1) < 0.15
    assert_array_equal(check.position, np.arange(0, N, 2))
    # the loaded blocks are those whose load stands 3 standard errors out of the noise
    assert_array_equal(check.loaded[load > 6 * se], True)
    assert_array_equal(check.loaded[load == 0], False)
    # restored to each row: the true load within 5 standard errors (the block's noise and the
    # drift's fit: at most ~3.3 sigma among 64 blocks, sqrt(1 + 3/64) wider)
    assert_allclose(check.restore, np.repeat(load, 4), atol=5 * se)
    assert_allclose(check.load()[check.loaded], load[check.loaded], atol=5 * se)
    assert "--bias-open" in check.advice(restored=True)


def test_no_load_stays_silent() -> None:
    # cogging below the friction (0.04 < 0.05) everywhere: the contact is never loaded at rest;
    # the bias varies by 0.8 N m over the cycle (the sensor's drift) and nothing is said
    cols, load, se = _closed_form(0.04)
    assert not load.any()
    check = check_bias(
        cols["position"], cols["pulse_width"], cols["torque"], cols["bias"], positions_per_cycle=N
    )
    assert np.ptp(check.bias) > 0.7
    assert not check.varies and not check.loaded.any() and check.separated
    assert check.p_value > 1e-3
    # the rows are re-zeroed on the drift: what is restored is each block's bias noise (5
    # standard errors: the largest of 64 normal draws, and the drift's fit)
    assert_allclose(check.restore, 0.0, atol=5 * se)
    assert np.std(check.restore) > 0.5 * se


def test_a_bias_the_drift_cannot_follow_is_warned_not_restored() -> None:
    # every 8th block 0.3 N m low: a load only adds, and no smooth drift leaves the blocks
    # below it within their noise, so the load cannot be told from the drift
    cols, _, _ = _closed_form(0.3)
    block = cols["position"] // 2
    cols["bias"] = cols["bias"] - 0.3 * (block % 8 == 0)
    check = check_bias(
        cols["position"], cols["pulse_width"], cols["torque"], cols["bias"], positions_per_cycle=N
    )
    assert check.varies and not check.separated and not check.restore.any()
    assert "Collect again with the bias read on an open contact" in check.advice(restored=False)


# -- the simulated rig: a bias read at rest against one read on an open contact ----------------

SETTINGS = CollectionSettings(readings=10, position_step=4, level_step=8, progress=False)


def _collect(rig: SimRig, spec: MotorSpec, out: Path, *, bias_open: bool) -> LinearizeData:
    settings = dataclasses.replace(SETTINGS, bias_open=bias_open)
    collect_characterisation(rig, spec, out, settings)
    return read_data(out, spec, kind="characterisation")


def _apmd(rig: SimRig, tables: TableSet) -> float:
    """Noise-free APMD of the sensed torque (motor less friction) through the tables."""
    n, cmax = tables.positions_per_cycle, tables.command_max
    act = np.moveaxis(tables.phases[:, :, : cmax + 1], 0, -1)
    p = np.arange(n)[:, None]
    sensed = np.maximum(rig.true_torque(p, act) - rig.settings.friction, 0.0)
    pp, cc = np.meshgrid(np.arange(n), np.arange(cmax + 1), indexing="ij")
    return apmd_report(
        pp.ravel(), cc.ravel(), sensed.ravel(), command_max=cmax, positions_per_cycle=n
    ).apmd


@pytest.fixture(scope="module")
def cogging_rig(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """The BLDC rig (cogging 0.12 N m, friction 0.06 N m: the contact is loaded at rest over
    part of the cycle), collected with the bias at rest and on an open contact, same noise."""
    tmp = tmp_path_factory.mktemp("bias")
    out: dict[str, object] = {"tmp": tmp}
    for bias_open in (False, True):
        rig = brushless_dc_rig(rng=7)
        spec = rig.motor_spec()
        out[f"data_{bias_open}"] = _collect(
            rig, spec, tmp / f"d{bias_open}.csv", bias_open=bias_open
        )
        out["rig"], out["spec"] = rig, spec
    return out


@pytest.fixture(scope="module")
def restored_tables(cogging_rig: dict[str, object]) -> TableSet:
    """The tables built from ``cogging_rig``'s rows read with the bias at rest, the load at rest
    restored from the bias column (two tests read them; read-only)."""
    rest: LinearizeData = cogging_rig["data_False"]  # type: ignore[assignment]
    spec: MotorSpec = cogging_rig["spec"]  # type: ignore[assignment]
    return build_tables(spec, rest.position, rest.level, rest.torque, bias=rest.bias)


@pytest.mark.xdist_group("bias_rig")
def test_the_rest_bias_is_restored_to_what_an_open_contact_reads(
    cogging_rig: dict[str, object], restored_tables: TableSet
) -> None:
    rest: LinearizeData = cogging_rig["data_False"]  # type: ignore[assignment]
    opened: LinearizeData = cogging_rig["data_True"]  # type: ignore[assignment]
    spec: MotorSpec = cogging_rig["spec"]  # type: ignore[assignment]
    rig: SimRig = cogging_rig["rig"]  # type: ignore[assignment]
    assert rest.bias is not None and opened.bias is not None
    assert_array_equal(rest.position, opened.position)  # the same rows, the same readings
    load = rest.bias - opened.bias  # what the open contact says the bias swallowed
    assert load.max() > 0.04 and load.min() > -0.01  # real, and never negative (noise aside)
    check = check_bias(
        rest.position,
        rest.level,
        rest.torque,
        rest.bias,
        positions_per_cycle=spec.positions_per_cycle,
    )
    assert check.varies and check.separated
    # restored rows = readings less the drift; the open collection's = readings less the
    # sensor's own bias of each block: they differ by that bias's noise and the drift's fit,
    # 0.02 N m / sqrt(100) a block: 5 standard errors
    se = rig.settings.noise / np.sqrt(100)
    assert_allclose(rest.torque + check.restore, opened.torque, atol=5 * se)
    # the tables: restored, as good as the open contact's (within 10 %), far better than not
    restored = restored_tables  # build_tables(..., bias=rest.bias)
    plain = build_tables(spec, rest.position, rest.level, rest.torque)
    open_tables = build_tables(spec, opened.position, opened.level, opened.torque)
    assert _apmd(rig, restored) < 1.1 * _apmd(rig, open_tables)
    assert _apmd(rig, restored) < 0.8 * _apmd(rig, plain)
    assert any("--bias-open" in w for w in restored.warnings)
    assert not any("bias" in w for w in plain.warnings)


@pytest.mark.parametrize("cogging", [0.0, 0.05])
def test_no_load_at_rest_on_the_rig_is_silent(tmp_path: Path, cogging: float) -> None:
    # no cogging, and cogging the friction (0.06 N m) holds everywhere: the bias at rest is the
    # sensor's own (0.6 + 0.2 sin over the cycle); the tables are those of the rows alone
    rig = brushless_dc_rig(rng=3, motor=BrushlessDcMotor(cogging=cogging))
    spec = rig.motor_spec()
    data = _collect(rig, spec, tmp_path / "d.csv", bias_open=False)
    assert data.bias is not None and np.ptp(data.bias) > 0.3
    check = check_bias(data.position, data.level, data.torque, data.bias, positions_per_cycle=256)
    assert not check.varies and check.separated
    # re-zeroed on the drift: each block's bias noise, 0.02 N m / sqrt(100), within 5 of it
    assert_allclose(check.restore, 0.0, atol=5 * rig.settings.noise / 10)
    with_bias = build_tables(spec, data.position, data.level, data.torque, bias=data.bias)
    without = build_tables(spec, data.position, data.level, data.torque)
    assert with_bias.warnings == without.warnings  # silent
    kept = build_tables(
        spec, data.position, data.level, data.torque, bias=data.bias, restore_bias=False
    )
    assert_array_equal(kept.phases, without.phases)


@pytest.mark.xdist_group("bias_rig")
def test_cli_build_warns_naming_the_file_and_reads_older_files(
    cogging_rig: dict[str, object], capsys: pytest.CaptureFixture[str]
) -> None:
    tmp: Path = cogging_rig["tmp"]  # type: ignore[assignment]
    write_toml(tmp / "m.toml", motor_to_dict(cogging_rig["spec"]))  # type: ignore[arg-type]
    data = str(tmp / "dFalse.csv")
    assert main(["linearize", "build", str(tmp / "m.toml"), data, "-o", str(tmp / "t.npz")]) == 0
    out, err = capsys.readouterr()
    assert "rows re-zeroed on the bias column's smooth drift over the cycle (1 harmonic)" in out
    assert err.count("\n") == 1 and err.startswith(f"torquemap: warning: {data}: the bias read at")
    assert "--bias-open" in err
    # the same rows without the bias column (an older file): built as before, silently
    cols = read_table(data)
    del cols["bias"]
    write_table(tmp / "old.csv", cols)
    old = str(tmp / "old.csv")
    assert main(["linearize", "build", str(tmp / "m.toml"), old, "-o", str(tmp / "o.npz")]) == 0
    out, err = capsys.readouterr()
    assert err == "" and "re-zeroed" not in out


@pytest.mark.xdist_group("bias_rig")  # cogging_rig, built once
def test_build_does_not_advise_an_open_contact_to_a_collection_that_read_it_open(
    cogging_rig: dict[str, object], capsys: pytest.CaptureFixture[str]
) -> None:
    # QA bench 305, collected with --bias-open at 40 readings a row: the bias (400 readings a
    # block) lay beyond its noise above a smooth drift at 2 positions (the sensor's bias read
    # where the secondary joint stepped over the target, up to half a step off), and build said
    # "the bias read at rest ... the torque at rest where cogging alone loads the contact ...
    # Collect again with the bias read on an open contact (linearize collect --bias-open)": the
    # collection had. The record says where the bias was read; the warning follows it.
    import json

    from torquemap.linearize.resume import record_path

    tmp: Path = cogging_rig["tmp"]  # type: ignore[assignment]
    write_toml(tmp / "m.toml", motor_to_dict(cogging_rig["spec"]))  # type: ignore[arg-type]
    opened = tmp / "opened.csv"
    opened.write_bytes((tmp / "dFalse.csv").read_bytes())
    record = json.loads(record_path(tmp / "dFalse.csv").read_text())
    record["settings"]["bias_open"] = True
    record_path(opened).write_text(json.dumps(record))
    capsys.readouterr()
    assert (
        main(["linearize", "build", str(tmp / "m.toml"), str(opened), "-o", str(tmp / "x.npz")])
        == 0
    )
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(
        f"torquemap: warning: {opened}: the bias read on"
    )
    assert "--bias-open" not in err and "at rest" not in err and "does not load" in err


@pytest.mark.parametrize(
    ("value", "message"),
    [("x", "column 'bias' is not numeric"), ("nan", "column 'bias' holds NaN or inf")],
)
def test_a_bad_bias_is_one_line_naming_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, message: str
) -> None:
    cols, _, _ = _closed_form(0.3)
    lines = ["position,pulse_width,torque,bias"] + [
        f"{p},{w},{t:.10g},{b:.10g}"
        for p, w, t, b in zip(*cols.values(), strict=True)  # type: ignore[call-overload]
    ]
    lines[5] = lines[5].rpartition(",")[0] + f",{value}"
    (tmp_path / "d.csv").write_text("\n".join(lines) + "\n")
    write_toml(
        tmp_path / "m.toml",
        {"motor": {"name": "m", "phases": 3, "positions_per_cycle": N,
                   "equilibrium_positions": [20, 63, 105], "ramping": "wide"}},
    )  # fmt: skip
    argv = ["linearize", "build", str(tmp_path / "m.toml"), str(tmp_path / "d.csv")]
    assert main([*argv, "-o", str(tmp_path / "t.npz")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "d.csv" in err
    assert not (tmp_path / "t.npz").exists()
    spec = load_motor(tmp_path / "m.toml")
    with pytest.raises(ValueError, match="as long as the rows"):
        build_tables(spec, cols["position"], cols["pulse_width"], cols["torque"], bias=[0.0])
    bias = np.where(np.arange(cols["bias"].size) == 4, np.nan, cols["bias"])
    with pytest.raises(InputError, match=r"d\.csv: bias holds NaN or inf \(data row 5\)"):
        build_tables(
            spec, cols["position"], cols["pulse_width"], cols["torque"], bias=bias,
            path=tmp_path / "d.csv",
        )  # fmt: skip


def test_build_takes_the_bias_weight_from_the_collection_record(tmp_path: Path) -> None:
    """The bias's weight in rows is the record's bias readings over its readings per row
    (written by ``linearize collect``), so a collection with other settings than the default
    ratio of 10 is not misjudged; without a record (or an unreadable one) the default."""
    from torquemap.cli.cmd_linearize import _bias_weight
    from torquemap.linearize.collect import BIAS_READINGS_FACTOR
    from torquemap.linearize.resume import CollectionRecord, record_path, write_record

    data = tmp_path / "data.csv"
    assert _bias_weight(None, str(data)) == BIAS_READINGS_FACTOR
    settings = {"readings": 10, "bias_readings": 30}
    write_record(data, CollectionRecord("characterisation", settings, {}, ()))
    assert _bias_weight(None, str(data)) == 3.0
    assert _bias_weight(7.0, str(data)) == 7.0  # an explicit weight wins
    record_path(data).write_text("{not json")
    assert _bias_weight(None, str(data)) == BIAS_READINGS_FACTOR


def test_build_takes_the_bias_weight_from_an_adaptive_record(tmp_path: Path) -> None:
    """``linearize collect --adaptive`` scales the bias readings with its readings per row and
    notes both in its own record; the build's weight is their ratio."""
    import json

    from torquemap.cli.cmd_linearize import _bias_weight

    data = tmp_path / "data.csv"
    record = {"blocks": [], "bias_open": False, "readings": 4, "bias_readings": 10}
    (tmp_path / "data.csv.adaptive.json").write_text(json.dumps(record))
    assert _bias_weight(None, str(data)) == 2.5


@pytest.mark.xdist_group("bias_rig")
def test_evaluate_says_a_verification_read_at_rest_is_not_the_joints_torque(
    cogging_rig: dict[str, object], restored_tables: TableSet, capsys: pytest.CaptureFixture[str]
) -> None:
    """A verification through tables that restore the load at rest, read with the bias at
    rest, measures the torque above the torque at rest: worse than the same tables verified
    on an open contact (the joint's torque). ``linearize evaluate`` says so, from the
    verification's bias column; on an open contact it is silent."""
    tmp: Path = cogging_rig["tmp"]  # type: ignore[assignment]
    spec: MotorSpec = cogging_rig["spec"]  # type: ignore[assignment]
    tables = restored_tables  # build_tables(..., bias=rest.bias) of the rows read at rest
    save = tmp / "restored.npz"
    save_tables(save, tables)
    write_toml(tmp / "mv.toml", motor_to_dict(spec))
    apmd = {}
    for bias_open in (False, True):
        rig = brushless_dc_rig(rng=11)
        out = tmp / f"verify_{bias_open}.csv"
        settings = dataclasses.replace(SETTINGS, bias_open=bias_open)
        collect_verification(rig, spec, tables.as_mapping(), out, settings)
        data = read_data(out, spec, kind="verification")
        apmd[bias_open] = evaluate_linearity(spec, data, tables=tables).apmd
        args = ["linearize", "evaluate", str(tmp / "mv.toml"), str(out), "--tables", str(save)]
        assert main(args) == 0
        err = capsys.readouterr().err
        said = "the verification's bias read at rest holds" in err
        assert said == (not bias_open), err
    # the reason for the warning: the same tables measured at rest look worse than they are
    assert apmd[False] > apmd[True]
