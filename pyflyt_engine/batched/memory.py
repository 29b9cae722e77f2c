"""The process's heap kept from step to step, so a batched step's big arrays do not fault.

A batched step allocates and frees arrays of up to a few MiB (an observation of 4096 envs
is 655 KiB; a swarm's of 4096 slots more).  glibc's ``malloc`` gives the top of its heap
back to the kernel once more than its trim threshold is free there (by default twice its
mmap threshold, which grows to the largest chunk freed so far) and takes it again at the next
allocation; every page taken again faults when first touched.  Which sequence of sizes sets
this off is a matter of chance: on a 2-core AMD EPYC VM, QuadX-Hover at N = 4096 and 64
worlds of 64 hovering agents took 500-800 such faults a step, 12-15 % of their CPU time in
the kernel (``experiments/speed_page_faults.py``), and removing one copy moved the faults
from one of them to the other.  :func:`keep_heap` sets glibc's two thresholds once per
process, as a batched env is made: arrays up to 32 MiB come from the heap (glibc's own upper
bound for its moving mmap threshold) and up to 64 MiB freed at its top stay in the process.
The cost: the process's resident memory may stay up to 64 MiB above what it uses.

Elsewhere than glibc (macOS, musl) it does nothing; ``PYFLYT_KEEP_HEAP=0`` in the
environment leaves the allocator as it is.
"""

from __future__ import annotations

import ctypes
import os
import platform

#: glibc's mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
#: the thresholds set: allocations up to this come from the heap ...
MMAP_THRESHOLD = 32 << 20
#: ... and up to this much freed at the heap's top stays in the process
TRIM_THRESHOLD = 64 << 20

_kept: bool | None = None


def keep_heap() -> bool:
    """Set glibc's mmap and trim thresholds (:data:`MMAP_THRESHOLD`, :data:`TRIM_THRESHOLD`)
    once per process; whether they are set (False elsewhere than glibc, or with
    ``PYFLYT_KEEP_HEAP=0``)."""
    global _kept
    if _kept is None:
        _kept = False
        if os.environ.get("PYFLYT_KEEP_HEAP", "1") != "0" and platform.libc_ver()[0] == "glibc":
            mallopt = ctypes.CDLL(None).mallopt
            mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
            # both or neither: setting one ends glibc's moving thresholds for both
            _kept = bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(
                mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)
            )
    return _kept


__all__ = ["MMAP_THRESHOLD", "TRIM_THRESHOLD", "keep_heap"]
