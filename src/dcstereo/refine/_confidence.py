"""Compiled kernel of :mod:`dcstereo.refine.confidence`: each pixel's margin over its best rival."""

import numba as nb
import numpy as np

from dcstereo.costs.window import _row_costs_any
from dcstereo.scanline.rows import chunk_bounds


@nb.njit(parallel=True, cache=True)
def confidence_rows(left_p, right_p, disparity, wanted, dmin, ndisp, radius, bt, nchunks, out):
    """Write into ``out`` the margin of each wanted pixel's disparity over its best rival.

    With ``C`` the row's window costs (``_row_costs_any``), ``c`` the least of ``C`` at
    ``floor(d)`` and ``ceil(d)``, and ``r`` the least ``C`` at the disparities two or more
    from ``d``: ``(r - c) / r``, at least -1 (0 when both are 0: a tie in a flat window);
    NaN when no rival has a cost. ``out`` holds NaN at the other pixels already.
    """
    height, width = disparity.shape
    for ch in nb.prange(nchunks):
        y0, y1 = chunk_bounds(height, nchunks, ch)
        cost = np.empty((width, ndisp), dtype=np.float64)
        vcol = np.empty((width, ndisp), dtype=np.int32)
        for y in range(y0, y1):
            _row_costs_any(left_p, right_p, y, dmin, ndisp, radius, vcol, cost, y > y0, bt)
            for x in range(width):
                if not wanted[y, x]:
                    continue
                v = disparity[y, x] - dmin
                lo = int(np.floor(v))
                hi = int(np.ceil(v))
                c = min(cost[x, lo], cost[x, hi])
                # the rivals, |k - v| >= 2: k <= lo - 2 and k >= hi + 2 (for a whole, a
                # half and any fractional v alike), two runs without a test per cell
                r = np.inf
                for k in range(0, max(0, lo - 1)):
                    r = min(r, cost[x, k])
                for k in range(hi + 2, ndisp):
                    r = min(r, cost[x, k])
                if r == np.inf:
                    continue
                if r > 0.0:
                    out[y, x] = max((r - c) / r, -1.0)
                else:
                    out[y, x] = 0.0 if c == 0.0 else -1.0
