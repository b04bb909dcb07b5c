"""Cross-based support regions and the aggregation of a cost volume over them.

Zhang, Lu and Lafruit, *Cross-based local stereo matching using orthogonal integral
images*, IEEE TCSVT 19(7), 2009; with the arm rules of Mei et al., *On building an
accurate stereo matching system on graphics hardware* (ADCensus), ICCV workshops 2011.

Each pixel ``p`` of the left view gets four arms (left, right, up, down): an arm grows
one pixel at a time while the next pixel ``q``

1. differs from ``p`` by less than ``tau1`` in every channel, and from the pixel before it
   on the arm by less than ``tau1`` too;
2. is less than ``limit1`` pixels from ``p``;
3. beyond ``limit2`` pixels, differs from ``p`` by less than ``tau2`` (a tighter colour
   bound for long arms, so that they reach across weak texture but stop at faint edges).

The cost volume is then averaged over the horizontal arm of each pixel (a horizontal
pass) and over its vertical arm (a vertical pass); one pass after the other averages it
over the cross-shaped region: the horizontal arms of the pixels on ``p``'s vertical arm
(or, vertical first, the other way round). Each pass writes the mean rounded to the
nearest integer, computed as ``int(float32(sum) * (float32(1) / float32(count)) +
float32(0.5))`` so that a numpy twin gives the same bits (``tests/naive_cross.py``).

Volumes are ``(rows, W, Dp)`` int16 as the ``sgm`` kernels hold them; only the lanes
``k < ndisp`` are touched.
"""

import numba as nb
import numpy as np

#: Arm order in the ``(4, H, W)`` arm array.
ARM_LEFT = 0
ARM_RIGHT = 1
ARM_UP = 2
ARM_DOWN = 3


@nb.njit(cache=True)
def _colour_distance(colour, y0, x0, y1, x1):
    """Return the largest absolute difference of the channels of two pixels of ``(C, H, W)``."""
    most = 0
    for c in range(colour.shape[0]):
        d = abs(np.int32(colour[c, y0, x0]) - np.int32(colour[c, y1, x1]))
        if d > most:
            most = d
    return most


@nb.njit(cache=True)
def _arm(colour, y, x, dy, dx, limit1, limit2, tau1, tau2):
    """Length (pixels past ``(y, x)``) of the arm in direction ``(dy, dx)``."""
    height, width = colour.shape[1], colour.shape[2]
    length = 0
    while True:
        t = length + 1
        yy = y + t * dy
        xx = x + t * dx
        if t >= limit1 or yy < 0 or yy >= height or xx < 0 or xx >= width:
            break
        to_centre = _colour_distance(colour, yy, xx, y, x)
        to_previous = _colour_distance(colour, yy, xx, yy - dy, xx - dx)
        if to_centre >= tau1 or to_previous >= tau1:
            break
        if t > limit2 and to_centre >= tau2:
            break
        length = t
    return length


@nb.njit(cache=True, parallel=True)
def cross_arms(colour, limit1, limit2, tau1, tau2, arms):
    """Write the four arm lengths of every pixel of ``colour`` (``(C, H, W)``) into ``arms``.

    ``arms`` is ``(4, H, W)`` int32, in the order :data:`ARM_LEFT`, :data:`ARM_RIGHT`,
    :data:`ARM_UP`, :data:`ARM_DOWN`. Rows in parallel.
    """
    height, width = colour.shape[1], colour.shape[2]
    for y in nb.prange(height):
        for x in range(width):
            arms[0, y, x] = _arm(colour, y, x, 0, -1, limit1, limit2, tau1, tau2)
            arms[1, y, x] = _arm(colour, y, x, 0, 1, limit1, limit2, tau1, tau2)
            arms[2, y, x] = _arm(colour, y, x, -1, 0, limit1, limit2, tau1, tau2)
            arms[3, y, x] = _arm(colour, y, x, 1, 0, limit1, limit2, tau1, tau2)


@nb.njit(cache=True)
def _horizontal_row(row, before, after, ndisp, prefix):
    """Average one row ``(W, Dp)`` in place over ``x - before[x] .. x + after[x]``.

    ``prefix`` is an int32 scratch of ``(W + 1) * ndisp``.
    """
    width = row.shape[0]
    for k in range(ndisp):
        prefix[k] = 0
    for x in range(width):
        src = row[x]
        base = x * ndisp
        for k in range(ndisp):
            prefix[base + ndisp + k] = prefix[base + k] + np.int32(src[k])
    half = np.float32(0.5)
    for x in range(width):
        lo = (x - before[x]) * ndisp
        hi = (x + after[x] + 1) * ndisp
        scale = np.float32(1.0) / np.float32(before[x] + after[x] + 1)
        dst = row[x]
        for k in range(ndisp):
            dst[k] = np.int16(np.float32(prefix[hi + k] - prefix[lo + k]) * scale + half)


@nb.njit(cache=True, parallel=True)
def aggregate_horizontal(volume, arms, ndisp):
    """Average ``volume`` (``(H, W, Dp)`` int16) in place over each pixel's horizontal arm.

    ``arms`` as :func:`cross_arms` writes them for the same rows. Rows in parallel.
    """
    height, width = volume.shape[0], volume.shape[1]
    for y in nb.prange(height):
        prefix = np.empty((width + 1) * ndisp, dtype=np.int32)
        _horizontal_row(volume[y], arms[0, y], arms[1, y], ndisp, prefix)


@nb.njit(cache=True)
def _prefix_rows(volume, ndisp, prefix):
    """``prefix[y, x, k]``: the sum of ``volume[0..y, x, k]`` (int32, ``(H, W, ndisp)``)."""
    height, width = volume.shape[0], volume.shape[1]
    for x in range(width):
        src = volume[0, x]
        dst = prefix[0, x]
        for k in range(ndisp):
            dst[k] = np.int32(src[k])
    for y in range(1, height):
        for x in range(width):
            src = volume[y, x]
            above = prefix[y - 1, x]
            dst = prefix[y, x]
            for k in range(ndisp):
                dst[k] = above[k] + np.int32(src[k])


@nb.njit(cache=True, parallel=True)
def aggregate_vertical(volume, arms, ndisp, prefix):
    """Average ``volume`` (``(H, W, Dp)`` int16) in place over each pixel's vertical arm.

    ``prefix`` is an int32 scratch of ``(H, W, ndisp)`` (its running sums down the
    columns, made first, serially); then rows in parallel.
    """
    height, width = volume.shape[0], volume.shape[1]
    _prefix_rows(volume, ndisp, prefix)
    half = np.float32(0.5)
    for y in nb.prange(height):
        for x in range(width):
            up = arms[2, y, x]
            down = arms[3, y, x]
            scale = np.float32(1.0) / np.float32(up + down + 1)
            bottom = prefix[y + down, x]
            dst = volume[y, x]
            if y - up > 0:
                top = prefix[y - up - 1, x]
                for k in range(ndisp):
                    dst[k] = np.int16(np.float32(bottom[k] - top[k]) * scale + half)
            else:
                for k in range(ndisp):
                    dst[k] = np.int16(np.float32(bottom[k]) * scale + half)


@nb.njit(cache=True, parallel=True)
def aggregate_horizontal_both(volume, arms, arms_r, dmin, ndisp, reciprocals):
    """:func:`aggregate_horizontal` over the arms both views share at each disparity.

    At disparity ``d = dmin + k`` the arm of left pixel ``x`` is the shorter of its own and
    that of right pixel ``x - d`` (clamped to the image, as the costs are), each side
    (Mei et al.'s combined support). ``reciprocals[n]`` is ``float32(1) / float32(n)``.
    """
    height, width = volume.shape[0], volume.shape[1]
    half = np.float32(0.5)
    for y in nb.prange(height):
        prefix = np.empty((width + 1) * ndisp, dtype=np.int32)
        row = volume[y]
        for k in range(ndisp):
            prefix[k] = 0
        for x in range(width):
            src = row[x]
            base = x * ndisp
            for k in range(ndisp):
                prefix[base + ndisp + k] = prefix[base + k] + np.int32(src[k])
        for x in range(width):
            dst = row[x]
            for k in range(ndisp):
                xr = min(max(x - dmin - k, 0), width - 1)
                before = min(arms[0, y, x], arms_r[0, y, xr])
                after = min(arms[1, y, x], arms_r[1, y, xr])
                total = prefix[(x + after + 1) * ndisp + k] - prefix[(x - before) * ndisp + k]
                dst[k] = np.int16(np.float32(total) * reciprocals[before + after + 1] + half)


@nb.njit(cache=True, parallel=True)
def aggregate_vertical_both(volume, arms, arms_r, dmin, ndisp, reciprocals, prefix):
    """:func:`aggregate_vertical` over the arms both views share (as the horizontal pass)."""
    height, width = volume.shape[0], volume.shape[1]
    _prefix_rows(volume, ndisp, prefix)
    half = np.float32(0.5)
    for y in nb.prange(height):
        for x in range(width):
            dst = volume[y, x]
            for k in range(ndisp):
                xr = min(max(x - dmin - k, 0), width - 1)
                up = min(arms[2, y, x], arms_r[2, y, xr])
                down = min(arms[3, y, x], arms_r[3, y, xr])
                total = prefix[y + down, x, k]
                if y - up > 0:
                    total -= prefix[y - up - 1, x, k]
                dst[k] = np.int16(np.float32(total) * reciprocals[up + down + 1] + half)
