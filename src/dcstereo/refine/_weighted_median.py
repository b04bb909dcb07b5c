"""The colour-weighted median's kernels (:mod:`dcstereo.refine.weighted_median`)."""

import numba as nb
import numpy as np


@nb.njit(cache=True, inline="always")
def weighted_select(values, weights, n, total):
    """Return the least of ``values[:n]`` whose weight with those below it is half ``total``.

    The weighted median: the least ``v`` with ``2 * (weights of the values <= v) >=
    total``; ``weights`` are integers (int64), ``total`` their sum, so that the sums are
    exact in any order. A three-way partition around the middle element, kept on the side
    that holds the answer (``values`` and ``weights`` are reordered together).
    """
    lo, hi = 0, n
    below = 0  # the weight of the values known to lie below values[lo:hi]
    while True:
        pivot = values[(lo + hi) // 2]
        # [lo, lt): < pivot, [lt, i): == pivot, [gt, hi): > pivot
        lt, i, gt = lo, lo, hi
        w_less = 0
        w_equal = 0
        while i < gt:
            v = values[i]
            if v < pivot:
                values[i], values[lt] = values[lt], v
                weights[i], weights[lt] = weights[lt], weights[i]
                w_less += weights[lt]
                lt += 1
                i += 1
            elif v > pivot:
                gt -= 1
                values[i], values[gt] = values[gt], v
                weights[i], weights[gt] = weights[gt], weights[i]
            else:
                w_equal += weights[i]
                i += 1
        if 2 * (below + w_less) >= total:
            hi = lt
        elif 2 * (below + w_less + w_equal) >= total:
            return pivot
        else:
            below += w_less + w_equal
            lo = gt


@nb.njit(cache=True, parallel=True)
def weighted_median_rows(disparity, colour, moved, radius, colour_weight, space_weight, out):
    """Write into ``out`` the colour-weighted median of each moved pixel's window.

    ``disparity`` float32 ``(H, W)``, NaN: no estimate; ``colour`` the guide, ``(C, H, W)``
    integer levels 0..255; ``out`` starts as a copy of ``disparity``. A pixel with
    ``moved[y, x]`` takes the weighted median (:func:`weighted_select`) of the finite values
    of the ``(2 radius + 1)`` square around it, cut at the image's edges, each weighted by
    ``colour_weight[g] * space_weight[dy + radius, dx + radius]``, ``g`` the largest
    difference of a channel between that pixel and the centre (both tables int64). Rows run
    in parallel.
    """
    height, width = disparity.shape
    channels = colour.shape[0]
    side = 2 * radius + 1
    for y in nb.prange(height):
        values = np.empty(side * side, dtype=np.float32)
        weights = np.empty(side * side, dtype=np.int64)
        for x in range(width):
            if not moved[y, x]:
                continue
            n = 0
            total = 0
            for yy in range(max(0, y - radius), min(height, y + radius + 1)):
                for xx in range(max(0, x - radius), min(width, x + radius + 1)):
                    v = disparity[yy, xx]
                    if not np.isfinite(v):
                        continue
                    g = 0
                    for c in range(channels):
                        g = max(g, abs(np.int64(colour[c, yy, xx]) - np.int64(colour[c, y, x])))
                    w = colour_weight[g] * space_weight[yy - y + radius, xx - x + radius]
                    values[n] = v
                    weights[n] = w
                    total += w
                    n += 1
            out[y, x] = weighted_select(values, weights, n, total)
