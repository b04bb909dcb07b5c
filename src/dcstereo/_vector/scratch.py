"""Scratch arrays at chosen offsets within a 4 KiB page (the band kernels' buffers)."""

import numba as nb
import numpy as np

from dcstereo._vector.simd import _address

# --------------------------------------------------------------------------- scratch
#
# Where each scratch array of ``match_band_rows`` starts within a 4 KiB page is chosen,
# not left to the allocator. The core guesses whether a load depends on an earlier store
# from the low 12 bits of the two addresses, so arrays that start at the same offset in a
# page and are read and written with the same index in one loop (the DP's column ring,
# the cost column, the vertical sums, the spread signal) stall on false dependencies. The
# allocator's offsets depend on what was allocated before, so the same call ran at
# different speeds in different processes and threads. On the 6-megapixel pair (dsi5,
# 2 threads) the worker thread's ring rows fell on the offsets of the spread signal, the
# vertical sums and their running sum: its half of the work took 1.7 s against the main
# thread's 1.3 s. Every array on one offset made a strip 3000 x 256 x 256 16 % slower and
# tsukuba 17 % (A/B in one process).

#: Bytes between the page offsets of consecutive scratch arrays (7 cache lines: 7 and 64
#: are coprime, so 64 arrays get 64 different lines).
PLACE_STEP = 448
_PAGE = 4096


@nb.njit(cache=True, inline="always")
def _placed(n, dtype, slot):
    """Return an uninitialised 1-d array of ``n`` values at ``slot * PLACE_STEP`` in a page.

    ``slot * PLACE_STEP % 4096`` bytes past the start of a page; ``n + 4096`` values are
    allocated for it.
    """
    buf = np.empty(n + _PAGE, dtype=dtype)
    page = np.uint64(_PAGE)
    shift = (np.uint64(slot * PLACE_STEP % _PAGE) + page - _address(buf) % page) % page
    start = shift // np.uint64(buf.itemsize)
    return buf[start : start + n]
