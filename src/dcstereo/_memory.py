"""Keep the kernels' work buffers mapped from call to call (glibc's malloc thresholds).

Every call of the band kernels allocates its work buffers afresh (a few MB per band of
rows: costs, DP table, vertical sums). glibc serves allocations above its mmap threshold
(128 KiB at start) with fresh mappings and returns freed heap tops above its trim
threshold to the system, so each call page-faulted and zero-filled its buffers again: on
cones, about 4,400 page faults and 7 ms of a 22 ms ``dsi5`` call. glibc raises both
thresholds by itself after the first free of a large mapped block, so whether a process
paid this depended on what it had freed before (numpy's temporaries used to do it).

``keep_work_buffers`` sets the two thresholds to the ceilings glibc's own adjustment
reaches on 64-bit systems (32 MiB, and 64 MiB for the trim), once, at import: freed
buffers stay in the heap and the next call reuses them. Set ``DCSTEREO_KEEP_MALLOC=1`` to
leave the allocator alone. Other C libraries and systems are not touched.
"""

import ctypes
import os
import sys

#: glibc's ceiling for its dynamic mmap threshold on 64-bit systems, and twice it for the
#: trim threshold (the values its own adjustment would end at).
MMAP_THRESHOLD = 32 * 2**20
TRIM_THRESHOLD = 2 * MMAP_THRESHOLD

_M_TRIM_THRESHOLD = -1  # mallopt parameters, <malloc.h>
_M_MMAP_THRESHOLD = -3


def keep_work_buffers() -> bool:
    """Raise glibc's mmap and trim thresholds; return whether they were set."""
    if os.environ.get("DCSTEREO_KEEP_MALLOC") or not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    if not hasattr(libc, "gnu_get_libc_version"):  # not glibc: its mallopt differs
        return False
    mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
    mallopt.restype = ctypes.c_int
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)) and bool(
        mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD)
    )


#: Whether the thresholds were set when dcstereo was imported.
KEPT = keep_work_buffers()
