"""Kernel of :mod:`dcstereo.consistency`: fill a pixel from its most similar neighbour."""

import numba as nb
import numpy as np

#: The eight directions searched, in the order that settles ties: right, left, down, up,
#: then the diagonals.
DIRECTIONS = ((1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (-1, -1), (1, -1), (-1, 1))


@nb.njit(cache=True, parallel=True)
def nearest_similar(disparity, wanted, colour, out):
    """For each ``wanted`` pixel: the estimate of the most similar pixel met along 8 lines.

    Along each direction of :data:`DIRECTIONS` the first pixel with a finite disparity is
    met; of those met, the one whose colour (``colour[c, y, x]``, summed absolute
    differences over the channels) is closest to the pixel's gives ``out[y, x]`` (the
    first in the order of the directions on ties); NaN where none is met. Other pixels
    get ``disparity``'s value.
    """
    height, width = disparity.shape
    channels = colour.shape[0]
    steps = np.array(DIRECTIONS, dtype=np.int64)
    for y in nb.prange(height):
        for x in range(width):
            out[y, x] = disparity[y, x]
            if not wanted[y, x]:
                continue
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
            out[y, x] = best
