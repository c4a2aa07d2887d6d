"""Keep the memory the process frees for its next arrays (glibc's ``mallopt``).

By default glibc maps every allocation above a threshold (128 KiB, raised as such blocks are
freed, at most 32 MiB) afresh with ``mmap`` and hands the top of its heap back to the system
once more than a threshold is free. Every such array is then new pages, and each page costs a
fault on first touch (zeroing 4 KiB and a trip through the kernel: 1-3 us measured on the
shared test machine, a few times more than the arithmetic the page holds). The estimate of a
long log allocates the same few arrays block after block: the low-pass of the whole-log
model's sigma alone needs ``8 (n + 2 pad) p`` bytes per piece (205 MB for a 2^19-sample block
and 46 parameters), mapped and faulted anew for every joint of every block (50 000 faults, a
third of that kernel's time). Raising both thresholds keeps freed memory in the heap for the
next block: no faults after the first block, at the price of the process not returning memory
to the system before it exits (its peak is unchanged: the peak is the largest block's).
The command line does this (:func:`torquemap.cli.main.main`); a library user who wants it
calls :func:`retain_freed_memory` or sets ``MALLOC_MMAP_THRESHOLD_`` and
``MALLOC_TRIM_THRESHOLD_`` in the environment.
"""

from __future__ import annotations

import ctypes
import os

#: Allocations below this many bytes come from the heap, and the heap keeps up to this many
#: bytes free at its top (glibc's ``M_MMAP_THRESHOLD`` and ``M_TRIM_THRESHOLD``).
RETAIN_BYTES = 1 << 30
#: Extra bytes the heap grows by when it must grow (``M_TOP_PAD``): fewer ``brk`` calls.
TOP_PAD_BYTES = 64 << 20

_M_TRIM_THRESHOLD = -1
_M_TOP_PAD = -2
_M_MMAP_THRESHOLD = -3


def is_glibc() -> bool:
    """Whether the process runs on glibc (where ``mallopt`` is)."""
    try:
        return (os.confstr("CS_GNU_LIBC_VERSION") or "").startswith("glibc")
    except (AttributeError, OSError, ValueError):
        return False


def retain_freed_memory() -> bool:
    """Make glibc keep freed memory for reuse instead of unmapping it; True if set.

    A no-op returning False where the C library is not glibc (macOS, Windows, musl).

    Examples
    --------
    >>> isinstance(retain_freed_memory(), bool)
    True
    """
    if not is_glibc():
        return False
    try:
        libc = ctypes.CDLL(None)
        settings = (
            (_M_MMAP_THRESHOLD, RETAIN_BYTES),
            (_M_TRIM_THRESHOLD, RETAIN_BYTES),
            (_M_TOP_PAD, TOP_PAD_BYTES),
        )
        return all(int(libc.mallopt(option, value)) == 1 for option, value in settings)
    except (AttributeError, OSError, ValueError):
        return False
