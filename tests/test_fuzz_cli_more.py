"""Bad input to every command, systematically: each input file of each command x the contract's
bad inputs (missing column, NaN, time going backwards, unknown key, empty, truncated, corrupt
table, binary bytes, a folder where a file is expected, a file that is not there) and outputs
that cannot be written.

tests/test_fuzz_cli.py fuzzes identify, estimate, pdtv-map, linearize build and evaluate with
random corruptions; tests/test_cli_bad_logs.py covers logs of another robot, too slow, in ms.
This file covers the other commands (spectrum, excite, report, cogging verify, linearize
figures / collect / home / transfer, fleet identify / drift, simulate figures, import rosbag)
and the fixed cases of the sweep (/tmp/Q39/driver.py in helper Q39's report). The contract:
exit 2, one line naming the file, no traceback, no output left behind.
"""

from __future__ import annotations

import datetime as dt
import io
import shutil
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from test_fuzz_cli import Clean, _run, assert_clean_outcome, clean  # noqa: F401 (fixture)

from torquemap.io import read_table, write_table, write_toml
from torquemap.linearize.export import load_tables
from torquemap.robot import robot_from_dict

# one worker runs test_fuzz_cli and test_fuzz_cli_more (pytest -n 2 --dist loadgroup), so
# the session fixture `clean` (every command's clean run) is built once, not once per worker
pytestmark = pytest.mark.xdist_group("fuzz_cli")

# -- the bad inputs ------------------------------------------------------------------------------


def _columns(path: Path) -> dict[str, np.ndarray]:
    return {k: np.array(v, dtype=np.float64) for k, v in read_table(path).items()}


def _csv(kind: str) -> Callable[[Path, Path], None]:
    def make(src: Path, dst: Path) -> None:
        text = src.read_bytes()
        if kind == "missing column":
            cols = _columns(src)
            cols.pop(list(cols)[-1])
            write_table(dst, cols)
        elif kind == "nan":
            cols = _columns(src)
            cols[list(cols)[-1]][5] = np.nan
            write_table(dst, cols)
        elif kind == "time backwards":
            cols = _columns(src)
            cols["t"][30] = -1.0
            write_table(dst, cols)
        elif kind == "header only":
            dst.write_bytes(text.split(b"\n")[0] + b"\n")
        elif kind == "cut row":  # cut inside a row, fewer cells than the header
            dst.write_bytes(text[: text.index(b",", len(text) // 3) + 1] + b"\n")
        else:
            _any(kind)(src, dst)

    return make


def _toml(kind: str) -> Callable[[Path, Path], None]:
    def make(src: Path, dst: Path) -> None:
        text = src.read_bytes()
        if kind in ("unknown key", "wrong type"):
            doc = tomllib.loads(text.decode())
            tables = [v[0] if isinstance(v, list) else v for v in doc.values()]
            head = next(v for v in tables if isinstance(v, dict))
            if kind == "unknown key":
                head["zz_unknown"] = 1
            else:
                head[next(iter(head))] = {"x": "y"}
            dst.write_text(tomli_w.dumps(doc))
        elif kind == "truncated":
            dst.write_bytes(text[: len(text) // 2])
        else:
            _any(kind)(src, dst)

    return make


def _npz(kind: str) -> Callable[[Path, Path], None]:
    def make(src: Path, dst: Path) -> None:
        if kind in ("missing key", "nan"):
            with np.load(src) as z:
                arrays = {k: z[k] for k in z.files}
            if kind == "missing key":
                arrays.pop("actuation_max")
            else:
                arrays["base"] = arrays["base"].copy()
                arrays["base"][0, 0] = np.nan
            buf = io.BytesIO()
            np.savez(buf, **arrays)
            dst.write_bytes(buf.getvalue())
        elif kind == "truncated":
            dst.write_bytes(src.read_bytes()[:1000])
        else:
            _any(kind)(src, dst)

    return make


def _any(kind: str) -> Callable[[Path, Path], None]:
    def make(src: Path, dst: Path) -> None:
        if kind == "empty":
            dst.write_bytes(b"")
        elif kind == "binary":
            dst.write_bytes(bytes(range(256)) * 8)
        elif kind == "folder":
            dst.mkdir()
        elif kind != "missing":
            raise KeyError(kind)

    return make


CSV_KINDS = ("missing column", "nan", "time backwards", "header only", "cut row", "empty",
             "binary", "folder", "missing")  # fmt: skip
TOML_KINDS = ("unknown key", "wrong type", "truncated", "empty", "binary", "folder", "missing")
NPZ_KINDS = ("missing key", "nan", "truncated", "empty", "binary", "folder", "missing")
FOLDER_KINDS = ("empty", "binary", "missing")  # a file (or nothing) where a folder is expected


def _maker(name: str, kind: str) -> Callable[[Path, Path], None]:
    if name.endswith(".csv") or name.endswith(".parquet"):
        return _csv(kind)
    if name.endswith(".toml"):
        return _toml(kind)
    if name.endswith(".npz"):
        return _npz(kind)
    return _any(kind)


# -- the inputs and the commands -----------------------------------------------------------------


@pytest.fixture(scope="module")
def inputs(clean: Clean, tmp_path_factory: pytest.TempPathFactory) -> Path:  # noqa: F811
    """The clean inputs of test_fuzz_cli, with a fleet, its run record and a few rows."""
    d = tmp_path_factory.mktemp("fuzz_more")
    for name in ("robot.toml", "model.toml", "sweep.csv", "log.csv", "log.parquet",
                 "motor.toml", "data.csv"):  # fmt: skip
        (d / name).write_bytes(clean[name].read_bytes())
    (d / "tables.npz").write_bytes((clean["out"] / "tables.npz").read_bytes())
    write_toml(  # the motor of `simulate rig --motor vr`, for collect and home --sim vr
        d / "vr.toml",
        {"motor": {"name": "sim-vr", "phases": 3, "positions_per_cycle": 512,
                   "command_bits": 8, "actuation_max": 255,
                   "equilibrium_positions": [213, 387, 41], "ramping": "wide"}},
    )  # fmt: skip
    data = read_table(d / "data.csv")
    few = (data["position"] % 8 == 0) & (data["pulse_width"] % 60 == 0)
    write_table(d / "few.csv", {k: v[few] for k, v in data.items()})
    write_toml(
        d / "FLEET.toml",
        {"robots": [{"name": "r01", "robot": "robot.toml",
                     "days": [{"date": dt.date(2026, 11, 2), "logs": ["sweep.csv"]}]}]},
    )  # fmt: skip
    run = d / "run"
    run.mkdir()
    (run / "r01").mkdir()
    (run / "r01" / "2026-11-02.toml").write_bytes((d / "model.toml").read_bytes())
    write_toml(
        run / "fleet-run.toml",
        {"fleet": "FLEET.toml", "workers": 1, "seconds": 1.0,
         "days": [{"robot": "r01", "date": dt.date(2026, 11, 2), "ok": True,
                   "model": "r01/2026-11-02.toml", "seconds": 1.0}]},
    )  # fmt: skip
    return d


#: command: (argv with {input} and {out}, the inputs it reads, the output it writes or None)
COMMANDS: dict[str, tuple[list[str], tuple[str, ...], str | None]] = {
    "spectrum": (["spectrum", "{model.toml}", "{sweep.csv}", "--joint", "a", "-o", "{out}/s.png"],
                 ("model.toml", "sweep.csv"), "s.png"),
    "excite": (["excite", "{robot.toml}", "-o", "{out}/traj.csv"], ("robot.toml",), "traj.csv"),
    "report": (["report", "{model.toml}", "{log.csv}", "-o", "{out}/r.html"],
               ("model.toml", "log.csv"), "r.html"),
    "estimate parquet": (["estimate", "{model.toml}", "{log.parquet}", "-o", "{out}/f.csv"],
                         ("log.parquet",), "f.csv"),
    "cogging verify": (["cogging", "verify", "{model.toml}", "{sweep.csv}", "--joint", "a"],
                       ("model.toml", "sweep.csv"), None),
    "linearize figures": (["linearize", "figures", "{motor.toml}", "{data.csv}", "--tables",
                           "{tables.npz}", "-o", "{out}/figs"],
                          ("motor.toml", "data.csv", "tables.npz"), "figs"),
    "linearize evaluate": (["linearize", "evaluate", "{motor.toml}", "{data.csv}", "-o",
                            "{out}/e.json"], ("motor.toml", "data.csv"), "e.json"),
    "linearize collect": (["linearize", "collect", "{vr.toml}", "--sim", "vr", "--no-progress",
                           "-o", "{out}/c.csv"], ("vr.toml",), "c.csv"),
    "linearize collect --tables": (["linearize", "collect", "{vr.toml}", "--sim", "vr",
                                    "--tables", "{tables.npz}", "--no-progress", "-o",
                                    "{out}/c.csv"], ("tables.npz",), "c.csv"),
    "linearize home": (["linearize", "home", "{vr.toml}", "--sim", "vr", "--tables",
                        "{tables.npz}"], ("vr.toml", "tables.npz"), None),
    "linearize transfer": (["linearize", "transfer", "{motor.toml}", "{data.csv}", "{motor.toml}",
                            "{few.csv}", "-o", "{out}/x.csv"],
                           ("motor.toml", "data.csv", "few.csv"), "x.csv"),
    "fleet identify": (["fleet", "identify", "{FLEET.toml}", "-o", "{out}/fo", "--workers", "1"],
                       ("FLEET.toml",), "fo"),
    "fleet drift": (["fleet", "drift", "{run}", "-o", "{out}/d.csv"], ("run",), "d.csv"),
    "fleet drift record": (["fleet", "drift", "{run}", "-o", "{out}/d.csv"],
                           ("run/fleet-run.toml", "run/r01/2026-11-02.toml"), "d.csv"),
    "simulate figures": (["simulate", "figures", "{bench}", "--out", "{out}/sf"], ("bench",), "sf"),
    "import rosbag": (["import", "rosbag", "{bag}", "--robot", "{robot.toml}", "-o",
                       "{out}/b.parquet"], ("bag", "robot.toml"), "b.parquet"),
}  # fmt: skip


def _kinds(name: str) -> tuple[str, ...]:
    if name in ("data.csv", "few.csv"):  # characterisation data: no time column
        return tuple(k for k in CSV_KINDS if k != "time backwards")
    if name.endswith((".csv", ".parquet")):
        return CSV_KINDS
    if name.endswith(".toml"):
        return TOML_KINDS
    if name.endswith(".npz"):
        return NPZ_KINDS
    return FOLDER_KINDS


CASES = [
    pytest.param(command, name, kind, id=f"{command}-{name}-{kind}")
    for command, (_, names, _) in COMMANDS.items()
    for name in names
    for kind in _kinds(name)
    # fleet-run.toml is written by fleet identify: a key it does not know is left alone (runs
    # of other versions stay readable); a needed key missing or mistyped is refused
    if (name, kind) != ("run/fleet-run.toml", "unknown key")
]


def _files(inputs: Path) -> dict[str, Path]:
    names = ("robot.toml", "model.toml", "sweep.csv", "log.csv", "log.parquet", "motor.toml",
             "data.csv", "tables.npz", "few.csv", "FLEET.toml", "run", "vr.toml")  # fmt: skip
    # "bench" and "bag" are only ever bad: a simulated bench or a bag is too slow to make here
    return {name: inputs / name for name in (*names, "bench", "bag")}


def _argv(template: list[str], files: dict[str, Path], out: Path) -> list[str]:
    argv = []
    for arg in template:
        arg = arg.replace("{out}", str(out))
        for name, path in files.items():
            arg = arg.replace("{" + name + "}", str(path))
        argv.append(arg)
    return argv


@pytest.mark.parametrize(("command", "name", "kind"), CASES)
def test_bad_input_is_one_line_naming_the_file(
    inputs: Path, tmp_path: Path, command: str, name: str, kind: str
) -> None:
    template = COMMANDS[command][0]
    files = _files(inputs)
    bad = tmp_path / "bad"
    bad.mkdir()
    if name.startswith("run/"):  # a file inside the fleet's run folder
        shutil.copytree(inputs / "run", bad / "run")
        target = bad / name
        target.unlink()
        _maker(name, kind)(inputs / name, target)
        files["run"] = bad / "run"
    else:
        target = bad / Path(name).name
        _maker(name, kind)(inputs / name, target)
        files[name] = target
    out = tmp_path / "out"
    out.mkdir()
    argv = _argv(template, files, out)
    status, err = _run(argv)
    assert_clean_outcome(status, err, argv)
    assert status == 2, (argv, err)
    assert target.name in err or str(target.parent) in err, err
    assert not list(out.iterdir()), list(out.iterdir())  # nothing written, no temporary left


# excite is left out: its robot must have a URDF, which it checks first
@pytest.mark.parametrize(
    "command", [c for c, v in COMMANDS.items() if v[2] is not None and c != "excite"]
)
@pytest.mark.parametrize("how", ["below a file", "a folder"])
def test_an_output_that_cannot_be_written(
    inputs: Path, tmp_path: Path, command: str, how: str
) -> None:
    template, _, output = COMMANDS[command]
    assert output is not None
    files = _files(inputs)
    if how == "below a file":
        out = tmp_path / "a_file"
        out.write_text("x")
    else:
        out = tmp_path / "out"
        out.mkdir()
        (out / output).mkdir() if "." in output else (out / output).write_text("x")
    argv = _argv(template, files, out)
    status, err = _run(argv)
    assert_clean_outcome(status, err, argv)
    assert status == 2, (argv, err)
    assert str(out) in err, err


# -- the cases the sweep found -------------------------------------------------------------------


def test_nan_in_the_tables_is_refused(inputs: Path, tmp_path: Path) -> None:
    # before: linearize figures drew the NaN surface, exit 0
    bad = tmp_path / "tables.npz"
    _npz("nan")(inputs / "tables.npz", bad)
    with pytest.raises(ValueError, match=r"array 'base' holds nan at \[0, 0\]"):
        load_tables(bad)
    argv = ["linearize", "figures", str(inputs / "motor.toml"), str(inputs / "data.csv"),
            "--tables", str(bad), "-o", str(tmp_path / "figs")]  # fmt: skip
    status, err = _run(argv)
    assert status == 2 and "tables.npz: array 'base' holds nan" in err
    assert not (tmp_path / "figs").exists()


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_folder_given_as_a_log_is_named(inputs: Path, tmp_path: Path, suffix: str) -> None:
    # before: a Parquet folder read as a data set, "table has no rows"; a CSV folder, pyarrow's
    # "Expected file path, but ... is a directory"
    log = tmp_path / f"log{suffix}"
    log.mkdir()
    argv = ["estimate", str(inputs / "model.toml"), str(log), "-o", str(tmp_path / "f.csv")]
    status, err = _run(argv)
    assert status == 2
    assert err.strip() == (
        f"torquemap: error: {log}: is a folder, expected a {suffix[1:].upper()} file"
    )


def test_a_robot_name_that_is_not_text_is_refused() -> None:
    # before: accepted, the name became "{'x': 'y'}"
    doc = {"robot": {"name": {"x": "y"}, "kinematics": "none"}, "joints": {"a": {}}}
    with pytest.raises(ValueError, match=r"\[robot\] name must be a string, got \{'x': 'y'\}"):
        robot_from_dict(doc)


@pytest.mark.parametrize("command", ["figures", "transfer"])
def test_linearize_warns_of_a_cut_last_line(inputs: Path, tmp_path: Path, command: str) -> None:
    # before: exit 0, nothing said (build and evaluate warned)
    cut = tmp_path / "data.csv"
    cut.write_bytes((inputs / "data.csv").read_bytes()[:-2])
    motor = str(inputs / "motor.toml")
    if command == "figures":
        argv = ["linearize", "figures", motor, str(cut), "-o", str(tmp_path / "figs")]
    else:
        argv = ["linearize", "transfer", motor, str(cut), motor, str(inputs / "few.csv"), "-o",
                str(tmp_path / "x.csv")]  # fmt: skip
    status, err = _run(argv)
    assert status == 0, err
    assert f"torquemap: warning: {cut}: the last line has no line end" in err


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "fleet", "--robots", "1", "--days", "1", "--out"],
        ["simulate", "actuator", "--out"],
        ["simulate", "arm", "--out"],
        ["fleet", "identify", "{FLEET.toml}", "--workers", "1", "-o"],
    ],
    ids=["simulate fleet", "simulate actuator", "simulate arm", "fleet identify"],
)
def test_an_output_folder_below_a_file_is_named(
    inputs: Path, tmp_path: Path, argv: list[str]
) -> None:
    # before: "torquemap: error: .../a_file/out: Not a directory" (the OS's words, after the
    # fleet was read); now the words of the other commands, before any work
    (tmp_path / "a_file").write_text("x")
    out = tmp_path / "a_file" / "out"
    status, err = _run([*_argv(argv, _files(inputs), tmp_path), str(out)])
    assert status == 2
    assert err.strip() == (
        f"torquemap: error: {out}: cannot create output folder: {tmp_path / 'a_file'} is a "
        "file, not a folder"
    )
