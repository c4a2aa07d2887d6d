"""tests/_reuse.py, the memo of the linearisation modules' table builds: it keeps a result only
for arguments equal by value, and never lets one test's changes reach another."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from _reuse import memoised


@dataclasses.dataclass(frozen=True)
class _Spec:
    name: str
    ramp: np.ndarray
    path: str | None = None


def _counted() -> tuple[list[int], Any]:
    calls: list[int] = []

    def build(spec: _Spec, rows: Any, *, scale: float = 10.0, path: str | None = None) -> Any:
        calls.append(1)
        if np.any(np.asarray(rows) < 0):
            raise ValueError(f"{path}: negative rows")
        return {"out": np.asarray(rows, dtype=np.float64) * scale}

    return calls, memoised(build, {})


def test_equal_arguments_are_built_once() -> None:
    calls, build = _counted()
    ramp = np.arange(6.0).reshape(3, 2)
    first = build(_Spec("m", ramp), np.array([1, 2]))
    # another object with the same values, the default spelt out, another file name, a
    # NumPy scalar for a Python one: the same call
    again = build(
        _Spec("m", ramp.copy(), path="m.toml"), np.array([1, 2]), scale=np.float64(10.0), path="d"
    )
    assert len(calls) == 1
    np.testing.assert_array_equal(first["out"], again["out"])
    # a change of any value, or of the rows' dtype, is another call
    build(_Spec("m", ramp + 1e-12), np.array([1, 2]))
    build(_Spec("n", ramp), np.array([1, 2]))
    build(_Spec("m", ramp), np.array([1, 2], dtype=np.int32))
    build(_Spec("m", ramp), np.array([1, 2]), scale=10.5)
    assert len(calls) == 5


def test_a_raising_call_is_not_kept_and_a_result_is_not_shared() -> None:
    calls, build = _counted()
    spec = _Spec("m", np.zeros(2))
    for path in ("a.csv", "b.csv"):
        with pytest.raises(ValueError, match=f"{path}: negative rows"):
            build(spec, np.array([-1]), path=path)
    assert len(calls) == 2
    got = build(spec, np.array([1, 2]))
    got["out"][:] = -5.0  # a test that changes what it got
    np.testing.assert_array_equal(build(spec, np.array([1, 2]))["out"], [10.0, 20.0])
    assert len(calls) == 3
