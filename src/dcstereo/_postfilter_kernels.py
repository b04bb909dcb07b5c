"""Compiled kernel of ``postfilter.py``: the median of the estimates in a window."""

import numba as nb
import numpy as np


@nb.njit(cache=True, parallel=True)
def median_rows(disparity, moved, radius, out):
    """Write into ``out`` the median of the finite values in each moved pixel's window.

    ``out`` starts as a copy of ``disparity``. A pixel with ``moved[y, x]`` takes the median
    of the finite values of ``disparity`` in the ``(2 radius + 1)`` square around it, cut at
    the image's edges (the pixel's own value is one of them, so there is at least one); of
    an even count, the mean of the middle two (as ``numpy.nanmedian``). The values are
    kept sorted by insertion as they are read. Returns nothing; rows run in parallel.
    """
    height, width = disparity.shape
    side = 2 * radius + 1
    for y in nb.prange(height):
        values = np.empty(side * side, dtype=np.float32)
        top = max(0, y - radius)
        bottom = min(height, y + radius + 1)
        for x in range(width):
            if not moved[y, x]:
                continue
            left = max(0, x - radius)
            right = min(width, x + radius + 1)
            n = 0
            for yy in range(top, bottom):
                for xx in range(left, right):
                    value = disparity[yy, xx]
                    if not np.isfinite(value):
                        continue
                    j = n
                    while j > 0 and values[j - 1] > value:
                        values[j] = values[j - 1]
                        j -= 1
                    values[j] = value
                    n += 1
            half = n // 2
            if n % 2 == 1:
                out[y, x] = values[half]
            else:
                middle = 0.5 * (np.float64(values[half - 1]) + np.float64(values[half]))
                out[y, x] = np.float32(middle)
