"""Fleets: the fleet file, identification of every robot-day on Dask, and drift trends.

Identification runs on short 1-DoF logs simulated here in closed form (inverse dynamics of a
known motion), so the fleet's mechanics are tested in seconds; drift is tested on model files
whose parameters follow a known trend plus noise of a known standard error.
"""

from __future__ import annotations

import datetime as dt
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from torquemap.cli.main import main
from torquemap.drift import drift_columns, fleet_drift, trend
from torquemap.errors import InputError
from torquemap.fleet import identify_fleet, read_fleet
from torquemap.io import write_table, write_toml
from torquemap.model import FrictionModel, JointModel, Model, PdtvLine, model_to_dict
from torquemap.robot import robot_from_dict
from torquemap.sim.fleet import MOTOR_ROBOT, motor_sweep_columns
from torquemap.tomlfile import read_toml

ROBOT = MOTOR_ROBOT


@pytest.fixture(scope="module")
def fleet_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two robots, two days each; r02's second day names a missing log."""
    root = tmp_path_factory.mktemp("fleet")
    rng = np.random.default_rng(3)
    robots = []
    for name in ("r01", "r02"):
        (root / name).mkdir()
        write_toml(root / name / "robot.toml", ROBOT)
        days = []
        for d in range(2):
            date = dt.date(2026, 11, 2 + d)
            log = f"{name}/{date.isoformat()}.csv"
            if not (name == "r02" and d == 1):
                write_table(root / log, motor_sweep_columns(rng, coulomb=0.05 + 0.01 * d))
            days.append({"date": date, "logs": [log]})
        robots.append({"name": name, "robot": f"{name}/robot.toml", "days": days})
    write_toml(root / "FLEET.toml", {"robots": robots})
    return root


def test_fleet_identify_every_robot_day(fleet_dir: Path, tmp_path: Path) -> None:
    fleet = read_fleet(fleet_dir / "FLEET.toml")
    run = identify_fleet(fleet, tmp_path / "out", workers=1, processes=False)
    assert [(o.robot, o.date.day, o.ok) for o in run.outcomes] == [
        ("r01", 2, True),
        ("r01", 3, True),
        ("r02", 2, True),
        ("r02", 3, False),
    ]
    # one robot-day fails, the others finish; the reason says where relative paths start
    assert "file not found (a fleet file's paths are relative to its own folder)" in (
        run.failed[0].reason
    )
    # each model holds the identified Coulomb friction of its day (0.05, then 0.06 N m): pass
    # means over ~2000 samples of 5 mN m noise are good to well under 1 mN m
    from torquemap.model import load_model

    for o in run.outcomes[:2]:
        assert o.model_path is not None
        m = load_model(o.model_path)
        expected = 0.05 + 0.01 * (o.date.day - 2)
        assert_allclose(m.joints["m"].friction.linear_parameters()[0], expected, atol=1e-3)
        errors = m.notes["joints"]["m"]["standard_errors"]
        assert 0 < errors["friction.coulomb_positive"] < 1e-3
    assert (tmp_path / "out" / "fleet-run.toml").exists()
    assert not list((tmp_path / "out").rglob(".*.tmp"))  # nothing half-written


def test_fleet_cli_reports_failures(
    fleet_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a log of another robot: r01's log read against a two-joint robot lacks columns
    other = robot_from_dict(
        {
            "robot": {},
            "joints": {
                "m": {"gear_ratio": 1, "torque_constant": 0.1},
                "n": {"gear_ratio": 1, "torque_constant": 0.1},
            },
        }
    )
    from torquemap.robot import robot_to_dict

    write_toml(tmp_path / "two.toml", robot_to_dict(other))
    log = fleet_dir / "r01" / "2026-11-02.csv"
    write_toml(
        tmp_path / "F.toml",
        {
            "robots": [
                {
                    "name": "x",
                    "robot": "two.toml",
                    "days": [{"date": dt.date(2026, 1, 1), "logs": [str(log)]}],
                }
            ]
        },
    )
    status = main(
        ["fleet", "identify", str(tmp_path / "F.toml"), "-o", str(tmp_path / "o"), "--workers", "1"]
    )
    out = capsys.readouterr().out
    assert status == 1  # every robot-day failed
    assert "x 2026-01-01: FAILED:" in out and "missing column 'q_n'" in out


D1, D2 = dt.date(2026, 1, 1), dt.date(2026, 1, 2)


def _day(date: dt.date, *logs: str) -> dict[str, object]:
    return {"date": date, "logs": list(logs)}


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ({"robots": []}, "lists no robots"),
        ({"robots": [{"name": "a b", "robot": "r.toml", "days": []}]}, "name must be"),
        ({"robots": [{"name": "a", "robot": "r.toml"}]}, "has no \\[\\[robots.days\\]\\]"),
        (
            {
                "robots": [
                    {
                        "name": "a",
                        "robot": "r.toml",
                        "days": [{"date": "2026-11-01", "logs": ["x.csv"]}],
                    }
                ]
            },
            "date must be a TOML date",
        ),
        (
            {
                "robots": [
                    {
                        "name": "a",
                        "robot": "r.toml",
                        "days": [{"date": dt.date(2026, 1, 1), "logs": ["x.csv"]}] * 2,
                    }
                ]
            },
            "listed twice",
        ),
        ({"robots": [], "extra": 1}, "unknown key 'extra'"),
        (
            {"robots": [{"name": "a", "robot": "r.toml", "days": [{"date": D1, "log": ["x"]}]}]},
            "unknown key 'log' in a day of robot 'a'",
        ),
        (
            {"robots": [{"name": "a", "robot": "r.toml", "days": [_day(D1, "x.csv", "x.csv")]}]},
            "log 'x.csv' is listed for a 2026-01-01 and again for a 2026-01-01",
        ),
        (
            {
                "robots": [
                    {
                        "name": "a",
                        "robot": "r.toml",
                        "days": [_day(D1, "x.csv"), _day(D2, "y.csv")],
                    },
                    {"name": "b", "robot": "r.toml", "days": [_day(D1, "./z/../y.csv")]},
                ]
            },
            "log './z/../y.csv' is listed for a 2026-01-02 and again for b 2026-01-01",
        ),
    ],
)
def test_bad_fleet_files(tmp_path: Path, doc: dict[str, object], message: str) -> None:
    write_toml(tmp_path / "F.toml", doc)
    with pytest.raises(InputError, match=message):
        read_fleet(tmp_path / "F.toml")


def test_trend_is_weighted_least_squares() -> None:
    # closed form for equal weights: slope = cov(x, y) / var(x), se = sigma / sqrt(Sxx)
    x = np.array([0.0, 1.0, 3.0, 4.0])
    y = np.array([1.0, 2.0, 2.5, 4.5])
    _, slope, se = trend(x, y, np.full(4, 0.5))
    sxx = float(np.sum((x - x.mean()) ** 2))
    assert_allclose(slope, float(np.sum((x - x.mean()) * (y - y.mean()))) / sxx, rtol=1e-12)
    assert_allclose(se, 0.5 / math.sqrt(sxx), rtol=1e-12)


def _drift_folder(tmp_path: Path) -> Path:
    """Eight days of one robot: Coulomb grows 1 mN m/day, a 2 CPR line is steady, a 5 CPR
    line jumps on day 5; noise and stored standard errors are 0.2 mN m."""
    rng = np.random.default_rng(11)
    robot = robot_from_dict(ROBOT)
    days = []
    (tmp_path / "r").mkdir()
    for d in range(8):
        date = dt.date(2026, 1, 1) + dt.timedelta(days=d)
        se = 2e-4
        jm = JointModel(
            friction=FrictionModel(0.05 + 1e-3 * d + rng.normal(0, se), 0.05 + rng.normal(0, se)),
            pdtv=(
                PdtvLine(2.0, 0.02 + rng.normal(0, se), 0.0),
                PdtvLine(5.0, 0.004 + (0.004 if d >= 5 else 0.0) + rng.normal(0, se), 0.0),
            ),
        )
        errors = {
            "friction.coulomb_positive": se,
            "friction.coulomb_negative": se,
            "pdtv.2.amplitude": se,
            "pdtv.5.amplitude": se,
        }
        model = Model(robot, {"m": jm}, {"joints": {"m": {"standard_errors": errors}}})
        write_toml(tmp_path / "r" / f"{date}.toml", model_to_dict(model))
        days.append({"robot": "r", "date": date, "ok": True, "model": f"r/{date}.toml"})
    days.append({"robot": "r", "date": dt.date(2026, 2, 1), "ok": False, "reason": "no log"})
    write_toml(tmp_path / "fleet-run.toml", {"days": days})
    return tmp_path


def test_drift_finds_wear_and_a_step_not_noise(tmp_path: Path) -> None:
    drift = fleet_drift(_drift_folder(tmp_path))
    by = {s.parameter: s for s in drift.series}
    wear = by["friction.coulomb_positive"]
    # the known slope, within 3 of its own standard errors
    assert abs(wear.slope - 1e-3) < 3 * wear.slope_se
    assert wear.flag and wear.sigma_source == "identification"
    assert not by["friction.coulomb_negative"].flag  # noise only
    assert not by["pdtv.2.amplitude"].flag
    assert by["pdtv.5.amplitude"].flag and "jumps" in by["pdtv.5.amplitude"].note
    assert drift.skipped == ("r 2026-02-01: no log",)


def test_drift_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = _drift_folder(tmp_path)
    assert main(["fleet", "drift", str(out), "-o", str(tmp_path / "drift.csv")]) == 0
    text = capsys.readouterr().out
    assert "FLAG r m friction.coulomb_positive" in text
    assert (tmp_path / "drift.csv").read_text().startswith("robot,joint,parameter,")


def test_a_day_whose_log_lost_its_last_line_end_is_warned(fleet_dir: Path, tmp_path: Path) -> None:
    # before: identified with no word about the possibly cut last row (identify itself warned)
    text = (fleet_dir / "r01" / "2026-11-02.csv").read_bytes()
    (tmp_path / "cut.csv").write_bytes(text[:-2])
    (tmp_path / "whole.csv").write_bytes(text)
    write_toml(tmp_path / "robot.toml", ROBOT)
    days = [
        {"date": dt.date(2026, 1, 1 + k), "logs": [name]}
        for k, name in enumerate(("cut.csv", "whole.csv"))
    ]
    write_toml(
        tmp_path / "F.toml", {"robots": [{"name": "x", "robot": "robot.toml", "days": days}]}
    )
    run = identify_fleet(
        read_fleet(tmp_path / "F.toml"), tmp_path / "o", workers=1, processes=False
    )
    cut, whole = run.outcomes
    assert cut.ok and any("cut.csv: the last line has no line end" in w for w in cut.warnings)
    assert whole.ok and not any("line end" in w for w in whole.warnings)


def test_a_taken_dashboard_port_does_not_stop_the_fleet(fleet_dir: Path, tmp_path: Path) -> None:
    # before: with port 8787 taken (a user's own Dask, or another fleet run at the same time),
    # the local cluster warned and, warnings being errors under pytest, failed to start
    import socket

    with socket.socket() as taken:
        try:
            taken.bind(("0.0.0.0", 8787))
        except OSError:
            pass  # already taken by someone else: the case itself
        taken.listen()
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            run = identify_fleet(
                read_fleet(fleet_dir / "FLEET.toml"), tmp_path / "o", workers=1, processes=False
            )
    assert [o.ok for o in run.outcomes] == [True, True, True, False]


def test_two_days_are_a_change_against_their_errors(tmp_path: Path) -> None:
    """Two days whose models hold standard errors: the trend is their difference and its
    standard error the two errors combined (closed form); a robot with one day is listed."""
    robot = robot_from_dict(ROBOT)
    (tmp_path / "r").mkdir()
    (tmp_path / "s").mkdir()
    se = 2e-4
    values = (0.050, 0.052)  # a change of 2 mN m: 7.1 combined standard errors
    days = []
    for name, count in (("r", 2), ("s", 1)):
        for d in range(count):
            date = dt.date(2026, 1, 1) + dt.timedelta(days=3 * d)
            jm = JointModel(friction=FrictionModel(values[d], 0.05))
            errors = {"friction.coulomb_positive": se, "friction.coulomb_negative": se}
            model = Model(robot, {"m": jm}, {"joints": {"m": {"standard_errors": errors}}})
            write_toml(tmp_path / name / f"{date}.toml", model_to_dict(model))
            days.append({"robot": name, "date": date, "ok": True, "model": f"{name}/{date}.toml"})
    write_toml(tmp_path / "fleet-run.toml", {"days": days})
    drift = fleet_drift(tmp_path)
    by = {s.parameter: s for s in drift.series}
    wear = by["friction.coulomb_positive"]
    assert_allclose(wear.change, values[1] - values[0], rtol=1e-9)
    assert_allclose(wear.change_se, math.hypot(se, se), rtol=1e-9)
    assert_allclose(wear.slope, (values[1] - values[0]) / 3.0, rtol=1e-9)
    assert wear.flag and not by["friction.coulomb_negative"].flag
    assert {s.robot for s in drift.series} == {"r"}
    assert drift.too_few == ("s: 1 identified day",)


def test_steady_robots_are_not_flagged_on_one_dof_standard_errors(tmp_path: Path) -> None:
    """Twenty robots, four days, no drift: the values scatter by 0.2 mN m and each day's stored
    standard error is that of a fit with one degree of freedom (0.2 mN m x |N(0, 1)|, as a daily
    sweep of two speeds gives). A day whose error happens to be tiny must not flag its robot."""
    rng = np.random.default_rng(5)
    robot = robot_from_dict(ROBOT)
    sd = 2e-4
    days = []
    for r in range(20):
        name = f"r{r:02d}"
        (tmp_path / name).mkdir()
        for d in range(4):
            date = dt.date(2026, 1, 1) + dt.timedelta(days=d)
            jm = JointModel(
                friction=FrictionModel(0.05 + rng.normal(0, sd), 0.05 + rng.normal(0, sd)),
                pdtv=(),
            )
            errors = {
                "friction.coulomb_positive": sd * abs(rng.normal()),
                "friction.coulomb_negative": sd * abs(rng.normal()),
            }
            model = Model(robot, {"m": jm}, {"joints": {"m": {"standard_errors": errors}}})
            write_toml(tmp_path / name / f"{date}.toml", model_to_dict(model))
            days.append({"robot": name, "date": date, "ok": True, "model": f"{name}/{date}.toml"})
    write_toml(tmp_path / "fleet-run.toml", {"days": days})
    drift = fleet_drift(tmp_path)
    assert len(drift.series) == 40
    # 0.3 % two-sided per series: none expected of 40; one allowed
    assert len(drift.flagged) <= 1, [s.note for s in drift.flagged]


def test_steady_wear_is_a_trend_not_a_jump(tmp_path: Path) -> None:
    """A line that grows by 5 standard errors a day, every day, is flagged as a change; no day
    of it is a jump (each day is where the days before it point)."""
    robot = robot_from_dict(ROBOT)
    se = 2e-4
    days = []
    (tmp_path / "r").mkdir()
    for d in range(6):
        date = dt.date(2026, 1, 1) + dt.timedelta(days=d)
        jm = JointModel(friction=FrictionModel(0.05 + 1e-3 * d, 0.05), pdtv=())
        errors = {"friction.coulomb_positive": se, "friction.coulomb_negative": se}
        model = Model(robot, {"m": jm}, {"joints": {"m": {"standard_errors": errors}}})
        write_toml(tmp_path / "r" / f"{date}.toml", model_to_dict(model))
        days.append({"robot": "r", "date": date, "ok": True, "model": f"r/{date}.toml"})
    write_toml(tmp_path / "fleet-run.toml", {"days": days})
    wear = {s.parameter: s for s in fleet_drift(tmp_path).series}["friction.coulomb_positive"]
    assert wear.flag and "changes" in wear.note
    assert "jumps" not in wear.note


def test_a_stopped_run_leaves_no_record_and_a_failed_day_no_stale_model(
    fleet_dir: Path, tmp_path: Path
) -> None:
    """OUT holds an earlier run (its record, and a model for the day that now fails): a run
    stopped after its first model leaves no record for `fleet drift` to read against models it
    partly rewrote; a finished run removes the model of the day that failed."""
    out = tmp_path / "out"
    (out / "r02").mkdir(parents=True)
    stale = out / "r02" / "2026-11-03.toml"
    stale.write_text("# an earlier fleet's model\n")
    write_toml(out / "fleet-run.toml", {"days": [{"robot": "r02", "date": "x", "ok": True}]})

    def stop(*_: object) -> None:
        raise KeyboardInterrupt

    fleet = read_fleet(fleet_dir / "FLEET.toml")
    with pytest.raises(KeyboardInterrupt):
        identify_fleet(fleet, out, workers=1, processes=False, progress=stop)
    assert not (out / "fleet-run.toml").exists()
    with pytest.raises(InputError, match=r"no fleet-run\.toml: .* did not finish"):
        fleet_drift(out)
    run = identify_fleet(fleet, out, workers=1, processes=False)
    assert [o.ok for o in run.outcomes] == [True, True, True, False]
    assert not stale.exists()
    assert (out / "fleet-run.toml").exists()


def test_a_failed_day_whose_log_was_cut_says_so(tmp_path: Path) -> None:
    """A log copied while being written ends inside a line; the day fails (too short), and its
    reason names the cut, the likely cause, not only the symptom."""
    write_toml(tmp_path / "robot.toml", ROBOT)
    (tmp_path / "cut.csv").write_text("t,q_m,i_m\n0,0,0.1\n0.001,0,0.1\n0.002,0.0")
    write_toml(
        tmp_path / "F.toml",
        {"robots": [{"name": "a", "robot": "robot.toml", "days": [_day(D1, "cut.csv")]}]},
    )
    run = identify_fleet(
        read_fleet(tmp_path / "F.toml"), tmp_path / "o", workers=1, processes=False
    )
    (outcome,) = run.outcomes
    assert not outcome.ok
    assert "cut.csv: the last line has no line end" in outcome.reason
    assert "\n" not in outcome.reason


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"window": -1.0}, "window must be a positive number"),
        ({"window": math.nan}, "window must be a positive number"),
        ({"scheduler": "nonsense"}, "cannot reach the Dask scheduler 'nonsense'"),
    ],
)
def test_bad_run_options_leave_the_output_folder_as_it_was(
    fleet_dir: Path, tmp_path: Path, kwargs: dict[str, object], message: str
) -> None:
    """A negative window failed every robot-day one by one; a scheduler address without a port
    was a traceback; neither may remove the record of the run already in OUT."""
    out = tmp_path / "out"
    out.mkdir()
    write_toml(out / "fleet-run.toml", {"days": []})
    with pytest.raises(InputError, match=message):
        identify_fleet(read_fleet(fleet_dir / "FLEET.toml"), out, workers=1, **kwargs)  # type: ignore[arg-type]
    assert (out / "fleet-run.toml").exists()


def test_drift_names_a_malformed_run_record(tmp_path: Path) -> None:
    write_toml(tmp_path / "fleet-run.toml", {"days": [{"robot": "r", "date": D1, "ok": True}]})
    with pytest.raises(InputError, match=r"fleet-run\.toml: \[\[days\]\] #1 needs robot, date"):
        fleet_drift(tmp_path)


def test_a_day_of_another_robot_is_flagged_not_averaged_away(tmp_path: Path) -> None:
    """Three days of a robot whose Coulomb friction grows 5 standard errors a day, the middle
    day identified from another robot's log (10 % higher): its scatter inflated every error by
    Birge's ratio until the wear no longer showed, and the middle of three days escapes the step
    test; the series is flagged, naming the scatter."""
    robot = robot_from_dict(ROBOT)
    se = 2e-4
    days = []
    (tmp_path / "r").mkdir()
    for d in range(3):
        date = dt.date(2026, 1, 1) + dt.timedelta(days=d)
        value = 0.05 + 1e-3 * d + (0.005 if d == 1 else 0.0)
        jm = JointModel(friction=FrictionModel(value, value), pdtv=())
        errors = {"friction.coulomb_positive": se, "friction.coulomb_negative": se}
        model = Model(robot, {"m": jm}, {"joints": {"m": {"standard_errors": errors}}})
        write_toml(tmp_path / "r" / f"{date}.toml", model_to_dict(model))
        days.append({"robot": "r", "date": date, "ok": True, "model": f"r/{date}.toml"})
    write_toml(tmp_path / "fleet-run.toml", {"days": days})
    series = {s.parameter: s for s in fleet_drift(tmp_path).series}
    odd = series["friction.coulomb_positive"]
    assert odd.flag and "scatter" in odd.note and "another robot" in odd.note


def test_local_workers_start_with_ctrl_c_ignored() -> None:
    """Ctrl-C reaches every process of the terminal's group: the local cluster's worker processes
    are started with SIGINT ignored (each printed a traceback), the parent's handler is back
    afterwards (it stops the run and closes the cluster: `torquemap: interrupted`)."""
    import signal

    from torquemap.fleet import _workers_ignore_ctrl_c

    before = signal.getsignal(signal.SIGINT)
    with _workers_ignore_ctrl_c():
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    assert signal.getsignal(signal.SIGINT) is before


def _lines_folder(tmp_path: Path, days_lines: list[list[tuple[float, float]]]) -> Path:
    """One robot, one day per entry of ``days_lines`` (its PDTV lines as (order, amplitude)),
    steady friction; every stored standard error 0.2 mN m."""
    robot = robot_from_dict(ROBOT)
    se = 2e-4
    (tmp_path / "r").mkdir()
    days = []
    for d, lines in enumerate(days_lines):
        date = dt.date(2026, 1, 1) + dt.timedelta(days=d)
        jm = JointModel(
            friction=FrictionModel(0.05, 0.05),
            pdtv=tuple(PdtvLine(order, amp, 0.0) for order, amp in lines),
        )
        errors = {"friction.coulomb_positive": se, "friction.coulomb_negative": se}
        errors |= {f"pdtv.{order:g}.amplitude": se for order, _ in lines}
        model = Model(robot, {"m": jm}, {"joints": {"m": {"standard_errors": errors}}})
        write_toml(tmp_path / "r" / f"{date}.toml", model_to_dict(model))
        days.append({"robot": "r", "date": date, "ok": True, "model": f"r/{date}.toml"})
    write_toml(tmp_path / "fleet-run.toml", {"days": days})
    return tmp_path


def test_a_line_found_only_on_the_last_day_is_flagged_as_appearing(tmp_path: Path) -> None:
    """A worn tooth: a 7 CPR line of 30 standard errors on the last of five days, none before.
    On one day it cannot make a trend, but the line search would have found a line that strong
    on the other days: it appears."""
    base = [(2.0, 0.02)]
    drift = fleet_drift(_lines_folder(tmp_path, [base] * 4 + [[*base, (7.0, 0.006)]]))
    by = {s.parameter: s for s in drift.series}
    new = by["pdtv.7.amplitude"]
    assert new.flag and "appears on 2026-01-05" in new.note, new.note
    assert_allclose(new.values, [0, 0, 0, 0, 0.006])
    assert not by["pdtv.2.amplitude"].flag
    assert not drift.too_few


def test_a_strong_line_that_vanishes_or_skips_a_day_is_flagged(tmp_path: Path) -> None:
    gone = [[(2.0, 0.02), (5.0, 0.01)]] * 3 + [[(2.0, 0.02)]] * 2
    drift = fleet_drift(_lines_folder(tmp_path, gone))
    s = {x.parameter: x for x in drift.series}["pdtv.5.amplitude"]
    assert s.flag and "not found from 2026-01-04 on" in s.note, s.note


def test_a_weak_or_shifted_line_is_not_a_new_line(tmp_path: Path) -> None:
    """A line of 3 standard errors that the search finds on some days only comes and goes
    with the noise; a strong fractional line placed at 7.5 then 7.55 CPR is the same line."""
    days = [
        [(2.0, 0.02), (3.0, 6e-4), (7.5, 0.01)],
        [(2.0, 0.02), (7.55, 0.01)],
        [(2.0, 0.02), (3.0, 6e-4), (7.5, 0.01)],
        [(2.0, 0.02), (7.5, 0.01)],
    ]
    drift = fleet_drift(_lines_folder(tmp_path, days))
    assert not drift.flagged, [(s.parameter, s.note) for s in drift.flagged]


def _with_pdtv_speeds(folder: Path, speeds: list[float]) -> Path:
    """Every day's model of :func:`_lines_folder` as identified from PDTV passes at ``speeds``."""
    for path in sorted((folder / "r").glob("*.toml")):
        doc = read_toml(path)
        doc["identification"]["joints"]["m"]["pdtv_speeds"] = speeds
        write_toml(path, doc)
    return folder


def test_a_line_from_passes_at_one_speed_may_be_a_ripple_in_time(tmp_path: Path) -> None:
    """The SCARA fleet's daily sweeps take PDTV from 5 rad/s passes only: the bench's 300 Hz
    inverter ripple sits at 377 CPR there, is kept on some days and not on others, and was
    flagged as a line appearing with no word that it may be no line of the motor angle
    (docs/fleet.md). The flag stays; its note names the ripple's frequency in time,
    377 * 5 / (2 pi) = 300.0 Hz, and the way to tell. Passes at two speeds: no such note."""
    base = [(2.0, 0.02)]
    days = [base] * 3 + [[*base, (377.0, 0.006)]]
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    one = fleet_drift(_with_pdtv_speeds(_lines_folder(tmp_path / "one", days), [5.0, -5.0]))
    s = {x.parameter: x for x in one.series}["pdtv.377.amplitude"]
    assert s.flag and "appears on 2026-01-04" in s.note, s.note
    assert "one speed (5 rad/s)" in s.note and "300 Hz in time" in s.note, s.note
    assert not {x.parameter: x for x in one.series}["pdtv.2.amplitude"].flag
    write_table(tmp_path / "drift.csv", drift_columns(one))  # the note is one CSV field
    two = fleet_drift(_with_pdtv_speeds(_lines_folder(tmp_path / "two", days), [3.0, 5.0]))
    s2 = {x.parameter: x for x in two.series}["pdtv.377.amplitude"]
    assert s2.flag and "appears on 2026-01-04" in s2.note and "one speed" not in s2.note
