"""Shared fixtures: the simulated benches, identified models and the demo, run once per session.

The expensive ones run the tutorial's own command lines (docs/tutorial.md), so that
tests/test_tutorial.py checks what they printed instead of running them again. Under
``pytest -n 2`` each worker has its own session: test_demo and test_tutorial, which share the demo
(21 s of CPU), carry ``xdist_group("demo")`` so that one worker runs it once (``--dist
loadgroup``, in the Makefile); the bench (9 s), its two identifications and the VR rig are built
once for the whole run, by the first worker that asks, in a folder both share (``_built_once``).
"""

from __future__ import annotations

import os

# One BLAS thread per test process, set before numpy loads (workers of `pytest -n 2` inherit it):
# two workers with OpenBLAS's default of one thread per core oversubscribe a two-core machine,
# and its spinning threads doubled the CPU time of the tests measured (test_denoise + test_tables
# + test_kinematics, one process: 10.5 s user with the default, 4.8 s with one thread).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import contextlib  # noqa: E402
import importlib.util  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import shutil  # noqa: E402
import sys  # noqa: E402
from collections.abc import Callable, Iterator  # noqa: E402
from dataclasses import dataclass  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import pytest  # noqa: E402

# the autouse fixture of the modules that set REUSE_BUILDS: their table builds, computed once
from _reuse import SESSION, _reused_builds, reused  # noqa: E402, F401

from torquemap import progress  # noqa: E402


@pytest.fixture(autouse=True)
def _no_progress_lines(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """No step lasts long enough to be reported: stderr holds only what a test checks.

    The CLI reports steps over 2 s (torquemap.progress.SHOW_AFTER); on a loaded machine any step
    may take that long, which would make stderr depend on the load. tests/test_progress.py sets
    the threshold it tests.
    """
    monkeypatch.setattr(progress, "SHOW_AFTER", math.inf)
    yield


def _tutorial() -> Any:
    """docs/gen_tutorial.py as a module: the tutorial's parser and command runner."""
    name = "gen_tutorial"
    if name not in sys.modules:
        path = Path(__file__).parents[1] / "docs" / "gen_tutorial.py"
        spec = importlib.util.spec_from_file_location(name, path)
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


@pytest.fixture(scope="session")
def tutorial() -> Any:
    """docs/gen_tutorial.py: ``parse``, ``run`` (one command, what it prints), ``masked``."""
    return _tutorial()


@dataclass(frozen=True)
class Ran:
    """Tutorial commands run once for the session in ``folder``: what each printed."""

    folder: Path
    printed: dict[str, str]


def _run_in(folder: Path, commands: list[str]) -> Ran:
    gen = _tutorial()
    printed = {}
    with gen.working_directory(folder):
        for command in commands:
            printed[command] = gen.run(command)
    return Ran(folder, printed)


def _built_once(
    tmp_path_factory: pytest.TempPathFactory, name: str, build: Callable[[Path], None]
) -> Path:
    """The folder ``name`` that ``build(folder)`` fills, built once for the whole test run.

    Under ``pytest -n 2`` each worker has its own session, so a session fixture runs once per
    worker; the folder here is shared by the workers of one run (the parent of their base
    temporary folders, new for every run) and built by whichever asks first while the other
    waits on a lock, then reads it. Without xdist it is an ordinary temporary folder. A build
    that fails leaves no mark, so the next worker builds again (and fails alike).
    """
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        folder = tmp_path_factory.mktemp(name)
        build(folder)
        return folder
    import fcntl

    root = tmp_path_factory.getbasetemp().parent
    folder, done = root / f"shared-{name}", root / f"shared-{name}.done"
    with open(root / f"shared-{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when the file closes
        if not done.exists():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            build(folder)
            done.touch()
    return folder


def _ran_once(
    tmp_path_factory: pytest.TempPathFactory,
    name: str,
    commands: list[str],
    *,
    prepare: Callable[[Path], None] | None = None,
) -> Ran:
    """:func:`_run_in` of tutorial ``commands`` (after ``prepare(folder)``) in a folder built once
    for the run (:func:`_built_once`); what they printed is kept beside it."""

    def build(folder: Path) -> None:
        if prepare is not None:
            prepare(folder)
        printed = _run_in(folder, commands).printed
        (folder / "printed.json").write_text(json.dumps(printed), encoding="utf-8")

    folder = _built_once(tmp_path_factory, name, build)
    printed = json.loads((folder / "printed.json").read_text(encoding="utf-8"))
    return Ran(folder, printed)


#: The tutorial's bench: the simulated SCARA with the default seed 0.
SIMULATE_SCARA = "torquemap simulate scara --out bench"
#: The tutorial's identify, run on the session's bench (shared with the CLI estimate tests).
IDENTIFY = "torquemap identify bench/robot.toml bench/sweep.csv -o bench/model.toml"
#: The tutorial's rig: the simulated VR motor with the default collection (the demo's too).
RIG_VR = "torquemap simulate rig --motor vr --out rig"


@pytest.fixture(scope="session")
def scara_run(tmp_path_factory: pytest.TempPathFactory) -> Ran:
    """The tutorial's ``torquemap simulate scara --out bench``, run once for the test run (both
    workers: 9 s of CPU): folder/bench."""
    return _ran_once(tmp_path_factory, "scara", [SIMULATE_SCARA])


@pytest.fixture(scope="session")
def scara_bench(scara_run: Ran) -> Path:
    """The simulated SCARA bench written with seed 0; returns its folder.

    The folder holds robot.toml, sweep.csv, circle.csv, truth.csv and truth.toml
    (docs/formats.md). Treat it as read-only: every test of the session shares it.
    """
    return scara_run.folder / "bench"


@pytest.fixture(scope="session")
def scara_identified(scara_bench: Path, tmp_path_factory: pytest.TempPathFactory) -> Ran:
    """The tutorial's ``identify`` run once beside links to the bench: folder/bench/model.toml.

    Read-only, like the bench: copy what a test wants to change. Run once for the test run
    (both workers), and it is also ``scara_model``: the tutorial's command line leaves
    ``--friction`` at its default, the whole fit.
    """

    def link_bench(folder: Path) -> None:
        (folder / "bench").mkdir()
        for path in scara_bench.iterdir():
            (folder / "bench" / path.name).symlink_to(path)

    return _ran_once(tmp_path_factory, "scara_identified", [IDENTIFY], prepare=link_bench)


#: Mark of the tests that take ``scara_model``: one worker runs them, so it is built once.
WHOLE_MODEL = pytest.mark.xdist_group("scara_model")


@pytest.fixture(scope="session")
def scara_model(scara_identified: Ran) -> Path:
    """The model ``torquemap identify --friction whole`` writes from the bench's sweeps.

    Returns the model file's path: that of ``scara_identified``, whose command line leaves
    ``--friction`` at its default, checked here to be ``whole`` (the same model byte for byte).
    Shared: identification is the expensive step.
    """
    from torquemap.cli.main import build_parser, subparsers

    default = subparsers(build_parser())["identify"].get_default("friction")
    assert default == "whole" and "--friction" not in IDENTIFY, (default, IDENTIFY)
    return scara_identified.folder / "bench" / "model.toml"


@pytest.fixture(scope="session")
def scara_passes(scara_bench: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The model ``torquemap identify --friction passes`` (the paper's pass method) writes from
    the bench's sweeps: for the tests of what a pass-method model does. Built once for the test
    run (both workers)."""
    from torquemap.cli.main import main

    def build(folder: Path) -> None:
        argv = ["identify", str(scara_bench / "robot.toml"), str(scara_bench / "sweep.csv")]
        assert main([*argv, "-o", str(folder / "model.toml"), "--friction", "passes"]) == 0

    return _built_once(tmp_path_factory, "scara_passes", build) / "model.toml"


@pytest.fixture(scope="session")
def vr_rig(tmp_path_factory: pytest.TempPathFactory) -> Ran:
    """The tutorial's ``simulate rig --motor vr`` run once for the test run (both workers):
    folder/rig/motor.toml and data.csv."""
    return _ran_once(tmp_path_factory, "vr_rig", [RIG_VR])


@dataclass(frozen=True)
class DemoRun:
    """``torquemap demo --out demo-out`` run in ``folder``: its stdout and its stderr."""

    folder: Path
    out: str
    err: str


@pytest.fixture(scope="session")
def demo_run(
    scara_bench: Path,
    vr_rig: Ran,
    scara_model: Path,
    scara_passes: Path,
    tmp_path_factory: pytest.TempPathFactory,
) -> DemoRun:
    """The demo as ``make demo`` runs it, with progress reported as when piped (every step).

    Its two simulations with the default seed are the session's: the SCARA bench, a run of
    ``simulate scara`` (test_cli_simulate checks the command writes what the library does, as a
    function of the seed), and the VR rig, a run of ``simulate rig`` with the demo's settings
    (test_cli_rig checks runs are a function of their arguments). So are its two identifications
    of the bench's sweeps, ``identify_model(robot, [sweep])`` and ``friction="passes"``: the
    models ``identify`` wrote for the session (``scara_model``, ``scara_passes``; the demo
    keeps only their ``model``), read back when the log is the bench's sweep sample for sample,
    with the log's path the demo read (the models it writes are then the same byte for byte).
    Its table builds are kept for the worker's session (``tests/_reuse.py``): test_tutorial's
    ``linearize build`` of the VR rig is the same call. Everything else runs as in ``make demo``.
    """
    import dataclasses

    import numpy as np

    from torquemap import demo as demo_module
    from torquemap.cli.main import main
    from torquemap.identify import Identification
    from torquemap.io import Log, read_log
    from torquemap.model import load_model
    from torquemap.sim import bench as sim_bench
    from torquemap.sim import rig as sim_rig

    real_bench, real_rig = sim_bench.write_scara_bench, sim_rig.write_rig_data

    def bench_copy(out_dir: Any, *, seed: int = 0) -> None:
        if seed != 0:
            real_bench(out_dir, seed=seed)
            return
        shutil.copytree(scara_bench, out_dir, dirs_exist_ok=True)

    def rig_copy(out_dir: Any, **options: Any) -> Any:
        options.pop("progress", None)
        if options != {"motor": "vr", "seed": 0}:
            return real_rig(out_dir, **options)
        shutil.copytree(vr_rig.folder / "rig", out_dir, dirs_exist_ok=True)
        return None

    real_identify = demo_module.identify_model
    written = {None: scara_model, "passes": scara_passes}  # by friction (None: the default)

    def identify_read(robot: Any, logs: list[Log], **options: Any) -> Any:
        friction = options.get("friction")
        if set(options) <= {"friction"} and friction in written and len(logs) == 1:
            sweep = read_log(scara_bench / "sweep.csv", robot)
            if all(
                np.array_equal(getattr(logs[0], k), getattr(sweep, k))
                for k in ("t", "q", "motor_torque", "joint_names")
            ):
                model = load_model(written[friction])
                notes = {**model.notes, "logs": [logs[0].path]}  # where the demo read it
                return Identification(model=dataclasses.replace(model, notes=notes))
        return real_identify(robot, logs, **options)

    folder = tmp_path_factory.mktemp("demo_run")
    out, err = io.StringIO(), io.StringIO()
    # its table builds kept for test_tutorial, whose ``linearize build`` of the VR rig is the
    # same call (tests/_reuse.py; REUSE_LOG names the hits)
    with (
        reused(SESSION),
        pytest.MonkeyPatch.context() as patch,
        _tutorial().working_directory(folder),
    ):
        patch.setattr(sim_bench, "write_scara_bench", bench_copy)
        patch.setattr(sim_rig, "write_rig_data", rig_copy)
        patch.setattr(demo_module, "identify_model", identify_read)
        patch.setattr(progress, "SHOW_AFTER", 0.0)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            assert main(["demo", "--out", "demo-out"]) == 0
    return DemoRun(folder, out.getvalue(), err.getvalue())
