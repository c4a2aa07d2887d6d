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


def test_a_memo_inside_another_wraps_the_function_itself() -> None:
    # the demo fixture opens a session memo while a module's memo may be open: the inner one
    # computes with the real function (not through the outer memo, whose dict it must not
    # fill), and closing each restores what was there
    from _reuse import _real, reused

    from torquemap.linearize import tables, transfer

    real_build, real_move = tables.build_tables, transfer.transfer_characterisation
    outer: dict[str, Any] = {}
    with reused(outer):
        wrapped = tables.build_tables
        assert wrapped is not real_build and wrapped.__wrapped__ is real_build
        with reused({}):
            assert tables.build_tables is not wrapped
            assert tables.build_tables.__wrapped__ is real_build
            assert transfer.transfer_characterisation.__wrapped__ is real_move
            assert _real(tables.build_tables) is real_build
        assert tables.build_tables is wrapped
    assert tables.build_tables is real_build
    assert transfer.transfer_characterisation is real_move
    assert not outer
