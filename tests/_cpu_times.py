"""A pytest plugin for measuring the suite: the CPU time (process time) of each test's phases.

Not loaded by default. Under a loaded machine the wall times of ``--durations`` grow with the
load; the CPU time each worker spends on a test much less so (docs/performance.md, "Test suite
time, stop 40"). Run, for example::

    PYTHONPATH=$PWD/src:$PWD/tests CPU_TIMES=/tmp/cpu .venv/bin/pytest -p _cpu_times \
        -n 2 --dist loadgroup -q

Each process appends ``cpu_seconds<TAB>wall_seconds<TAB>phase<TAB>nodeid`` lines to
``$CPU_TIMES.<pid>`` (one file per xdist worker); sum them with, e.g.,
``cat /tmp/cpu.* | awk -F'\\t' '{s += $1} END {print s}'``. A session fixture's cost lands in
the setup of the first test that asks for it; time spent waiting on another worker's build of
a shared fixture (conftest.py, ``_built_once``) is not CPU time and is not counted.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Generator
from typing import Any, TextIO

import pytest

_out: list[TextIO] = []


def _write(nodeid: str, phase: str, cpu: float, wall: float) -> None:
    if not _out:
        prefix = os.environ.get("CPU_TIMES", "cpu_times")
        _out.append(open(f"{prefix}.{os.getpid()}", "a", encoding="utf-8"))
    _out[0].write(f"{cpu:.3f}\t{wall:.3f}\t{phase}\t{nodeid}\n")
    _out[0].flush()


def _timed(phase: str) -> Callable[..., Generator[None, Any, None]]:
    @pytest.hookimpl(hookwrapper=True)
    def hook(item: pytest.Item) -> Generator[None, Any, None]:
        cpu, wall = time.process_time(), time.perf_counter()
        yield
        _write(item.nodeid, phase, time.process_time() - cpu, time.perf_counter() - wall)

    return hook


pytest_runtest_setup = _timed("setup")
pytest_runtest_call = _timed("call")
pytest_runtest_teardown = _timed("teardown")
