"""The median post-filter's kernels (:mod:`dcstereo.refine.postfilter`): a window's median."""

import numba as nb
import numpy as np


@nb.njit(cache=True, inline="always")
def _insert_sorted(values, n, value):
    """Insert ``value`` into the sorted ``values[:n]``; return the new count."""
    j = n
    while j > 0 and values[j - 1] > value:
        values[j] = values[j - 1]
        j -= 1
    values[j] = value
    return n + 1


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
                    if np.isfinite(value):
                        n = _insert_sorted(values, n, value)
            half = n // 2
            if n % 2 == 1:
                out[y, x] = values[half]
            else:
                middle = 0.5 * (np.float64(values[half - 1]) + np.float64(values[half]))
                out[y, x] = np.float32(middle)


@nb.njit(cache=True, inline="always")
def _bucket_values(disparity, bins, top, bottom, left, right, first, last, values):
    """Put the window's values in buckets ``first..last`` into ``values``, sorted; count them."""
    n = 0
    for yy in range(top, bottom):
        for xx in range(left, right):
            if first <= bins[yy, xx] <= last:
                n = _insert_sorted(values, n, disparity[yy, xx])
    return n


@nb.njit(cache=True, parallel=True)
def median_rows_binned(disparity, bins, moved, radius, nbins, low, exact, out):
    """:func:`median_rows` by a histogram of value buckets slid along each row.

    ``bins[y, x]`` is the bucket of a pixel with an estimate ``d`` (:func:`value_buckets`:
    an integer in ``0 .. nbins - 1``, never smaller for a larger ``d``) and -1 for one
    without. Each row keeps the histogram of its window's buckets and the count of values
    below a pointer bucket (Huang, Yang and Tang, 1979): a step along the row adds the
    column entering the window and takes away the one leaving, and the pointer moves to the
    bucket that holds the middle value. ``exact``: every value is ``low + bucket / 2`` (a
    map of whole and half pixels), so the bucket is the value; otherwise the window's values
    in the middle bucket(s), a few, are sorted to find the middle one(s). Of an even count,
    the mean of the middle two, as :func:`median_rows`. Returns nothing; rows run in
    parallel.
    """
    height, width = bins.shape
    side = 2 * radius + 1
    for y in nb.prange(height):
        hist = np.empty(nbins, dtype=np.int32)  # no array expression: see value_buckets
        for b in range(nbins):
            hist[b] = 0
        values = np.empty(side * side, dtype=np.float32)
        top = max(0, y - radius)
        bottom = min(height, y + radius + 1)
        count = 0  # values in the window
        below = 0  # values in the window whose bucket is below the pointer
        pointer = 0
        for xx in range(min(width, radius + 1)):  # the window of x = 0
            for yy in range(top, bottom):
                b = bins[yy, xx]
                if b >= 0:
                    hist[b] += 1
                    count += 1
        for x in range(width):
            if x > 0:
                enter = x + radius
                leave = x - radius - 1
                if enter < width:
                    for yy in range(top, bottom):
                        b = bins[yy, enter]
                        if b >= 0:
                            hist[b] += 1
                            count += 1
                            if b < pointer:
                                below += 1
                if leave >= 0:
                    for yy in range(top, bottom):
                        b = bins[yy, leave]
                        if b >= 0:
                            hist[b] -= 1
                            count -= 1
                            if b < pointer:
                                below -= 1
            if not moved[y, x]:
                continue
            k = (count - 1) // 2  # the middle value's rank (of two, the lower)
            while below > k:  # the pointer bucket must hold rank k
                pointer -= 1
                below -= hist[pointer]
            while below + hist[pointer] <= k:
                below += hist[pointer]
                pointer += 1
            first = pointer
            if count % 2 == 1 or k + 1 < below + hist[pointer]:
                second = first
            else:  # rank k + 1 is in the next bucket that holds a value
                second = pointer + 1
                while hist[second] == 0:
                    second += 1
            if exact:
                middle = low + 0.25 * (first + second)  # the mean of low + bucket / 2 of both
            else:
                left = max(0, x - radius)
                right = min(width, x + radius + 1)
                # the buckets between the two middle ones hold no value: one scan for both
                _bucket_values(disparity, bins, top, bottom, left, right, first, second, values)
                rank = k - below  # of the lower middle value among the gathered ones
                if count % 2 == 1:
                    middle = np.float64(values[rank])
                else:
                    middle = 0.5 * (np.float64(values[rank]) + np.float64(values[rank + 1]))
            out[y, x] = np.float32(middle)


#: The finest buckets of a sub-pixel map, per pixel of disparity (finer: fewer values to
#: sort in the middle bucket, measured best up to here on the development scenes).
FINEST_BUCKETS = 128.0


@nb.njit(cache=True, parallel=True)
def value_buckets(disparity, max_bins, bins):
    """Fill ``bins`` with the histogram buckets ``floor(scale (d - low))`` (-1: no estimate).

    ``low`` is the least estimate. A map of whole and half pixels gets ``scale`` 2, one
    value to a bucket (``exact``: ``d = low + bucket / 2``); any other map the finest power
    of two up to :data:`FINEST_BUCKETS` whose buckets over the map's span number fewer than
    ``max_bins``. Returns ``(low, nbins, exact)``, or ``(0.0, 0, False)`` (``bins`` then
    unspecified) when the map has no estimate or no scale from 2 up fits.
    """
    height, width = disparity.shape
    # loops, not array expressions (np.full, .min()): numba makes each array expression of
    # a parallel function a parallel loop of its own, which only lengthens the compile
    lows = np.empty(height)
    highs = np.empty(height)
    halves = np.empty(height, dtype=np.bool_)
    for y in nb.prange(height):
        lows[y] = np.inf
        highs[y] = -np.inf
        halves[y] = True
        for x in range(width):
            v = np.float64(disparity[y, x])
            if not np.isfinite(v):
                continue
            lows[y] = min(lows[y], v)
            highs[y] = max(highs[y], v)
            if 2.0 * v != np.floor(2.0 * v):
                halves[y] = False
    low = np.inf
    high = -np.inf
    exact = True
    for y in range(height):
        low = min(low, lows[y])
        high = max(high, highs[y])
        exact = exact and halves[y]
    if not np.isfinite(low):
        return 0.0, 0, False
    span = high - low
    scale = 2.0 if exact else FINEST_BUCKETS
    while scale > 2.0 and scale * span >= max_bins:
        scale *= 0.5
    if scale * span >= max_bins:
        return 0.0, 0, False
    for y in nb.prange(height):
        for x in range(width):
            v = np.float64(disparity[y, x])
            bins[y, x] = np.int32(np.floor(scale * (v - low))) if np.isfinite(v) else -1
    return low, int(np.floor(scale * span)) + 1, exact


@nb.njit(cache=True)
def limit_inside(out, disparity, filled, least, largest, bottom, top):
    """Limit in place each changed value of ``out`` to the disparities its pixel can have.

    ``postfilter._inside``'s rule in one pass instead of numpy's dozen (every value changed:
    teddy 0.73 -> 0.54 ms, KITTI 000066 4.1 -> 1.7 ms, with the flags' test):
    where ``out`` differs from ``disparity`` (NaN differs), the value is clipped to ``[low,
    high]`` if that is not empty: ``bottom``..``top`` (float32, the searched range) for a
    filled pixel (``filled`` true), else that range cut to column ``x``'s ``least[x] ..
    largest[x]`` (``postfilter.right_image_bounds``: ``x - d`` inside the right image).
    NaN stays NaN.
    """
    height, width = out.shape
    for y in range(height):
        for x in range(width):
            value = out[y, x]
            if value == disparity[y, x]:
                continue
            low, high = bottom, top
            if not filled[y, x]:
                low = max(least[x], bottom)
                high = min(largest[x], top)
            if low <= high:
                if value < low:
                    out[y, x] = low
                elif value > high:
                    out[y, x] = high
