"""Kernel of :mod:`dcstereo.refine.consistency`: fill occlusions and mismatches in one pass."""

import numba as nb
import numpy as np

#: The eight directions searched for a mismatched pixel, in the order that settles ties:
#: right, left, down, up, then the diagonals.
DIRECTIONS = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1), (1, -1), (-1, 1))


@nb.njit(cache=True)
def _nearest_similar(disparity, colour, y, x, steps):
    """Return the estimate of the most similar pixel met first along the 8 directions.

    Along each direction the first pixel with a finite disparity is met; of those met, the
    one whose colour (summed absolute differences over the channels of ``colour[c, y,
    x]``) is closest to the pixel's wins (the first direction on ties). NaN if none.
    """
    height, width = disparity.shape
    channels = colour.shape[0]
    best = np.nan
    best_distance = 1 << 62
    for i in range(steps.shape[0]):
        dx, dy = steps[i, 0], steps[i, 1]
        xx, yy = x + dx, y + dy
        while 0 <= xx < width and 0 <= yy < height and np.isnan(disparity[yy, xx]):
            xx += dx
            yy += dy
        if not (0 <= xx < width and 0 <= yy < height):
            continue
        distance = 0
        for c in range(channels):
            distance += abs(np.int64(colour[c, y, x]) - np.int64(colour[c, yy, xx]))
        if distance < best_distance:
            best_distance = distance
            best = disparity[yy, xx]
    return best


@nb.njit(cache=True, parallel=True)
def fill_rows(disparity, mismatched, colour, out):
    """Fill every NaN of ``disparity`` into ``out`` (the other pixels copied).

    A ``mismatched`` pixel takes :func:`_nearest_similar`'s estimate; any other, or a
    mismatched one with none, the background: the smaller of the nearest finite estimates
    to its left and right on its row (the one there is, if only one; NaN if none), as
    :func:`dcstereo.fill_occlusions`. Only the estimates of ``disparity`` are read, never
    a filled value.
    """
    height, width = disparity.shape
    steps = np.array(DIRECTIONS, dtype=np.int64)
    for y in nb.prange(height):
        before = np.empty(width, dtype=np.float32)  # the nearest estimate at or left of x
        last = np.float32(np.nan)
        for x in range(width):
            if not np.isnan(disparity[y, x]):
                last = disparity[y, x]
            before[x] = last
        after = np.float32(np.nan)
        for x in range(width - 1, -1, -1):
            value = disparity[y, x]
            if not np.isnan(value):
                after = value
                out[y, x] = value
                continue
            if mismatched[y, x]:
                similar = _nearest_similar(disparity, colour, y, x, steps)
                if not np.isnan(similar):
                    out[y, x] = similar
                    continue
            left = before[x]
            if np.isnan(left):
                out[y, x] = after
            elif np.isnan(after):
                out[y, x] = left
            else:
                out[y, x] = min(left, after)
