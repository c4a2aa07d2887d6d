"""``numba.njit(cache=True)`` with the decorated function's own type (for mypy).

The compiled kernels (:mod:`torquemap._kernels`) are plain functions on contiguous float64
arrays, compiled once per signature on first call and cached on disk (``cache=True``: later
processes load the machine code instead of compiling it). No fast-math: a kernel performs the
same floating-point operations in the same order as the numpy/scipy code it replaces, so its
numbers are that code's to rounding (most are bit for bit).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar, cast

_F = TypeVar("_F", bound=Callable[..., Any])


def jit(function: _F) -> _F:
    """Compile ``function`` with numba (nopython mode, cached on disk)."""
    import numba

    return cast(_F, numba.njit(cache=True, nogil=True)(function))
