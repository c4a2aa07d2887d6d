"""``torquemap._memory``: freed memory reused instead of mapped (and faulted) anew."""

from __future__ import annotations

import ctypes
import os
import resource

import numpy as np
import pytest
from scipy import signal

from torquemap import _kernels as K
from torquemap._memory import is_glibc, retain_freed_memory

pytestmark = pytest.mark.xdist_group("kernels")


def _faults_of_lowpass(x: np.ndarray) -> int:
    """Minor page faults of one compiled low-pass of ``x`` (1, n), whose kernel allocates its
    (n + 2 pad, 4) work array and (1, n) output: 40 bytes per sample, in 4 KiB pages (numba's
    arrays, unlike numpy's large ones, are not given huge pages)."""
    sos = np.ascontiguousarray(signal.butter(2, 2.0, fs=2000.0, output="sos"))
    zi = np.ascontiguousarray(signal.sosfilt_zi(sos))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    K.sosfiltfilt_odd(sos, zi, x, 9)
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before


@pytest.mark.skipif(not is_glibc(), reason="mallopt is glibc's")
def test_a_kernels_arrays_reuse_freed_pages() -> None:
    n = 1 << 20
    x = np.random.default_rng(0).standard_normal((1, n))
    pages = 40 * n // 4096  # 10 240
    _faults_of_lowpass(x)  # compiled, and its arrays' sizes seen once
    # control: the arrays mapped afresh (every allocation above 128 KiB by mmap, the heap
    # trimmed above 128 KiB): the second call faults in most of its pages again
    libc = ctypes.CDLL(None)
    assert libc.mallopt(-3, 128 << 10) == 1 and libc.mallopt(-1, 128 << 10) == 1
    if _faults_of_lowpass(x) <= pages // 2:  # transparent huge pages on every mapping
        pytest.skip("this kernel maps the arrays in huge pages: no fault to save")
    # retained: after one call to size the heap, the next reuses its pages (the bound, a
    # hundredth of them, leaves room for the interpreter's own small allocations)
    assert retain_freed_memory()
    _faults_of_lowpass(x)
    assert _faults_of_lowpass(x) < pages // 100


def test_returns_false_without_glibc(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "confstr", lambda name: "musl")
    assert retain_freed_memory() is False
