"""Slow, obviously correct twin of the sparse census (``kernels.census_sparse``)."""

import numpy as np


def sparse_census(signal, rows, cols, step):
    """Census codes over samples ``step`` apart, edges repeated (raster order, centre out)."""
    height, width = signal.shape
    out = np.zeros((height, width), dtype=np.uint64)
    for y in range(height):
        for x in range(width):
            code = 0
            for i in range(-(rows // 2), rows // 2 + 1):
                for j in range(-(cols // 2), cols // 2 + 1):
                    if i == 0 and j == 0:
                        continue
                    yy = min(max(y + step * i, 0), height - 1)
                    xx = min(max(x + step * j, 0), width - 1)
                    code = code * 2 + int(signal[yy, xx] < signal[y, x])
            out[y, x] = code
    return out
