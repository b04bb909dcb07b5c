"""The kernel of the local planes (:mod:`dcstereo.refine.local_planes`).

For each pixel, the weighted sums of its window's estimates within ``tolerance`` of its
own: their offsets, their offsets' squares and products, and their differences from the
pixel's estimate times 1 and the offsets, in a fixed order (the window's rows, each summed
over its columns first in float32, their totals in float64); then the plane through them
by weighted least squares (the slopes lightly regularised), evaluated at the pixel.

A sample's weight is symmetric: pixel ``p``'s weight of its sample at offset ``o`` is
``p + o``'s of its sample at ``-o`` (the same colour difference, the same distance, the
same float32 product). So each row computes the weights of half its window's offsets
(:func:`forward_weights`: the rows below, and the same row to the right), and takes the
others from the rows above, which computed them before it: rows run in order within a band
of :data:`BAND` rows, keeping the last ``radius + 1`` rows' weights, and the bands run in
parallel (each computes the ``radius`` rows above it again). The colour factor was three
quarters of the stage's time; this halves it, the values the same bit for bit (the
kernel, one thread, AVX2: teddy 34.5 -> 24.4 ms, KITTI 000066 89 -> 63). An offset's colour
differences go to a scratch row first (as the weighted median's:
:func:`~dcstereo.refine._weighted_median.channel_differences`), then the products are made
from it: two loops of which the compiler makes tighter vector code than of the one they
were (24.4 -> 18.1 ms, 63 -> 47).
"""

import numba as nb
import numpy as np

from dcstereo._vector.sgm import next_task
from dcstereo.refine._weighted_median import BAND, band_rows, channel_differences, forward_index

#: The slopes' regularisation, per unit of weight: keeps the fit defined where the
#: window's estimates lie on a line, and leaves it the weighted mean where they are one.
RIDGE = 1e-3


@nb.njit(cache=True, inline="always")
def colour_weight(g, space, powers):
    """Return ``space * exp(-g / colour_scale)`` in float32, ``g`` (0..255) an integer.

    The product of ``powers[b]`` (``exp(-2**b / colour_scale)``) over ``g``'s bits, from
    ``space`` in the order of the bits (a table lookup would be a gather, which the
    compiler leaves scalar; as select and multiply it is vector code).
    """
    one = np.float32(1.0)
    return (
        space
        * (powers[0] if g & 1 else one) * (powers[1] if g & 2 else one)
        * (powers[2] if g & 4 else one) * (powers[3] if g & 8 else one)
        * (powers[4] if g & 16 else one) * (powers[5] if g & 32 else one)
        * (powers[6] if g & 64 else one) * (powers[7] if g & 128 else one)
    )  # fmt: skip


@nb.njit(cache=True)
def forward_weights(guide, y, radius, powers, space_weight, diff, slot):
    """Write ``slot[forward_index(dy, dx), x]``: pixel ``(y, x)``'s weight of ``(y + dy, x + dx)``.

    For the forward offsets (``dy > 0``, or ``dy == 0`` and ``dx > 0``: those after the
    centre in the window's order, :func:`~dcstereo.refine._weighted_median.forward_index`)
    whose sample lies inside the image; the other entries are left as they are (never read).
    ``diff``: int32 scratch of the width (the colour differences of an offset).
    """
    height = guide.shape[1]
    side = 2 * radius + 1
    p = (powers[0], powers[1], powers[2], powers[3], powers[4], powers[5], powers[6], powers[7])
    for dy in range(0, min(radius, height - 1 - y) + 1):
        for dx in range(1 if dy == 0 else -radius, radius + 1):
            space = np.float32(space_weight[dy + radius, dx + radius])
            a, b = channel_differences(guide, y, y + dy, dx, diff)
            dst = slot[forward_index(dy, dx, side), a:b]
            for i in range(b - a):  # branch-free, written out here: vector code
                dst[i] = colour_weight(diff[i], space, p)


@nb.njit(cache=True, parallel=True)
def local_plane_rows(disparity, guide, moved, radius, tolerance, colour_powers, space_weight,
                     out, threads=1):  # fmt: skip
    """Write into ``out`` the local plane's value at each moved pixel (the others copied).

    ``disparity`` float32 ``(H, W)`` (NaN: no estimate), ``guide`` ``(3, H, W)`` levels
    0..255, ``moved`` bool ``(H, W)``; a window sample counts when it has an estimate within
    ``tolerance`` of the pixel's, weighing ``exp(-g / colour_scale) * space_weight[dy +
    radius, dx + radius]``, ``g`` (0..255) the largest channel difference to the pixel's
    colour; ``colour_powers[b]`` is ``exp(-2**b / colour_scale)`` (b 0..7), whose product
    over ``g``'s bits is the colour factor (:func:`colour_weight`); ``space_weight`` symmetric
    about its centre (a distance's weight: the weights of ``o`` and ``-o`` are shared).

    Bands of :data:`BAND` rows handed out one at a time to ``threads`` (numba's thread
    count; default 1) as each is free; within a band the rows in order, each row's forward
    weights (:func:`forward_weights`) kept for the ``radius`` rows below it
    (:func:`plane_row`).
    """
    height, width = disparity.shape
    side = 2 * radius + 1
    half = (side * side - 1) // 2  # the forward offsets; slot[half]: the centre's weight
    slots = radius + 1
    bands = (height + BAND - 1) // BAND
    counter = np.zeros(1, dtype=np.int64)
    for _ in nb.prange(max(1, min(threads, bands))):
        ring = np.empty((slots, half + 1, width), dtype=np.float32)
        for s in range(slots):  # g = 0: the product of ones, the distance's weight alone
            ring[s, half, :] = np.float32(space_weight[radius, radius])
        sums = np.zeros((9, width))  # w, w dx, w dy, w dx2, w dx dy, w dy2, w r, w r dx, w r dy
        # one window row's sums: w, w dx, w dx2, w r, w r dx (1-D arrays: their slices
        # stay contiguous for the compiler, which makes vector code of them)
        parts = np.zeros((5, width), dtype=np.float32)
        diff = np.empty(width, dtype=np.int32)
        band = next_task(counter)
        while band < bands:
            first, y0, stop = band_rows(band, radius, height)
            for y in range(first, stop):
                forward_weights(
                    guide, y, radius, colour_powers, space_weight, diff, ring[y % slots]
                )
                if y >= y0:
                    plane_row(disparity, moved, radius, tolerance, ring, y, sums, parts, out)
            band = next_task(counter)


@nb.njit(cache=True)
def plane_row(disparity, moved, radius, tolerance, ring, y, sums, parts, out):
    """Write row ``y`` of :func:`local_plane_rows`, its weights from ``ring``.

    ``ring[t % (radius + 1)]`` holds row ``t``'s forward weights (:func:`forward_weights`)
    for rows ``y - radius .. y``, and the centre's weight at ``[.., half]``. Pixel ``x``'s
    weight of its sample at a forward offset ``o`` is its own row's; at ``-o``, the one
    row ``y - dy`` gave pixel ``x - dx`` for ``o``. For each row of the window, the sums
    over its columns first (of ``w``, ``w dx``, ``w dx**2``, ``w r``, ``w r dx``, ``r``
    the difference from the pixel's estimate), over slices that start at the first column
    inside the image (vector code), then the row's share of the nine sums of
    :func:`plane_offset`.
    """
    height, width = disparity.shape
    zero, tol = np.float32(0.0), np.float32(tolerance)
    side = 2 * radius + 1
    slots = radius + 1
    half = (side * side - 1) // 2
    sums[:, :] = 0
    p0, p1, p2, p3, p4 = parts[0], parts[1], parts[2], parts[3], parts[4]
    for dy in range(-radius, radius + 1):
        yy = y + dy
        if yy < 0 or yy >= height:
            continue
        parts[:, :] = 0
        for dx in range(-radius, radius + 1):
            fx = np.float32(dx)
            fxx = fx * fx
            a, b = max(0, -dx), min(width, width - dx)  # the pixels, their samples + dx
            row, centre = disparity[yy, a + dx : b + dx], disparity[y, a:b]
            if dy == 0 and dx == 0:
                weight = ring[y % slots, half, a:b]
            elif dy > 0 or (dy == 0 and dx > 0):  # this row's own
                weight = ring[y % slots, forward_index(dy, dx, side), a:b]
            else:  # the sample's, for the opposite offset
                weight = ring[yy % slots, forward_index(-dy, -dx, side), a + dx : b + dx]
            w_sum, wx_sum, wxx_sum = p0[a:b], p1[a:b], p2[a:b]
            wr_sum, wrx_sum = p3[a:b], p4[a:b]
            for i in range(b - a):  # branch-free, written out here: vector code
                r = row[i] - centre[i]
                near = abs(r) <= tol  # NaN on either side: False
                w = weight[i] if near else zero
                wr = w * r if near else zero
                w_sum[i] += w
                wx_sum[i] += fx * w
                wxx_sum[i] += fxx * w
                wr_sum[i] += wr
                wrx_sum[i] += fx * wr
        fy = np.float64(dy)
        for x in range(width):
            w, wx, wxx = np.float64(p0[x]), np.float64(p1[x]), np.float64(p2[x])
            wr, wrx = np.float64(p3[x]), np.float64(p4[x])
            sums[0, x] += w
            sums[1, x] += wx
            sums[2, x] += fy * w
            sums[3, x] += wxx
            sums[4, x] += fy * wx
            sums[5, x] += fy * fy * w
            sums[6, x] += wr
            sums[7, x] += wrx
            sums[8, x] += fy * wr
    centre = disparity[y]
    for x in range(width):
        out[y, x] = centre[x]
        if moved[y, x] and sums[0, x] > 0:
            offset = plane_offset(
                sums[0, x], sums[1, x], sums[2, x], sums[3, x], sums[4, x], sums[5, x],
                sums[6, x], sums[7, x], sums[8, x],
            )  # fmt: skip
            out[y, x] = np.float32(np.float64(centre[x]) + offset)


@nb.njit(cache=True)
def plane_offset(s0, sx, sy, sxx, sxy, syy, sr, sxr, syr):
    """Return the value at offset 0 of the weighted least-squares plane of the sums.

    ``r = a dx + b dy + c`` fitted to the samples whose weighted sums are given (``s0``:
    the weights; ``sx``: of ``w dx``; ... ``syr``: of ``w dy r``); the slopes' normal
    equations about the weighted mean offset, with :data:`RIDGE` ``* s0`` added to their
    diagonal, then ``c`` = the mean of ``r`` less the slopes times the mean offsets.
    """
    mx, my, mr = sx / s0, sy / s0, sr / s0
    cxx = sxx - sx * mx + RIDGE * s0
    cyy = syy - sy * my + RIDGE * s0
    cxy = sxy - sx * my
    cxr = sxr - sx * mr
    cyr = syr - sy * mr
    det = cxx * cyy - cxy * cxy
    a = (cyy * cxr - cxy * cyr) / det
    b = (cxx * cyr - cxy * cxr) / det
    return mr - a * mx - b * my
