"""A fleet of robots: the fleet file, and identification of every robot and day on Dask.

A fleet file (TOML, docs/fleet.md) lists robots, each with its robot file and its logs by day::

    [[robots]]
    name = "r01"
    robot = "r01/robot.toml"          # relative to the fleet file
    [[robots.days]]
    date = 2026-11-01                 # a TOML date
    logs = ["r01/2026-11-01/sweep.csv"]

:func:`identify_fleet` identifies every robot-day as one task on a Dask cluster (a local one by
default) and writes one model per robot and day, ``OUT/<robot>/<date>.toml``, plus
``OUT/fleet-run.toml`` with every robot-day's status. A robot-day that fails (a missing log, a log
of another robot, too little motion) is reported with its reason; the others finish.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import math
import os
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from torquemap.errors import InputError
from torquemap.tomlfile import read_toml

#: The record of a run, written last (:func:`identify_fleet`).
RUN_FILE = "fleet-run.toml"

_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


@dataclass(frozen=True, slots=True, eq=False)
class RobotDay:
    """One robot on one day: the logs to identify.

    Attributes
    ----------
    robot
        The robot's name in the fleet (a file-name-safe identifier).
    robot_file
        Its robot file.
    date
        The day the logs were taken.
    logs
        The no-load logs of that day.
    """

    robot: str
    robot_file: Path
    date: dt.date
    logs: tuple[Path, ...]


@dataclass(frozen=True, slots=True, eq=False)
class Fleet:
    """A parsed fleet file.

    Attributes
    ----------
    days
        Every robot-day, robots in file order, days in date order.
    path
        The fleet file.
    """

    days: tuple[RobotDay, ...]
    path: Path


@dataclass(frozen=True, slots=True, eq=False)
class DayOutcome:
    """What became of one robot-day.

    Attributes
    ----------
    robot, date
        Which robot-day.
    ok
        True when a model was written.
    model_path
        The model written (None when failed).
    reason
        Why it failed, one line ("" when ok).
    warnings
        The identification's warnings.
    seconds
        Wall time of the task [s].
    """

    robot: str
    date: dt.date
    ok: bool
    model_path: Path | None
    reason: str
    warnings: tuple[str, ...]
    seconds: float


@dataclass(frozen=True, slots=True, eq=False)
class FleetRun:
    """Result of :func:`identify_fleet`.

    Attributes
    ----------
    outcomes
        One per robot-day, in the fleet file's order.
    out_dir
        Where the models are.
    workers
        Dask workers used.
    seconds
        Wall time of the whole run [s].
    """

    outcomes: tuple[DayOutcome, ...]
    out_dir: Path
    workers: int
    seconds: float

    @property
    def failed(self) -> tuple[DayOutcome, ...]:
        """The robot-days that failed."""
        return tuple(o for o in self.outcomes if not o.ok)


def read_fleet(path: str | os.PathLike[str]) -> Fleet:
    """Read a fleet file (module docstring; docs/fleet.md).

    Robot files and logs are not opened here (a missing one fails its robot-day only), but
    names, dates and the file's structure are checked.

    Raises
    ------
    InputError
        On a missing or malformed file, an unknown key, a bad or repeated robot name, a robot
        without days, a bad date, a day listed twice or a log listed twice.
    """
    p = Path(path)
    doc = read_toml(p)
    unknown = set(doc) - {"robots"}
    if unknown:
        raise InputError(f"unknown key {sorted(unknown)[0]!r} in the fleet file", path=p)
    robots = doc.get("robots")
    if not isinstance(robots, list) or not robots:
        raise InputError("the fleet file lists no robots ([[robots]] tables)", path=p)
    base = p.parent
    days: list[RobotDay] = []
    seen: set[str] = set()
    owner: dict[str, str] = {}
    for k, entry in enumerate(robots):
        where = f"[[robots]] #{k + 1}"
        if not isinstance(entry, Mapping):
            raise InputError(f"{where} must be a table", path=p)
        extra = set(entry) - {"name", "robot", "days"}
        if extra:
            raise InputError(f"unknown key {sorted(extra)[0]!r} in {where}", path=p)
        name = entry.get("name")
        if not isinstance(name, str) or not _NAME.match(name):
            raise InputError(
                f"{where} name must be 1-64 letters, digits, '_', '.', '-' (a file name), "
                f"got {name!r}",
                path=p,
            )
        if name in seen:
            raise InputError(f"robot {name!r} is listed twice", path=p)
        seen.add(name)
        robot_file = entry.get("robot")
        if not isinstance(robot_file, str) or not robot_file:
            raise InputError(f'robot {name!r} needs robot = "<robot file>"', path=p)
        raw_days = entry.get("days")
        if not isinstance(raw_days, list) or not raw_days:
            raise InputError(f"robot {name!r} has no [[robots.days]]", path=p)
        dates: set[dt.date] = set()
        mine: list[RobotDay] = []
        for day in raw_days:
            if not isinstance(day, Mapping):
                raise InputError(f"robot {name!r}: each day must be a table", path=p)
            if set(day) - {"date", "logs"}:
                key = sorted(set(day) - {"date", "logs"})[0]
                raise InputError(
                    f"unknown key {key!r} in a day of robot {name!r} (a day holds date and logs)",
                    path=p,
                )
            date = day.get("date")
            if isinstance(date, dt.datetime) or not isinstance(date, dt.date):
                raise InputError(
                    f"robot {name!r}: date must be a TOML date (2026-11-01), got {date!r}", path=p
                )
            if date in dates:
                raise InputError(f"robot {name!r}: day {date} is listed twice", path=p)
            dates.add(date)
            logs = day.get("logs")
            if (
                not isinstance(logs, list)
                or not logs
                or not all(isinstance(x, str) and x for x in logs)
            ):
                raise InputError(f"robot {name!r} on {date}: logs must list log files", path=p)
            for x in logs:
                # one recording is one robot-day: listed again, it would pass for a second day
                # (a steady robot) or weigh twice in its day (standard errors too small)
                key = os.path.normpath(os.path.abspath(base / x))
                if key in owner:
                    raise InputError(
                        f"log {x!r} is listed for {owner[key]} and again for {name} {date}",
                        path=p,
                    )
                owner[key] = f"{name} {date}"
            mine.append(
                RobotDay(
                    robot=name,
                    robot_file=base / robot_file,
                    date=date,
                    logs=tuple(base / x for x in logs),
                )
            )
        days.extend(sorted(mine, key=lambda d: d.date))
    return Fleet(days=tuple(days), path=p)


def model_path(out_dir: str | os.PathLike[str], robot: str, date: dt.date) -> Path:
    """Where :func:`identify_fleet` writes the model of a robot-day."""
    return Path(out_dir) / robot / f"{date.isoformat()}.toml"


def identify_day(day: RobotDay, out_dir: str, window: float | None = None) -> DayOutcome:
    """Identify one robot-day and write its model; a failure is returned, never raised.

    This is the task each Dask worker runs. The model's ``[identification]`` notes gain
    ``robot`` and ``date``.
    """
    import time

    from torquemap.identify import identify_model
    from torquemap.identify_arm import is_rigid_body_arm
    from torquemap.io import cut_last_line_warnings, read_log, write_toml
    from torquemap.model import Model, model_to_dict
    from torquemap.robot import load_robot

    start = time.perf_counter()
    target = model_path(out_dir, day.robot, day.date)
    try:
        for f in (day.robot_file, *day.logs):
            if not f.exists():
                # a path written from the shell's folder, not the fleet file's, is the usual cause
                raise InputError(
                    "file not found (a fleet file's paths are relative to its own folder)", path=f
                )
        robot = load_robot(day.robot_file)
        if is_rigid_body_arm(robot.arm):
            # the pass identification has no gravity or coupling: a UR5's day failed with
            # "a vertical arm? ... use a robot file that models gravity", of a file that does
            raise InputError(
                "fleet identify reads robots of kinematics 'none' or 'planar2r'; this is an "
                "arm with a URDF: identify its days one by one with `torquemap identify`",
                path=day.robot_file,
            )
        logs = [read_log(p, robot) for p in day.logs]
        kwargs: dict[str, Any] = {} if window is None else {"window": window}
        # the pass method's law (Coulomb per direction, viscous, Stribeck): a fixed form whose
        # fields and standard errors the drift trends compare from day to day
        result = identify_model(robot, logs, friction="passes", **kwargs)
        notes = {**result.model.notes, "robot": day.robot, "date": day.date.isoformat()}
        joints_notes = dict(notes.get("joints", {}))
        for name, errors in standard_errors(result).items():
            joints_notes[name] = {**joints_notes.get(name, {}), "standard_errors": errors}
        notes["joints"] = joints_notes
        model = Model(robot=result.model.robot, joints=result.model.joints, notes=notes)
        target.parent.mkdir(parents=True, exist_ok=True)
        write_toml(target, model_to_dict(model))
    except (InputError, OSError, ValueError, ArithmeticError) as exc:
        # One robot-day's problem is reported, not raised: the others finish.
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        cut = cut_last_line_warnings(day.logs)
        if cut:
            reason = f"{reason} ({cut[0]})"
        # a model of this robot-day left by an earlier run is not this run's answer
        try:
            target.unlink(missing_ok=True)
        except OSError:
            pass
        return DayOutcome(day.robot, day.date, False, None, reason, (), time.perf_counter() - start)
    return DayOutcome(
        day.robot,
        day.date,
        True,
        target,
        "",
        (*result.warnings, *cut_last_line_warnings(day.logs)),
        time.perf_counter() - start,
    )


def standard_errors(result: Any) -> dict[str, dict[str, float]]:
    """The identification's own standard errors, per joint, of the parameters drift follows.

    Friction: ordinary least squares over the constant-speed passes, ``s^2 (A^T A)^-1`` with
    ``A`` the law's basis at the pass speeds (the parameters it identified: nonzero ones) and
    ``s^2`` the pass residuals' variance. PDTV: each line's amplitude standard error from the
    harmonic fit. Parameters without enough data to say are left out.
    """
    import numpy as np

    out: dict[str, dict[str, float]] = {}
    for name, jr in result.joints.items():
        errors: dict[str, float] = {}
        law = result.model.joints[name].friction
        fit = jr.friction
        if fit is not None and jr.passes:
            speeds = np.array([p.speed for _, p in jr.passes])
            values = law.linear_parameters()
            active = np.flatnonzero(values != 0.0)
            dof = speeds.size - active.size
            if active.size and dof > 0:
                a = law.basis(speeds)[:, active]
                s2 = float(np.sum(np.asarray(fit.residual) ** 2)) / dof
                try:
                    cov = s2 * np.linalg.inv(a.T @ a)
                except np.linalg.LinAlgError:
                    cov = np.full((active.size, active.size), np.nan)
                for col, k in enumerate(active):
                    se = float(np.sqrt(max(cov[col, col], 0.0)))
                    if np.isfinite(se) and se > 0:
                        errors[f"friction.{law.linear_parameter_names[k]}"] = se
        h = jr.harmonics
        if h is not None:
            for line in result.model.joints[name].pdtv:
                match = np.flatnonzero(np.isclose(h.order, line.order))
                if match.size and line.direction == "both":
                    se = float(h.amplitude_se[match[0]])
                    if np.isfinite(se) and se > 0:
                        errors[f"pdtv.{line.order:g}.amplitude"] = se
        if errors:
            out[name] = errors
    return out


def identify_fleet(
    fleet: Fleet,
    out_dir: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    workers: int = 2,
    processes: bool = True,
    window: float | None = None,
    progress: Callable[[DayOutcome, int, int], None] | None = None,
) -> FleetRun:
    """Identify every robot-day of a fleet in parallel on Dask.

    Parameters
    ----------
    fleet
        The fleet (:func:`read_fleet`).
    out_dir
        Output folder: ``<robot>/<date>.toml`` per robot-day and ``fleet-run.toml``.
    scheduler
        Address of a running Dask scheduler (``tcp://host:8786``); default: a local cluster of
        ``workers`` single-threaded workers, closed at the end.
    workers
        Workers of the local cluster (>= 1).
    processes
        Local workers as processes (default; the identification holds the GIL) or threads.
    window
        Differentiation window [s] (default: identification's).
    progress
        Called with each outcome as it arrives, and the count done and total.

    Returns
    -------
    FleetRun
        Every robot-day's outcome; the run file ``fleet-run.toml`` is written last.

    Raises
    ------
    InputError
        On a bad output folder, ``workers < 1``, a window that is not a positive number, or a
        scheduler that cannot be reached (the output folder is then left as it was).
    """
    import time

    from distributed import Client, LocalCluster, as_completed

    from torquemap.io import write_toml

    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"workers must be a positive integer, got {workers!r}")
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise InputError("output path exists and is not a folder", path=out)
    if window is not None and not (isinstance(window, int | float) and 0 < window < math.inf):
        raise InputError(f"window must be a positive number of seconds, got {window!r}")
    start = time.perf_counter()
    cluster: LocalCluster | None = None
    try:
        if scheduler is None:
            # the scheduler's HTTP server (metrics; a dashboard where bokeh is installed) on a
            # free port: its default 8787, when taken (a user's own Dask, a second fleet run),
            # gives a warning and leaks the socket it tried
            with _workers_ignore_ctrl_c():
                cluster = LocalCluster(
                    n_workers=workers,
                    threads_per_worker=1,
                    processes=processes,
                    dashboard_address="127.0.0.1:0",
                    silence_logs=50,
                )
            client = Client(cluster)
        else:
            try:
                client = Client(scheduler, timeout="10s")
            except (OSError, TimeoutError, ValueError) as exc:
                raise InputError(f"cannot reach the Dask scheduler {scheduler!r} ({exc})") from None
        with client:
            # OUT is touched only once the cluster is there. An earlier run's record must not
            # outlive this run's first model: were this run stopped, `fleet drift` would read
            # the old record against models partly rewritten by this one.
            out.mkdir(parents=True, exist_ok=True)
            (out / RUN_FILE).unlink(missing_ok=True)
            n_workers = len(client.scheduler_info().get("workers", {})) or workers
            futures = {
                client.submit(identify_day, day, str(out), window, pure=False): k
                for k, day in enumerate(fleet.days)
            }
            outcomes: list[DayOutcome | None] = [None] * len(fleet.days)
            done = 0
            for future in as_completed(futures):
                k = futures[future]
                try:
                    outcome: DayOutcome = future.result()
                except Exception as exc:
                    day = fleet.days[k]
                    outcome = DayOutcome(
                        day.robot, day.date, False, None, f"task failed: {exc}", (), 0.0
                    )
                outcomes[k] = outcome
                done += 1
                if progress is not None:
                    progress(outcome, done, len(fleet.days))
    finally:
        if cluster is not None:
            cluster.close()
    final = tuple(o for o in outcomes if o is not None)
    run = FleetRun(
        outcomes=final,
        out_dir=out,
        workers=n_workers,
        seconds=time.perf_counter() - start,
    )
    write_toml(out / RUN_FILE, run_document(run, fleet))
    return run


@contextlib.contextmanager
def _workers_ignore_ctrl_c() -> Iterator[None]:
    """Ignore SIGINT while the local cluster starts its worker processes, which inherit it.

    Ctrl-C reaches the terminal's whole process group: the workers printed a KeyboardInterrupt
    traceback each before the parent's one-line ``interrupted``. Ignoring it, they are stopped
    by the parent closing the cluster instead. Outside the main thread (where handlers cannot be
    set) nothing changes.
    """
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def run_document(run: FleetRun, fleet: Fleet) -> dict[str, Any]:
    """``fleet-run.toml``: the fleet file it came from and every robot-day's outcome."""
    days: list[dict[str, Any]] = []
    for o in run.outcomes:
        entry: dict[str, Any] = {"robot": o.robot, "date": o.date, "ok": o.ok}
        if o.model_path is not None:
            entry["model"] = o.model_path.relative_to(run.out_dir).as_posix()
        if o.reason:
            entry["reason"] = o.reason
        if o.warnings:
            entry["warnings"] = list(o.warnings)
        entry["seconds"] = round(o.seconds, 3)
        days.append(entry)
    return {
        "fleet": str(fleet.path),
        "workers": run.workers,
        "seconds": round(run.seconds, 3),
        "days": days,
    }


def read_run(out_dir: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The robot-days of ``OUT/fleet-run.toml`` (InputError when it is missing or malformed)."""
    path = Path(out_dir) / RUN_FILE
    if not path.is_file():
        raise InputError(
            f"no {RUN_FILE}: not an output folder of `fleet identify`, or its run did not finish "
            "(run it again)",
            path=Path(out_dir),
        )
    doc = read_toml(path)
    days = doc.get("days")
    if not isinstance(days, list):
        raise InputError(f"{RUN_FILE} has no days", path=path)
    for k, day in enumerate(days):
        # a record edited or cut by hand: say which entry, not a KeyError
        if (
            not isinstance(day, Mapping)
            or not isinstance(day.get("robot"), str)
            or not isinstance(day.get("date"), dt.date | str)
            or not isinstance(day.get("ok"), bool)
            or (day["ok"] and not isinstance(day.get("model"), str))
        ):
            raise InputError(
                f"[[days]] #{k + 1} needs robot, date, ok and (when ok) model; run "
                "`fleet identify` again",
                path=path,
            )
    return list(days)


def summary_lines(run: FleetRun) -> Sequence[str]:
    """One line per failed robot-day, then a count."""
    lines = [f"{o.robot} {o.date}: FAILED: {o.reason}" for o in run.failed]
    ok = len(run.outcomes) - len(run.failed)
    lines.append(
        f"{ok} of {len(run.outcomes)} robot-days identified on {run.workers} worker(s) in "
        f"{run.seconds:.1f} s"
    )
    return lines
