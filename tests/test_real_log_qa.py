"""A new user's loop on real logs, broken as loggers break them (new-user QA, stop 39;
docs/safety.md, "Real-log QA").

Each test builds its log here, small and seeded, and asserts one independent fact: the exact
refusal or warning, or that a clean log draws none.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from torquemap.errors import InputError
from torquemap.identify import Identification, identify_model
from torquemap.io import log_from_columns
from torquemap.robot import Joint, Robot

#: One motor, no gear, 0.1 N m/A.
ONE = Robot(name="m", kinematics="none", link_lengths=(), joints=(Joint("m", 1.0, 0.1),))


def _sweep(
    speeds: tuple[float, ...] = (2.0, -2.0, 5.0, -5.0), seed: int = 0
) -> dict[str, np.ndarray]:
    """No-load sweeps at 1 kHz, two motor turns a pass: friction 20 mN m + 1 mN m s/rad, a
    3 CPR line of 5 mN m, inertia 2e-4 kg m^2, noise 0.5 mN m; current in A."""
    rate = 1000.0
    rng = np.random.default_rng(seed)
    v = [np.zeros(200)]
    for s in speeds:
        ramp = np.linspace(0.0, s, 200)
        v += [ramp, np.full(int(4 * math.pi / abs(s) * rate), s), ramp[::-1], np.zeros(200)]
    w = np.concatenate(v)
    t = np.arange(w.size) / rate
    angle = np.cumsum(w) / rate
    tau = 2e-4 * np.gradient(w, t) + np.tanh(w / 0.05) * (0.02 + 0.001 * np.abs(w))
    tau += 0.005 * np.sin(3 * angle) + 0.0005 * rng.standard_normal(w.size)
    return {"t": t, "q_m": angle, "i_m": tau / 0.1}


def _identify(cols: dict[str, np.ndarray]) -> tuple[str, ...]:
    return identify_model(ONE, [log_from_columns(cols, ONE, path="sweep.csv")]).warnings


@pytest.fixture(scope="module")
def clean() -> Identification:
    """``identify_model`` of the clean sweep (``_sweep()``), which four tests read (each
    identified it alike before)."""
    return identify_model(ONE, [log_from_columns(_sweep(), ONE, path="sweep.csv")])


def test_a_clean_sweep_draws_no_sign_or_unit_warning(clean: Identification) -> None:
    assert not [w for w in clean.warnings if "opposes" in w or " A in the median" in w]


def test_a_current_of_the_wrong_sign_is_refused() -> None:
    # Before (stop 39): exit 0, friction held at 0 and a warning blaming a load; the paper
    # bench's sweep with i_a negated gave forces of 68 N median on the 3.5 N circle, and the
    # real ODrive sweep negated an anti-cogging map correlating -0.976 with the measured one.
    cols = _sweep()
    cols["i_m"] = -cols["i_m"]
    with pytest.raises(
        InputError,
        match=(
            r"^sweep.csv: joint m: in every steady pass of the no-load sweeps the motor torque "
            r"has the sign of the motion's opposite \(-0.02\d+ N m at \+3.5 rad/s, \+0.02\d+ N "
            r"m at -3.5 rad/s in the median\): .* negate i_m"
        ),
    ):
        _identify(cols)


def test_a_constant_load_larger_than_friction_is_not_taken_for_a_wrong_sign() -> None:
    # 30 mN m pulling positive: the negative passes' torque has the motion's sign (+10 mN m
    # against -5 rad/s), the positive passes' does not; a load cannot flip both directions.
    cols = _sweep()
    cols["i_m"] = cols["i_m"] + 0.03 / 0.1
    assert not [w for w in _identify(cols) if "opposes" in w]


def test_a_one_way_sweep_of_the_wrong_sign_is_warned() -> None:
    # One direction only: a load driving the joint looks alike, so a warning, not a refusal.
    cols = _sweep((2.0, 5.0))
    cols["i_m"] = -cols["i_m"]
    said = [w for w in _identify(cols) if "opposes the motion" in w]
    assert len(said) == 1
    assert said[0].startswith("sweep.csv: joint m: in every steady pass the motor torque opposes")
    assert "negate i_m" in said[0]


def test_a_current_in_milliamperes_is_warned(clean: Identification) -> None:
    # Before (stop 39): the real ODrive sweep in mA identified 13 N m of friction on a
    # 0.04 N m/A hobby motor, no word; its median pass needs 0.2 A here, 200 in mA.
    cols = _sweep()
    assert not [w for w in clean.warnings if " A in the median" in w]  # _identify(cols)
    cols["i_m"] = cols["i_m"] * 1000.0
    said = [w for w in _identify(cols) if " A in the median" in w]
    assert len(said) == 1
    assert "is i_m in mA (or tau_m in N mm)?" in said[0]


def _model_document(**joint: object) -> dict[str, object]:
    spec = {"gear_ratio": 1.0, "torque_constant": 0.04, **joint}
    return {
        "robot": {"kinematics": "none"},
        "joints": {"a": spec},
        "identification": {"joints": {"a": {"passes": 1, "friction_fit": "whole"}}},
    }


@pytest.mark.parametrize("table", ["friction", "inertia"])
def test_a_model_missing_an_identified_table_is_refused(table: str) -> None:
    # Before (stop 39): the real ODrive sweep's model with [joints.a.friction] deleted gave
    # exit 0, every sample sound, tau_ext_a off by the friction (RMS 13.4 mN m, 1.7 clean).
    from torquemap.model import model_from_dict

    tables = {
        "friction": {"coulomb_positive": 0.013, "coulomb_negative": 0.013},
        "inertia": {"constant": 1e-5},
    }
    model_from_dict(_model_document(**tables), path="model.toml")  # whole: fine
    del tables[table]
    with pytest.raises(
        InputError,
        match=(
            rf"^model.toml: \[joints.a.{table}\] missing, though \[identification.joints.a\] "
            r"says the joint was identified: deleted or renamed by hand\?"
        ),
    ):
        model_from_dict(_model_document(**tables), path="model.toml")
    # a robot file as a model, or a joint identification never moved, reads as no friction
    document = _model_document()
    del document["identification"]
    assert model_from_dict(document).joints["a"].friction.torque(1.0) == 0.0
    document = _model_document()
    document["identification"] = {"joints": {"a": {"passes": 0, "friction_fit": "passes"}}}
    assert model_from_dict(document).joints["a"].friction.torque(1.0) == 0.0


@pytest.mark.parametrize(
    ("names", "says"),
    [
        # before: "the log's joints (a_deg) are not the robot's (a): a log from another robot?"
        (("t", "q_m_deg", "i_m"), r"missing column 'q_m' \(the file has 'q_m_deg': .*; its values in deg must be in rad too\)"),
        # before: "... (the file has t, q_m, i_m_mA)"
        (("t", "q_m", "i_m_mA"), r"missing column 'i_m' or 'tau_m' .*'i_m_mA': .*; its values in mA must be in A too\)"),
        (("t_ms", "q_m", "i_m"), r"missing column 't' \(the file has 't_ms': .*; its values in ms must be in s too\)"),
        # before: "(the file has 't [ms]': names are exact, lower case, no unit)" alone
        (("t [ms]", "q_m", "i_m"), r"'t \[ms\]': names are exact, lower case, no unit; its values in ms must be in s too\)"),
        (("t", "q_m [rad]", "i_m"), r"'q_m \[rad\]': names are exact, lower case, no unit\)$"),
    ],
)  # fmt: skip
def test_a_unit_in_a_column_name_is_named(names: tuple[str, ...], says: str) -> None:
    cols = _sweep()
    renamed = dict(zip(names, (cols["t"], cols["q_m"], cols["i_m"]), strict=True))
    with pytest.raises(InputError, match=says):
        log_from_columns(renamed, ONE, path="sweep.csv")


def test_a_torque_constant_edited_after_identification_is_refused(clean: Identification) -> None:
    # Before (stop 39): the ODrive model with torque_constant 0.04 -> 0.4 by hand gave exit 0,
    # tau_ext_a RMS 0.28 N m on its own sweep (1.7 mN m as identified), no word.
    from torquemap.model import model_from_dict, model_to_dict

    model = clean.model
    document = model_to_dict(model)
    assert document["identification"]["joints"]["m"]["torque_constant"] == 0.1
    model_from_dict(document, path="model.toml")  # as written: fine
    document["joints"]["m"]["torque_constant"] = 0.4
    with pytest.raises(
        InputError,
        match=(
            r"^model.toml: \[joints.m\] torque_constant 0.4 N m/A is not the 0.1 N m/A "
            r"identification read the currents with .* read 4 times as large; identify again"
        ),
    ):
        model_from_dict(document, path="model.toml")
    del document["identification"]["joints"]["m"]["torque_constant"]  # a model of before
    assert model_from_dict(document).robot.joints[0].torque_constant == 0.4


def test_two_logs_joined_in_one_file_are_named(tmp_path: Path) -> None:
    # Before (stop 39): "time 't' goes backwards (at data row 14733)" alone for the ODrive sweep
    # appended to itself.
    from torquemap.io import read_log, write_table

    cols = _sweep()
    n = cols["t"].size
    joined = {k: np.concatenate([v, v]) for k, v in cols.items()}
    p = tmp_path / "joined.csv"
    write_table(p, joined)
    with pytest.raises(
        InputError,
        match=(
            rf"goes backwards \(at data row {n + 1}\): t falls by [\d.]+ s \(from [\d.]+ to 0\) "
            rf"once and runs on: two logs joined .* split it before data row {n + 1} into two logs"
        ),
    ):
        read_log(p, ONE)


@pytest.mark.parametrize(
    ("table", "listed"),
    [
        # before (stop 39): "(allowed: viscous, viscous_negative, zero_velocity)"
        (
            {
                "kind": "speed-table",
                "speeds": [1.0, 2.0],
                "positive": [0.01, 0.01],
                "negative": [0.01, 0.01],
            },
            "kind, negative, positive, speeds, viscous, viscous_negative, zero_velocity",
        ),
        ({"coulomb_positive": 0.01}, "coulomb_negative, coulomb_positive, kind,"),
    ],
)
def test_an_unknown_friction_key_lists_every_key_the_table_may_hold(
    table: dict[str, object], listed: str
) -> None:
    from torquemap.friction_law import friction_law_from_dict

    friction_law_from_dict(table)  # as written: fine
    with pytest.raises(
        InputError, match=rf"^m.toml: unknown key 'foo' in \[f\] \(allowed: {listed}"
    ):
        friction_law_from_dict({**table, "foo": 1.0}, where="[f]", path="m.toml")


def test_raw_counts_in_a_robot_file_that_says_rad_are_named() -> None:
    # Before (stop 39): the real ODrive sweep in whole counts under position_unit = "rad"
    # was identified at 2130 rad/s with its cogging at 0.0054 CPR (7 / 1304), exit 0.
    rad = Robot(
        name="m", kinematics="none", link_lengths=(), joints=(Joint("m", 1.0, 0.1, 8192, "rad"),)
    )
    cols = _sweep()
    cols["q_m"] = np.round(cols["q_m"] * 8192 / (2 * math.pi))
    with pytest.raises(
        InputError,
        match=(
            r"^sweep.csv: joint m: the log's angle moves in steps of 1304 encoder counts of the "
            r"robot file \(8192 per motor turn, 1:1\): q_m holds encoder counts, not rad: set "
            r"position_unit = 'counts' in the robot file$"
        ),
    ):
        identify_model(rad, [log_from_columns(cols, rad, path="sweep.csv")])
    cols["q_m"] = cols["q_m"] * (2 * math.pi / 8192)  # the same counts in rad: identified
    identify_model(rad, [log_from_columns(cols, rad, path="sweep.csv")])


def test_unix_seconds_written_with_too_few_digits_are_named() -> None:
    # Before (stop 39): Unix seconds through "%.10g" (whole seconds) were refused with "no
    # stretch of the log between gaps ... record without gaps longer than 0.125 s" alone.
    cols = _sweep()
    cols["t"] = np.array([float(f"{1_764_300_000.0 + x:.10g}") for x in cols["t"]])
    with pytest.raises(
        InputError,
        match=(
            r"^sweep.csv: no stretch of the log .* \(t repeats the previous stamp on 9\d.\d% of "
            r"its steps and advances in steps of 1 s: 't' was written with too few digits; "
            r"write t with all its digits"
        ),
    ):
        _identify(cols)


def test_a_burst_of_missed_reads_says_what_to_do(tmp_path: Path) -> None:
    # Before (stop 39): "column 'q_m' holds NaN or inf (first at data row 1001)" alone; the
    # rows deleted, the gap they leave is cut and flagged (checked here too).
    from torquemap.io import iter_log_chunks, read_log, write_table

    cols = _sweep()
    cols["q_m"] = cols["q_m"].copy()
    cols["q_m"][1000:1200] = np.nan
    said = (
        r"column 'q_m' holds NaN or inf \(first at data row 1001, 200 rows in all\): empty "
        r"cells or a logger's missed reads\? delete those rows \(a gap in time is cut and "
        r"flagged, not refused\)$"
    )
    p = tmp_path / "log.csv"
    write_table(p, cols)
    with pytest.raises(InputError, match=said):
        read_log(p, ONE)
    q = tmp_path / "log.parquet"  # estimate's block reader: the same words
    write_table(q, cols)
    with pytest.raises(InputError, match=said):
        list(iter_log_chunks(q, ONE, rows=700))
    keep = np.isfinite(cols["q_m"])
    log = log_from_columns({k: v[keep] for k, v in cols.items()}, ONE)
    from torquemap.sanitize import sanitize_log

    assert len(sanitize_log(log, window=0.05).pieces) == 2  # cut at the 0.2 s gap


def test_a_log_too_short_without_a_gap_is_not_told_to_avoid_gaps() -> None:
    # Before (stop 39): a 0.149 s free-motion log of a two-link arm (identification asks 4
    # windows) was told "record without gaps longer than 0.125 s"; it holds no gap.
    from torquemap.sanitize import no_stretch_message

    said = no_stretch_message(np.arange(150) * 1e-3, 0.05)
    assert said == (
        "no stretch of the log between gaps in time lasts the 0.05 s differentiator window: "
        "the log lasts 0.149 s in all, without a gap; record a longer motion"
    )
    gapped = np.r_[np.arange(40) * 1e-3, 1.0 + np.arange(40) * 1e-3]  # 1 s gap: as before
    assert no_stretch_message(gapped, 0.05).endswith("record without gaps longer than 0.125 s")


def test_degrees_under_a_robot_file_in_rad_show_a_sub_revolution_line(
    clean: Identification,
) -> None:
    # Before (stop 39): the real ODrive sweep in degrees (fractional counts: no whole-count
    # test applies) under position_unit = "rad" gave exit 0, its 7 CPR cogging at 0.123 CPR.
    said = "its strongest PDTV line sits at"
    cols = _sweep()
    assert not [w for w in clean.warnings if said in w]  # _identify(cols)
    cols["q_m"] = np.degrees(cols["q_m"])
    found = [w for w in _identify(cols) if said in w]
    assert len(found) == 1
    assert found[0].startswith("joint m: its strongest PDTV line sits at 0.052")  # 3 pi / 180
    assert "is q_m in the unit the robot file says (rad; degrees read as rad" in found[0]
