"""Freed memory kept by the C allocator for the next fit (glibc's malloc).

A fit allocates its work arrays (sensitivities, the coloured-residual
correction's transforms: several MB for a 1,500-sample record) and frees them
at its end.  glibc by default returns large freed blocks to the system, so the
next fit's arrays arrive as fresh pages, each a page fault the kernel serves:
a third of an ATTAS lateral fit's CPU time, a fifth of HFB-320's
(benchmarks/bench_stage_eval.py).  Raising the allocator's mmap and trim
thresholds keeps those pages in the process, and the next fit reuses them.

This is process-wide (the allocator is the process's); ``MLID_MALLOC=system``
in the environment before mlid is imported leaves it as it was.  Elsewhere
than glibc (no ``mallopt``) nothing is done.  The values computed do not
depend on it: only where the arrays live.
"""

import ctypes
import os

#: glibc's mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: Blocks up to this size come from the heap, not their own mapping (glibc's
#: largest allowed on 64-bit).
MMAP_THRESHOLD = 32 * 2**20
#: Free memory at the heap's top up to this size is kept, not returned.
TRIM_THRESHOLD = 128 * 2**20


def keep_freed_memory():
    """Set glibc's thresholds (MMAP_THRESHOLD, TRIM_THRESHOLD) unless
    MLID_MALLOC=system; True when they were set."""
    if os.environ.get("MLID_MALLOC", "").strip().lower() == "system":
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    # both set: setting either one also stops glibc adjusting them itself
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and \
        bool(mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD))
