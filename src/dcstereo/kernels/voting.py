"""Kernels of :mod:`dcstereo.voting`: cross-based support regions and region voting.

ADCensus (Mei et al. 2011, section 2.4): each pixel's support region is built from
crosses; the arms of a pixel ``p`` stretch along a direction while the next pixel ``q``
(and the one before it) stays within ``tau1`` of ``p``'s colour (largest channel
difference), at most ``l1`` pixels, and past ``l2`` pixels only within the stricter
``tau2``. The region of ``p`` is the union of the horizontal arms of the pixels on
``p``'s vertical arm.

:func:`vote_rows`: a pixel to refine takes the disparity most of the trusted estimates of
its region vote for (rounded to whole pixels, the mean of that bin's values), when they are
more than ``min_votes`` and the bin holds more than ``min_share`` of them. One pass reads
``disparity`` and writes ``out`` (Jacobi): rows in parallel give the same result.
"""

import numba as nb
import numpy as np


@nb.njit(cache=True)
def _arm(colour, y, x, dy, dx, tau1, tau2, l1, l2):
    """Length of the arm of ``(y, x)`` along ``(dy, dx)`` (0: not even one step)."""
    channels, height, width = colour.shape
    length = 0
    y, x = np.int64(y), np.int64(x)  # a prange index may be unsigned
    py, px = y, x
    while length < l1:
        qy, qx = py + dy, px + dx
        if not (0 <= qy < height and 0 <= qx < width):
            break
        to_p = 0
        to_prev = 0
        for c in range(channels):
            to_p = max(to_p, abs(np.int64(colour[c, qy, qx]) - np.int64(colour[c, y, x])))
            to_prev = max(to_prev, abs(np.int64(colour[c, qy, qx]) - np.int64(colour[c, py, px])))
        limit = tau2 if length + 1 > l2 else tau1
        if to_p >= limit or to_prev >= tau1:
            break
        length += 1
        py, px = qy, qx
    return length


@nb.njit(cache=True, parallel=True)
def cross_arms(colour, tau1, tau2, l1, l2, arms):
    """Arms of every pixel into ``arms`` (``(4, H, W)`` int32: left, right, up, down)."""
    channels, height, width = colour.shape
    for y in nb.prange(height):
        for x in range(width):
            arms[0, y, x] = _arm(colour, y, x, 0, -1, tau1, tau2, l1, l2)
            arms[1, y, x] = _arm(colour, y, x, 0, 1, tau1, tau2, l1, l2)
            arms[2, y, x] = _arm(colour, y, x, -1, 0, tau1, tau2, l1, l2)
            arms[3, y, x] = _arm(colour, y, x, 1, 0, tau1, tau2, l1, l2)


@nb.njit(cache=True, parallel=True)
def vote_rows(disparity, trusted, todo, arms, low, nbins, min_votes, min_share, out, done):
    """One pass of region voting: see the module's text.

    ``disparity`` float32 (NaN: no estimate); ``trusted``: the estimates that vote;
    ``todo``: the pixels to refine; bins are ``round(d) - low`` for ``0..nbins-1``.
    ``out`` gets the new map, ``done`` True where a pixel took a vote.
    """
    height, width = disparity.shape
    for y in nb.prange(height):
        counts = np.zeros(nbins, dtype=np.int64)
        sums = np.zeros(nbins, dtype=np.float64)
        for x in range(width):
            out[y, x] = disparity[y, x]
            done[y, x] = False
            if not todo[y, x]:
                continue
            counts[:] = 0
            sums[:] = 0.0
            total = 0
            for yy in range(y - arms[2, y, x], y + arms[3, y, x] + 1):
                for xx in range(x - arms[0, yy, x], x + arms[1, yy, x] + 1):
                    if not trusted[yy, xx]:
                        continue
                    d = disparity[yy, xx]
                    b = int(np.floor(d + 0.5)) - low
                    if 0 <= b < nbins:
                        counts[b] += 1
                        sums[b] += d
                        total += 1
            if total <= min_votes:
                continue
            best = 0
            for b in range(1, nbins):
                if counts[b] > counts[best]:
                    best = b
            if counts[best] > min_share * total:
                out[y, x] = np.float32(sums[best] / counts[best])
                done[y, x] = True
