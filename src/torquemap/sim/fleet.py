"""A simulated fleet: SCARA benches whose friction and PDTV drift with use, day after day.

Every robot is the SCARA bench with its own friction levels and PDTV amplitudes (drawn around
the default bench's), and every day it records a short no-load sweep. With use, Coulomb friction
grows (wear) at a rate of its own per robot, the viscous term falls or rises (lubrication), and
on some robots one PDTV line grows from a given day on (a loosening belt, a worn tooth). The
truth, per robot and day, is written to ``truth.toml`` for tests and benchmarks only.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from torquemap.errors import InputError
from torquemap.sim.bench import _log_columns, robot_document, simulate_sweep
from torquemap.sim.scara import Axis, Harmonic, ScaraBench, default_bench

#: Largest fleet the simulator writes (robots x days): a guard against typos, not a limit of
#: the fleet commands.
MAX_ROBOT_DAYS = 10_000


@dataclass(frozen=True, slots=True, eq=False)
class RobotWear:
    """How one simulated robot changes with use.

    Attributes
    ----------
    coulomb_rate
        Relative growth of Coulomb friction per day [1/day].
    viscous_rate
        Relative change of viscous friction per day [1/day].
    belt_day
        Day from which one PDTV line grows (-1: never).
    belt_axis, belt_order
        Which axis and line.
    belt_rate
        Its amplitude's growth per day after ``belt_day`` [N m/day].
    """

    coulomb_rate: float
    viscous_rate: float
    belt_day: int
    belt_axis: int
    belt_order: float
    belt_rate: float


def _short_sweep(bench: ScaraBench) -> ScaraBench:
    # A daily check: two speeds per axis, two revolutions per pass (about 20 s of log).
    sweep = dataclasses.replace(
        bench.sweep,
        speeds=(5.0, 15.0),
        revolutions=2.0,
        elbow_angles=(0.6, 1.6),
        fast_speeds=0,
    )
    return dataclasses.replace(bench, sweep=sweep)


def _scaled_axis(axis: Axis, rng: np.random.Generator) -> Axis:
    f = axis.friction
    scale = float(rng.uniform(0.7, 1.4))
    friction = dataclasses.replace(
        f,
        coulomb_positive=f.coulomb_positive * scale,
        coulomb_negative=f.coulomb_negative * scale,
        viscous=f.viscous * float(rng.uniform(0.7, 1.4)),
    )
    pdtv = tuple(
        dataclasses.replace(h, amplitude=h.amplitude * float(rng.uniform(0.6, 1.5)))
        for h in axis.pdtv
    )
    return dataclasses.replace(axis, friction=friction, pdtv=pdtv)


def robot_on_day(base: ScaraBench, wear: RobotWear, day: int) -> ScaraBench:
    """The bench as it is after ``day`` days of use."""
    axes = []
    for k, axis in enumerate(base.axes):
        f = axis.friction
        grow = 1.0 + wear.coulomb_rate * day
        friction = dataclasses.replace(
            f,
            coulomb_positive=f.coulomb_positive * grow,
            coulomb_negative=f.coulomb_negative * grow,
            viscous=f.viscous * max(0.0, 1.0 + wear.viscous_rate * day),
        )
        pdtv: tuple[Harmonic, ...] = axis.pdtv
        if 0 <= wear.belt_day <= day and k == wear.belt_axis:
            extra = wear.belt_rate * (day - wear.belt_day + 1)
            pdtv = tuple(
                dataclasses.replace(h, amplitude=h.amplitude + extra)
                if h.order == wear.belt_order
                else h
                for h in pdtv
            )
        axes.append(dataclasses.replace(axis, friction=friction, pdtv=pdtv))
    return dataclasses.replace(base, axes=(axes[0], axes[1]))


MOTOR_ROBOT = {
    "robot": {"name": "motor on a bench", "kinematics": "none"},
    "joints": {"m": {"gear_ratio": 1.0, "torque_constant": 0.1, "encoder_counts_per_rev": 8000}},
}
"""The robot file of :func:`motor_sweep_columns`: one direct-drive motor, 8000 counts/rev."""


def motor_sweep_columns(
    rng: np.random.Generator,
    *,
    coulomb: float = 0.05,
    viscous: float = 0.004,
    line_amplitude: float = 0.02,
    noise: float = 0.005,
) -> dict[str, np.ndarray]:
    """A short no-load sweep of one direct-drive motor, by inverse dynamics of a known motion.

    Back-and-forth passes at 4 and 8 rad/s (two revolutions each, raised-cosine ramps of
    0.2 s), logged at 1 kHz: torque = 2e-4 kg m^2 x acceleration + symmetric Coulomb and
    viscous friction + a 2 CPR line while moving, plus white noise [N m]; the angle is
    quantised to 8000 counts per revolution. Columns ``t``, ``q_m``, ``i_m`` (0.1 N m/A).
    About 6 s of log: cheap enough for fleets of hundreds of robot-days.
    """
    rate, ramp = 1000.0, 0.2
    h = 1.0 / rate
    vel: list[np.ndarray] = [np.zeros(150)]
    for v in (4.0, 8.0):
        for s in (1, -1):
            tr = np.arange(0.0, ramp, h)
            up = 0.5 * (1 - np.cos(np.pi * tr / ramp)) * v * s
            vel += [up, np.full(int(2 * 2 * np.pi / v * rate), v * s), up[::-1], np.zeros(150)]
    w = np.concatenate(vel)
    t = np.arange(w.size) * h
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * h)))
    friction = coulomb * np.sign(w) + viscous * w
    moving = np.abs(w) > 1e-9
    tau = 2e-4 * np.gradient(w, h) + np.where(
        moving, friction + line_amplitude * np.cos(2 * theta + 0.3), 0.0
    )
    tau = tau + rng.normal(0.0, noise, t.size)
    q = np.round(theta * 8000 / (2 * np.pi)) * (2 * np.pi / 8000)
    return {"t": t, "q_m": q, "i_m": tau / 0.1}


def write_motor_fleet(
    out_dir: str | os.PathLike[str], *, robots: int, days: int, seed: int = 0
) -> Path:
    """A light fleet of single motors (:func:`motor_sweep_columns`) whose Coulomb friction
    grows by 0-3 %/day; writes FLEET.toml, each motor's robot file and daily sweep. For tests
    and the fleet benchmark, where the SCARA simulator would dominate the time."""
    from torquemap.io import write_table, write_toml

    out = _fleet_folder(out_dir, robots, days, seed)
    rng = np.random.default_rng(seed)
    fleet: list[dict[str, Any]] = []
    for r in range(robots):
        name = f"m{r + 1:03d}"
        (out / name).mkdir(exist_ok=True)
        write_toml(out / name / "robot.toml", MOTOR_ROBOT)
        rate, base = float(rng.uniform(0.0, 0.03)), float(rng.uniform(0.03, 0.08))
        entries = []
        for d in range(days):
            date = dt.date(2026, 11, 2) + dt.timedelta(days=d)
            log = f"{name}/{date.isoformat()}.csv"
            write_table(out / log, motor_sweep_columns(rng, coulomb=base * (1 + rate * d)))
            entries.append({"date": date, "logs": [log]})
        fleet.append({"name": name, "robot": f"{name}/robot.toml", "days": entries})
    write_toml(out / "FLEET.toml", {"robots": fleet})
    return out / "FLEET.toml"


def _fleet_folder(out_dir: str | os.PathLike[str], robots: int, days: int, seed: int) -> Path:
    for what, value in (("robots", robots), ("days", days)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise InputError(f"{what} must be a positive integer, got {value!r}")
    if robots * days > MAX_ROBOT_DAYS:
        raise InputError(f"at most {MAX_ROBOT_DAYS} robot-days, asked {robots * days}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("output path exists and is not a folder", path=out)
    out.mkdir(parents=True, exist_ok=True)
    return out


def write_fleet(
    out_dir: str | os.PathLike[str],
    *,
    robots: int,
    days: int,
    seed: int = 0,
    start: dt.date = dt.date(2026, 11, 2),
    progress: Callable[[int, int], None] | None = None,
) -> Path:
    """Simulate a fleet and write its files; returns the fleet file.

    Files: ``FLEET.toml`` (docs/fleet.md), ``<robot>/robot.toml``, ``<robot>/<date>/sweep.csv``
    per robot and day, and ``truth.toml`` (each robot's wear and its true friction and PDTV per
    day, for scoring only).

    Parameters
    ----------
    out_dir
        Output folder (created).
    robots, days
        Fleet size (>= 1 each, at most ``MAX_ROBOT_DAYS`` robot-days).
    seed
        Seed of every random draw.
    start
        The first day's date.
    progress
        Called with robot-days done and total.

    Raises
    ------
    InputError
        On a bad size or seed, or an output path that is not a folder.
    """
    from torquemap.io import write_table, write_toml

    out = _fleet_folder(out_dir, robots, days, seed)
    rng = np.random.default_rng(seed)
    fleet: list[dict[str, Any]] = []
    truth: dict[str, Any] = {}
    done = 0
    for r in range(robots):
        name = f"r{r + 1:02d}"
        bench0 = default_bench()
        base = _short_sweep(
            dataclasses.replace(
                bench0,
                axes=(_scaled_axis(bench0.axes[0], rng), _scaled_axis(bench0.axes[1], rng)),
                name=f"simulated fleet robot {name}",
            )
        )
        belt = bool(rng.uniform() < 0.5)
        axis = int(rng.integers(0, 2))
        wear = RobotWear(
            coulomb_rate=float(rng.uniform(0.0, 0.03)),
            viscous_rate=float(rng.uniform(-0.02, 0.02)),
            belt_day=int(rng.integers(1, max(days, 2))) if belt else -1,
            belt_axis=axis,
            belt_order=float(base.axes[axis].pdtv[0].order),
            belt_rate=float(rng.uniform(0.0005, 0.002)),
        )
        rdir = out / name
        rdir.mkdir(exist_ok=True)
        write_toml(rdir / "robot.toml", robot_document(base))
        robot_days: list[dict[str, Any]] = []
        robot_truth: dict[str, Any] = {"wear": dataclasses.asdict(wear), "days": []}
        for d in range(days):
            date = start + dt.timedelta(days=d)
            bench = robot_on_day(base, wear, d)
            run = simulate_sweep(bench, rng=rng.spawn(1)[0])
            ddir = rdir / date.isoformat()
            ddir.mkdir(exist_ok=True)
            write_table(ddir / "sweep.csv", _log_columns(run, bench))
            robot_days.append({"date": date, "logs": [f"{name}/{date.isoformat()}/sweep.csv"]})
            robot_truth["days"].append(
                {
                    "date": date,
                    "joints": {
                        ax.name: {
                            "coulomb_positive": ax.friction.coulomb_positive,
                            "coulomb_negative": ax.friction.coulomb_negative,
                            "viscous": ax.friction.viscous,
                            "pdtv": [{"order": h.order, "amplitude": h.amplitude} for h in ax.pdtv],
                        }
                        for ax in bench.axes
                    },
                }
            )
            done += 1
            if progress is not None:
                progress(done, robots * days)
        fleet.append({"name": name, "robot": f"{name}/robot.toml", "days": robot_days})
        truth[name] = robot_truth
    write_toml(out / "truth.toml", {"robots": truth})
    write_toml(out / "FLEET.toml", {"robots": fleet})
    return out / "FLEET.toml"
